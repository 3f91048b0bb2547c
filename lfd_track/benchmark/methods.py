"""How a repetition learns its controller: the paper's offline pipeline, or interactive methods.

Every method is an arrangement of the teaching loop (:mod:`lfd_track.teaching`) and ends with a
controller plus a record of the human's effort, counted the same way for every method:

* ``commands`` — commands the human gave (demonstration, library-only ones included, and
  corrections / interventions; for ``dagger`` every label, executed or not);
* ``corrections`` — times the human took control back from a driving policy;
* ``takeovers`` — times the policy took control;
* ``learning_drive_s`` — simulated seconds the robot drove while learning (whoever drove);
* ``autonomous_drive_s`` — of those, the seconds the policy drove.

Methods:

* ``paper`` — demonstration, then the GA offline (the paper, §4.2.5).
* ``online`` — the GA runs ``generations_per_case`` ask/tell generations per new case while the
  scripted human demonstrates; once the policy agreed with the human on at least ``threshold`` of
  the last ``window`` commands it drives, and the human watches, taking control back by the
  intervention rule (:class:`~lfd_track.teaching.scripted.InterventionConfig`); corrections are
  flagged cases and learned like the rest. The controller is the best individual of the run.
* ``bc`` / ``cma-es`` — the paper's demonstration, then the same network fitted to its cases by
  backprop (:func:`~lfd_track.learning.bc.fit_bc`) or by CMA-ES on Algorithm 3
  (:func:`~lfd_track.learning.cmaes.fit_cmaes`) instead of the GA.
* ``hg-dagger`` — the paper's demonstration and GA, then ``rounds`` rounds of autonomous runs on
  the training track (one each way) with the human intervening by the same rule; the
  interventions of every round are aggregated and the GA re-run on all cases after each round.
* ``dagger`` — classic DAgger (:mod:`lfd_track.benchmark.dagger`): the paper's demonstration and
  a first fit (GA or backprop, optionally a wider hidden layer), then ``rounds`` rounds of runs
  like HG-DAgger's where the human labels *every* visited state (noise-free by default) and the
  learner is re-fitted on all cases after each round.

"The training track" above is the paper's unless a method is given another open ``track``
(``BenchmarkConfig.demo_track``): the human then demonstrates, and HG-DAgger's rounds drive,
there instead.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..core.commands import Command
from ..core.config import DictConfig
from ..dataset import Demonstration, load_demonstration
from ..dataset.recording import recording_writer
from ..demo.demonstrator import (
    DemonstrationSummary,
    HumanConfig,
    protocol_human,
    run_demonstration,
)
from ..demo.views import ViewCases
from ..envs.presets import Preset
from ..envs.track_env import LfDTrackEnv
from ..learning.bc import BCConfig
from ..learning.cmaes import CMAESConfig
from ..learning.elman import episode_starts, evolve_elman, fit_bc_elman, sequence_accuracy
from ..learning.fitness import training_accuracy
from ..learning.ga import GAConfig, evolve, ga_rescore, ga_result
from ..learning.learners import learner_for
from ..learning.mirror import with_mirrored
from ..learning.result import check_int
from ..policy.controller import Controller
from ..policy.features import DEFAULT_FEATURES
from ..policy.memory import MemoryConfig
from ..teaching.arbiter import Arbiter
from ..teaching.commanders import PolicyCommander
from ..teaching.learner_feed import GALearnerFeed
from ..teaching.loop import LoopCounts, TeachingLoop
from ..teaching.observers import CaseBuffer, LearningTally, Recorder
from ..teaching.perception import Perception
from ..teaching.scripted import InterventionConfig, ProtocolHuman
from ..vision.road_library import RoadLibrary
from ..world.track import load_track

METHODS = ("paper", "online", "hg-dagger", "bc", "cma-es", "dagger")
#: The methods that learn after one simulated demonstration, so can learn from its shifted and
#: turned views (:mod:`lfd_track.demo.views`).
VIEW_METHODS = ("paper", "bc", "cma-es")
#: The methods that train an Elman network: the GA (``paper``) and backprop through time (``bc``).
ELMAN_METHODS = ("paper", "bc")


@dataclass(frozen=True)
class TakeoverConfig(DictConfig):
    """What ``online`` and ``hg-dagger`` share: when the policy may drive, when the human steps in."""

    window: int = 10
    """K: the agreement is measured over the human's last K commands (1..10 000)."""
    threshold: float = 0.9
    """Share of those K the policy must have agreed with to drive (9 of 10 by default)."""
    intervention: InterventionConfig = field(default_factory=InterventionConfig)
    """When the watching human takes control (back)."""

    def _check_count(self, name: str, maximum: int) -> None:
        """The setting ``name`` must be an integer in 1..maximum (the error names the method)."""
        check_int(f"{self.settings_name} {name}", getattr(self, name), 1, maximum)

    def __post_init__(self) -> None:
        self._check_count("window", 10_000)
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f"{self.settings_name} threshold must be in (0, 1]")


@dataclass(frozen=True)
class OnlineConfig(TakeoverConfig):
    """Settings of the ``online`` method (evolution during the demonstration, with takeover)."""

    settings_name = "online"

    generations_per_case: int = 2
    """GA generations (ask/tell, population re-scored on all cases so far) after each new case
    (1..10 000)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("generations_per_case", 10_000)


@dataclass(frozen=True)
class HGDaggerConfig(TakeoverConfig):
    """Settings of the ``hg-dagger`` method (rounds of autonomous runs with interventions; after
    an intervention the policy drives again once it agreed on the last ``window``)."""

    settings_name = "hg-dagger"

    rounds: int = 3
    """R: rounds of autonomous runs, each followed by re-evolving on all cases (1..1000)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("rounds", 1_000)


@dataclass
class Learned:
    """What the learning part of a repetition produced."""

    controller: Controller
    demo: dict[str, Any]
    """Demonstration summary (cases, counts, library …) for results.json."""
    fitness_best: list[float]
    fitness_mean: list[float]
    training_accuracy: float
    effort: dict[str, Any]
    """Human effort and robot driving during learning (see the module docstring)."""


def effort_record(counts: LoopCounts, period_s: float, **extra: Any) -> dict[str, Any]:
    """The effort fields of results.json from a loop's counts (``period_s``: one command [s])."""
    return {
        "commands": counts.human_commands,
        "corrections": counts.corrections,
        "takeovers": counts.takeovers,
        "learning_drive_s": round(counts.steps * period_s, 6),
        "autonomous_drive_s": round(counts.policy_commands * period_s, 6),
        **extra,
    }


def _add(total: LoopCounts, part: LoopCounts) -> None:
    for f in dataclasses.fields(LoopCounts):
        setattr(total, f.name, getattr(total, f.name) + getattr(part, f.name))


# ------------------------------------------------------------------------------------ paper
def _demonstrate(
    rep_dir: Path,
    *,
    demo_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    memory: MemoryConfig | None = None,
    track: str = "training",
    shifted_views: bool = False,
) -> tuple[DemonstrationSummary, Demonstration, RoadLibrary, ViewCases | None]:
    """Record the paper's demonstration on ``track`` in ``rep_dir``; (summary, cases, library,
    views): the shifted and turned views of every case with ``shifted_views``, else None."""
    views = ViewCases() if shifted_views else None
    demo_path = rep_dir / "demonstration.lfdemo"
    summary = run_demonstration(
        demo_path,
        seed=demo_seed,
        track=track,
        preset=preset,
        human=human,
        fsync=False,
        overwrite=True,
        memory=memory,
        views=views,
    )
    demo = load_demonstration(demo_path)
    return summary, demo, RoadLibrary.from_dict(demo.metadata["road_library"]), views


def _learned_offline(
    summary: DemonstrationSummary,
    demo: Demonstration,
    controller: Controller,
    preset: str | Preset,
    *,
    fitness_best: list[float],
    fitness_mean: list[float],
    extra: dict[str, Any] | None = None,
) -> Learned:
    """What a repetition that learns after one demonstration (no robot driving) produced."""
    return Learned(
        controller=controller,
        demo={
            "cases": summary.n_cases,
            "counts": summary.counts,
            "turnarounds": list(summary.turnarounds),
            "library_models": summary.library_models,
            "library_types": summary.library_types,
            "learned_off_felt": summary.learned_off_felt,
            **(extra or {}),
        },
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=_accuracy(controller, demo),
        effort={
            "commands": summary.commands,
            "corrections": 0,
            "takeovers": 0,
            "learning_drive_s": round(summary.commands * _period_s(preset), 6),
            "autonomous_drive_s": 0.0,
        },
    )


def _accuracy(controller: Controller, demo: Demonstration) -> float:
    """Share of a demonstration's cases whose command the controller's network would give (an
    Elman network run over the cases in order, its context from 0)."""
    x = demo.policy_inputs(controller.features)
    if controller.policy_kind == "elman-sigmoid":
        starts = episode_starts(len(demo.commands))
        return sequence_accuracy(controller.weights, x, demo.commands, starts, bias=controller.bias)
    return training_accuracy(controller.weights, x, demo.commands)


def _episodes(demo: Demonstration, mirror: bool) -> list[int]:
    """The episodes an Elman network is fitted over: the demonstration's cases in order, one
    episode (the rover drives on through the turn-arounds), then its mirror image as another."""
    return [demo.n_cases] * (2 if mirror else 1)


def learn_paper(
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    ga: GAConfig,
    memory: MemoryConfig | None = None,
    mirror: bool = False,
    track: str = "training",
    features: str = DEFAULT_FEATURES,
    shifted_views: bool = False,
    policy_kind: str = "mlp-sigmoid",
) -> Learned:
    """The paper: record a demonstration, then evolve offline (200 generations by default).

    ``mirror``: learn from the cases and their mirror images (:mod:`lfd_track.learning.mirror`).
    ``features``: the per-region inputs (:mod:`lfd_track.policy.features`), computed from the
    recorded histograms. ``shifted_views``: learn also from the shifted and turned views of
    every case (:mod:`lfd_track.demo.views`; mirrored too with ``mirror``). ``policy_kind``
    ``"elman-sigmoid"``: evolve an Elman network over the cases in order
    (:func:`~lfd_track.learning.elman.evolve_elman`; not with ``shifted_views``).
    """
    summary, demo, library, views, (x, a) = _offline_cases(
        rep_dir,
        demo_seed=demo_seed,
        preset=preset,
        human=human,
        memory=memory,
        mirror=mirror,
        track=track,
        features=features,
        shifted_views=shifted_views,
        policy_kind=policy_kind,
    )
    rng = np.random.default_rng(ga_seed)
    if policy_kind == "elman-sigmoid":
        result = evolve_elman(x, a, ga, rng, episodes=_episodes(demo, mirror))
    else:
        result = evolve(x, a, ga, rng)
    controller = Controller.from_evolution(
        library, result, seed=ga_seed, memory=memory, features=features, policy_kind=policy_kind
    )
    return _learned_offline(
        summary,
        demo,
        controller,
        preset,
        fitness_best=result.best_history.tolist(),
        fitness_mean=result.mean_history.tolist(),
        extra=_views_record(views),
    )


def learn_baseline(
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    learner: BCConfig | CMAESConfig,
    memory: MemoryConfig | None = None,
    mirror: bool = False,
    track: str = "training",
    features: str = DEFAULT_FEATURES,
    shifted_views: bool = False,
    policy_kind: str = "mlp-sigmoid",
) -> Learned:
    """The paper's demonstration, then BC or CMA-ES instead of the GA (same cases, same seed;
    ``shifted_views`` as for :func:`learn_paper`). ``policy_kind`` ``"elman-sigmoid"``: BC
    trains an Elman network by backpropagation through time
    (:func:`~lfd_track.learning.elman.fit_bc_elman`; CMA-ES does not train this kind)."""
    if policy_kind == "elman-sigmoid" and not isinstance(learner, BCConfig):
        raise ValueError("an Elman network is trained by the GA or by backprop, not CMA-ES")
    summary, demo, library, views, (x, a) = _offline_cases(
        rep_dir,
        demo_seed=demo_seed,
        preset=preset,
        human=human,
        memory=memory,
        mirror=mirror,
        track=track,
        features=features,
        shifted_views=shifted_views,
        policy_kind=policy_kind,
    )
    trainer = learner_for(learner)
    rng = np.random.default_rng(ga_seed)
    if policy_kind == "elman-sigmoid":
        result = fit_bc_elman(x, a, learner, rng, episodes=_episodes(demo, mirror))
    else:
        result = trainer.fit(x, a, rng)
    controller = Controller(
        library,
        result.weights,
        bias=learner.bias,
        learner=trainer.name,
        learner_config=learner.to_dict(),
        seed=ga_seed,
        fitness_history=result.history.tolist(),
        memory=memory,
        features=features,
        policy_kind=policy_kind,
    )
    return _learned_offline(
        summary,
        demo,
        controller,
        preset,
        fitness_best=result.history.tolist(),
        fitness_mean=[],
        extra={"learner": result.learner, **_views_record(views)},
    )


def _offline_cases(
    rep_dir: Path,
    *,
    demo_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    memory: MemoryConfig | None,
    mirror: bool,
    track: str,
    features: str,
    shifted_views: bool,
    policy_kind: str,
) -> tuple[
    DemonstrationSummary,
    Demonstration,
    RoadLibrary,
    ViewCases | None,
    tuple[np.ndarray, np.ndarray],
]:
    """Record the demonstration (with its views if ``shifted_views``) and make what an offline
    learner fits from it: (summary, cases, library, views, (inputs, commands))."""
    if policy_kind == "elman-sigmoid" and shifted_views:
        # An Elman network learns from cases in the order they were driven: views have none.
        raise ValueError(
            "shifted views have no place in a driven sequence: not with an Elman network"
        )
    summary, demo, library, views = _demonstrate(
        rep_dir,
        demo_seed=demo_seed,
        preset=preset,
        human=human,
        memory=memory,
        track=track,
        shifted_views=shifted_views,
    )
    cases = _training_set(*_cases(demo, views, features), memory, mirror, features)
    return summary, demo, library, views, cases


def _cases(
    demo: Demonstration, views: ViewCases | None, features: str
) -> tuple[np.ndarray, np.ndarray]:
    """A demonstration's cases (inputs, commands), followed by its views when there are any."""
    x, a = demo.policy_inputs(features), demo.commands
    if views is None or not len(views):
        return x, a
    return (
        np.concatenate([x, views.policy_inputs(features)]),
        np.concatenate([np.asarray(a, dtype=np.int64), views.commands]),
    )


def _views_record(views: ViewCases | None) -> dict[str, Any]:
    """What a repetition records of its views: their number per label (nothing without)."""
    if views is None:
        return {}
    counts = np.bincount(views.commands, minlength=len(Command))
    return {"views": {c.name.lower(): int(counts[c]) for c in Command}}


def _training_set(
    inputs: np.ndarray,
    actions: np.ndarray,
    memory: MemoryConfig | None,
    mirror: bool,
    features: str = DEFAULT_FEATURES,
) -> tuple[np.ndarray, np.ndarray]:
    """What a learner fits: the cases, followed by their mirror images when ``mirror``."""
    if not mirror:
        return inputs, actions
    return with_mirrored(inputs, actions, memory, features)


def _relabel(controller: Controller, learner: str, config: dict[str, Any]) -> Controller:
    """The same controller, recording ``learner`` and its settings ``config``."""
    return Controller(
        controller.library,
        controller.weights,
        bias=controller.bias,
        learner=learner,
        learner_config=config,
        seed=controller.seed,
        fitness_history=controller.fitness_history,
        memory=controller.memory,
        features=controller.features,
    )


def _period_s(preset: str | Preset) -> float:
    from ..envs.presets import load_preset

    p = preset if isinstance(preset, Preset) else load_preset(preset)
    return float(p.rover.control_period_s)


# ------------------------------------------------------------------------------------ online
def learn_online(
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    ga: GAConfig,
    online: OnlineConfig,
    memory: MemoryConfig | None = None,
    mirror: bool = False,
    track: str = "training",
    features: str = DEFAULT_FEATURES,
) -> Learned:
    """Demonstrate on ``track`` while the GA learns; the policy takes over when it agrees.

    The protocol, the human's random stream and the env seed are the paper's (same
    ``demo_seed``); the cases, including flagged corrections, are written to
    ``rep_dir/demonstration.lfdemo`` (the footer lists the correction case indices).
    """
    rng = np.random.default_rng(demo_seed)
    env_seed = int(rng.integers(2**31 - 1))
    env = LfDTrackEnv(track=track, preset=preset, max_steps=10**9, continue_after_end=True)
    person = protocol_human(
        track, human, rng, intervention=online.intervention, rover=env.preset.rover, memory=memory
    )
    library = RoadLibrary()
    perception = Perception(library, "careful" if human.careful else "always", memory, features)
    policy = PolicyCommander(None)
    feed = GALearnerFeed(
        ga,
        np.random.default_rng(ga_seed),
        online.generations_per_case,
        policy,
        perception.n_inputs,
        training_set=lambda x, a: _training_set(x, a, memory, mirror, features),
    )
    metadata = {
        "kind": "simulated",
        "method": "online",
        "track": track,
        "seed": demo_seed,
        "env_seed": env_seed,
        "preset": preset if isinstance(preset, str) else preset.name,
        "human": dataclasses.asdict(human),
        "online": online.to_dict(),
        "bins": library.bins,
    }
    path = rep_dir / "demonstration.lfdemo"
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
        state = ga_rescore(feed.state, *feed.training_set(x, a), ga)  # the best on every case
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
    result = ga_result(state, ga, feed.rng_state)
    controller = _relabel(
        Controller.from_evolution(library, result, seed=ga_seed, memory=memory, features=features),
        "online",
        {**online.to_dict(), "ga": ga.to_dict()},
    )
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
            "generations": state.generation,
        },
        fitness_best=list(state.best_history),
        fitness_mean=list(state.mean_history),
        training_accuracy=training_accuracy(state.best_weights, x, a),
        effort=effort_record(loop.counts, float(env.preset.rover.control_period_s)),
    )


# ------------------------------------------------------------------------------------ hg-dagger
def learn_hg_dagger(
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    ga: GAConfig,
    hg: HGDaggerConfig,
    memory: MemoryConfig | None = None,
    mirror: bool = False,
    track: str = "training",
    features: str = DEFAULT_FEATURES,
) -> Learned:
    """The paper's demonstration and GA, then rounds of runs with interventions and re-evolving.

    Each round drives the current controller once each way on ``track`` (library
    frozen) with the scripted human watching; intervention cases of round r are written to
    ``rep_dir/interventions_r<r>.lfdemo`` and added to the training set before the GA runs again
    (same settings, continuing the GA's random stream).
    """
    paper = learn_paper(
        rep_dir,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset=preset,
        human=human,
        ga=ga,
        memory=memory,
        mirror=mirror,
        track=track,
        features=features,
    )
    demo = load_demonstration(rep_dir / "demonstration.lfdemo")
    inputs = [np.asarray(demo.policy_inputs(features), dtype=np.float64)]
    actions = [np.asarray(demo.commands, dtype=np.intp)]
    controller = paper.controller
    library = controller.library
    ga_rng = np.random.default_rng([ga_seed, 1])
    round_rng = np.random.default_rng([demo_seed, 1])
    totals = LoopCounts()
    per_round: list[dict[str, Any]] = []
    fitness_best, fitness_mean = list(paper.fitness_best), list(paper.fitness_mean)
    period = _period_s(preset)
    for r in range(1, hg.rounds + 1):
        buffer = CaseBuffer(controller.n_inputs)
        round_counts = LoopCounts()
        reasons: dict[str, int] = {}
        human_rng = np.random.default_rng(int(round_rng.integers(2**62)))
        path = rep_dir / f"interventions_r{r}.lfdemo"
        metadata = {"kind": "simulated", "method": "hg-dagger", "round": r, "bins": library.bins}
        with recording_writer(
            path,
            metadata,
            controller.perception("frozen"),
            fsync=False,
            overwrite=True,
            log_library=False,  # the library is the demonstration's, frozen: nothing to log
        ) as w:
            for reverse in (False, True):
                env = LfDTrackEnv(track=track, reverse=reverse, preset=preset)
                legs = (env.track, load_track(track, reverse=not reverse))
                person = ProtocolHuman(
                    legs,
                    dataclasses.replace(human, legs=1, library_only_commands=0),
                    human_rng,
                    intervention=hg.intervention,
                    rover=env.preset.rover,
                    memory=memory,
                )
                loop = TeachingLoop(
                    env,
                    controller.perception("frozen"),
                    Arbiter(
                        "takeover",
                        window=hg.window,
                        threshold=hg.threshold,
                        initial_driver="policy",
                    ),
                    human=person,
                    policy=controller.commander(),
                    observers=[
                        buffer,
                        Recorder(
                            w,
                            lambda s, p=person: {
                                "pose": s.moment.pose,
                                "progress_m": p.progress_m,
                                "phase": "correction" if s.decision.correction else "intervention",
                                "step": s.moment.step,
                            },
                            round=r,
                            source="correction",
                        ),
                    ],
                )
                loop.reset(seed=int(round_rng.integers(2**62)))
                loop.run()
                _add(round_counts, loop.counts)
                for why, n in person.interventions.items():
                    reasons[why] = reasons.get(why, 0) + n
                env.close()
            w.close({"round": r, "cases": len(buffer.commands)})
        _add(totals, round_counts)
        x, a = buffer.arrays()
        inputs.append(x)
        actions.append(a)
        all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
        result = evolve(*_training_set(all_x, all_a, memory, mirror, features), ga, ga_rng)
        controller = _relabel(
            Controller.from_evolution(
                library, result, seed=ga_seed, memory=memory, features=features
            ),
            "hg-dagger",
            {**hg.to_dict(), "ga": ga.to_dict()},
        )
        fitness_best += result.best_history.tolist()
        fitness_mean += result.mean_history.tolist()
        per_round.append(
            {
                "round": r,
                "intervention_cases": int(len(a)),
                "corrections": round_counts.corrections,
                "interventions": reasons,
                "autonomous_drive_s": round(round_counts.policy_commands * period, 6),
            }
        )
    all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
    effort = dict(paper.effort)
    effort["commands"] += totals.human_commands
    effort["corrections"] += totals.corrections
    effort["takeovers"] += totals.takeovers
    effort["learning_drive_s"] = round(effort["learning_drive_s"] + totals.steps * period, 6)
    effort["autonomous_drive_s"] = round(totals.policy_commands * period, 6)
    demo_record = dict(paper.demo, rounds=per_round, cases=int(len(all_a)))
    return Learned(
        controller=controller,
        demo=demo_record,
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=training_accuracy(controller.weights, all_x, all_a),
        effort=effort,
    )
