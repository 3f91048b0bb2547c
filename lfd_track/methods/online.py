"""The ``online`` method: a learner learns while the scripted human demonstrates; the policy
takes over when it agrees, and the human takes control back by the intervention rule.

With ``learner = "ga"`` (the default) the GA runs ``generations_per_case`` ask/tell generations
per new case; with ``learner = "bc"`` backprop (the benchmark's ``bc`` settings) runs
``epochs_per_case`` Adam epochs per new case on all cases so far, warm-started from the current
weights. Once the policy agreed with the human on at least ``threshold`` of the last ``window``
commands it drives, and the human watches, taking control back by the intervention rule
(:class:`~lfd_track.teaching.scripted.InterventionConfig`); corrections are flagged cases and
learned like the rest. The controller is the GA's best individual of the run, or the ``bc``
fit on all cases at the end (the network ``hg-dagger`` with learner ``"bc"`` writes for the
same cases). The learning time of ``"bc"`` per repetition is timed by
``benchmarks/speed/bench_budget.py``.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.recording import recording_writer
from ..demo.demonstrator import protocol_human
from ..learning.fitness import training_accuracy
from ..learning.ga import ga_rescore, ga_result
from ..learning.learners import learner_for
from ..policy.controller import Controller
from ..policy.mlp import N_HIDDEN
from ..teaching.arbiter import Arbiter
from ..teaching.commanders import PolicyCommander
from ..teaching.learner_feed import BCLearnerFeed, GALearnerFeed
from ..teaching.loop import TeachingLoop
from ..teaching.observers import LearningTally, Recorder
from ..teaching.perception import Perception
from ..vision.road_library import RoadLibrary
from . import baseline, common
from .common import Learned, MethodContext, effort_record, recording_metadata, training_set
from .takeover import TakeoverConfig

ONLINE_LEARNERS = ("ga", "bc")
"""What learns while the human demonstrates in ``online``: the paper's GA or backprop."""


@dataclass(frozen=True)
class OnlineConfig(TakeoverConfig):
    """Settings of the ``online`` method (learning during the demonstration, with takeover)."""

    settings_name = "online"

    generations_per_case: int = 2
    """With learner ``"ga"``: GA generations (ask/tell, population re-scored on all cases so
    far) after each new case (1..10 000)."""
    learner: str = "ga"
    """What learns while the human demonstrates: ``"ga"`` (the paper's GA, the benchmark's
    ``ga`` settings) or ``"bc"`` (backprop, the benchmark's ``bc`` settings, with mirrored cases
    as the benchmark says; an MLP only). ``"bc"`` is the learner of the goal taught by the
    paper's human model (``benchmarks/experiments/human_goal/round03/``); online with it is a
    candidate of ``benchmarks/experiments/human_goal/round04/selection_round4.toml``, timed per
    repetition by ``benchmarks/speed/bench_budget.py``."""
    epochs_per_case: int = 20
    """With learner ``"bc"``: full-batch Adam epochs on all cases so far after each new case,
    continuing from the current weights (1..10 000). With 20 a repetition of the human-taught
    goal's configuration learns in about half a second of one core, the refits and the final fit
    together, and one refit takes a few milliseconds (``benchmarks/speed/bench_budget.py``; the
    budget is 60 s per repetition)."""

    def to_dict(self) -> dict[str, Any]:
        """The settings as a dict; ``learner`` and ``epochs_per_case`` only when the learner is
        not ``"ga"`` (what every run did before the setting existed), so that files written
        before it still match theirs."""
        data = super().to_dict()
        if data["learner"] == "ga":
            del data["learner"], data["epochs_per_case"]
        return data

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("generations_per_case", 10_000)
        self._check_count("epochs_per_case", 10_000)
        if self.learner not in ONLINE_LEARNERS:
            raise ValueError(
                f"online learner must be one of {', '.join(ONLINE_LEARNERS)}, got {self.learner!r}"
            )
        # Each count is the other learner's no-op: refused rather than silently unused.
        defaults = OnlineConfig.__dataclass_fields__
        unused = "epochs_per_case" if self.learner == "ga" else "generations_per_case"
        if getattr(self, unused) != defaults[unused].default:
            wanted = "bc" if self.learner == "ga" else "ga"
            raise ValueError(f"online {unused} is for learner '{wanted}'")


def learn(context: MethodContext) -> Learned:
    """Demonstrate on ``context.track`` while the learner learns; the policy takes over when it
    agrees.

    The protocol, the human's random stream and the env seed are the paper's (same
    ``demo_seed``); the cases, including flagged corrections, are written to
    ``rep_dir/demonstration.lfdemo`` (the footer lists the correction case indices). With
    learner ``"bc"`` the weights the policy drives with start from a draw of the generator
    ``[ga_seed, 1]``; the controller is the ``bc`` fit on all cases with the generator
    ``ga_seed``, as the ``bc`` method fits its demonstration.
    """
    online: OnlineConfig = context.settings
    ga, human, memory, features = context.ga, context.human, context.memory, context.features
    if online.learner == "bc" and context.policy_kind != "mlp-sigmoid":
        raise ValueError("online learner 'bc' fits an MLP (policy_kind 'mlp-sigmoid')")
    rng = np.random.default_rng(context.demo_seed)
    env_seed = int(rng.integers(2**31 - 1))
    env = common.track_env(context, max_steps=10**9, continue_after_end=True)
    person = protocol_human(
        context.track,
        human,
        rng,
        intervention=online.intervention,
        rover=env.preset.rover,
        memory=memory,
    )
    library = RoadLibrary()
    perception = Perception(
        library,
        "careful" if human.careful else "always",
        memory,
        features,
        geometry=context.map_geometry,
    )
    policy = PolicyCommander(None, hidden=context.bc.hidden if online.learner == "bc" else N_HIDDEN)
    feed: GALearnerFeed | BCLearnerFeed
    if online.learner == "ga":
        feed = GALearnerFeed(
            ga,
            np.random.default_rng(context.ga_seed),
            online.generations_per_case,
            policy,
            perception.n_inputs,
            training_set=lambda x, a: training_set(context, x, a),
        )
    else:
        feed = BCLearnerFeed(
            context.bc,
            np.random.default_rng([context.ga_seed, 1]),
            online.epochs_per_case,
            policy,
            perception.n_inputs,
            training_set=lambda x, a: training_set(context, x, a),
        )
    preset = context.preset
    metadata = recording_metadata(
        "online",
        library,
        track=context.track,
        seed=context.demo_seed,
        env_seed=env_seed,
        preset=preset if isinstance(preset, str) else preset.name,
        human=dataclasses.asdict(human),
        online=online.to_dict(),
    )
    path = context.rep_dir / "demonstration.lfdemo"
    tally = LearningTally()
    with recording_writer(path, metadata, perception, fsync=False, overwrite=True) as w:
        recorder = Recorder(
            w,
            lambda step: {
                "pose": step.moment.pose,
                "progress_m": person.progress_m,
                "phase": "correction" if step.decision.correction else person.phase,
                "step": step.moment.step,
            },
        )
        loop = TeachingLoop(
            env,
            perception,
            Arbiter("takeover", window=online.window, threshold=online.threshold),
            human=person,
            policy=policy,
            observers=[recorder, feed, tally],
            stop_on_episode_end=False,
        )
        loop.reset(seed=env_seed)
        loop.run(max_steps=human.max_commands)
        x, a = feed.cases.arrays()
        corrections = [i for i, c in enumerate(feed.cases.corrections) if c]
        w.close(
            {
                "road_library": library.to_dict(),
                "turnarounds": person.turnarounds,
                "library_models": library.n_models,
                "library_types": library.n_types,
                "commands": loop.counts.steps,
                "correction_cases": corrections,
                "interventions": dict(person.interventions),
            }
        )
    env.close()
    if isinstance(feed, GALearnerFeed):
        state = ga_rescore(feed.state, *feed.training_set(x, a), ga)  # the best on every case
        result = ga_result(state, ga, feed.rng_state)
        learned = Controller.from_evolution(
            library,
            result,
            seed=context.ga_seed,
            memory=memory,
            features=features,
            frame_size=context.frame_size,
            map_geometry=context.map_geometry,
        )
        settings = {"ga": ga.to_dict()}
        fitness_best, fitness_mean = list(state.best_history), list(state.mean_history)
        steps = {"generations": state.generation}
    else:
        fit = learner_for(context.bc).fit(
            *training_set(context, x, a), np.random.default_rng(context.ga_seed)
        )
        learned = baseline.controller_of_fit(context, library, fit, context.bc)
        settings = {"bc": context.bc.to_dict()}
        fitness_best, fitness_mean = fit.history.tolist(), []
        steps = {"epochs_while_teaching": feed.generation}
    controller = learned.relabelled("online", {**online.to_dict(), **settings})
    counts = np.bincount(a, minlength=3)
    return Learned(
        controller=controller,
        demo={
            "cases": int(len(a)),
            "counts": {"forward": int(counts[0]), "left": int(counts[1]), "right": int(counts[2])},
            "turnarounds": list(person.turnarounds),
            "library_models": library.n_models,
            "library_types": library.n_types,
            "learned_off_felt": tally.learned_off_felt,
            "off_felt_frames": tally.off_felt,
            "correction_cases": len(corrections),
            "interventions": dict(person.interventions),
            **steps,
        },
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=training_accuracy(controller.weights, x, a, hidden=controller.hidden),
        effort=effort_record(float(env.preset.rover.control_period_s), counts=loop.counts),
    )


def learn_online(rep_dir: str | Path, *, online: OnlineConfig, **context: Any) -> Learned:
    """:func:`learn` with the settings ``online`` and the context's fields as keywords
    (:class:`~lfd_track.methods.common.MethodContext`)."""
    return learn(MethodContext(Path(rep_dir), settings=online, **context))


# ------------------------------------------------------------------------------- command line
def add_flags(parser: argparse.ArgumentParser) -> None:
    """The ``online`` flag of ``lfd-track benchmark``."""
    parser.add_argument(
        "--online-learner",
        choices=ONLINE_LEARNERS,
        default=None,
        help="with --method online: what learns while the human demonstrates, the GA or backprop"
        " (the bc method's settings, warm-started after each case; default: ga)",
    )


def flags_given(args: argparse.Namespace) -> list[str]:
    """The ``online`` flags given on the command line."""
    return ["--online-learner"] if args.online_learner is not None else []


def settings_from_flags(args: argparse.Namespace) -> OnlineConfig:
    """The ``online`` settings of the command line's flags."""
    return OnlineConfig(learner=args.online_learner or "ga")
