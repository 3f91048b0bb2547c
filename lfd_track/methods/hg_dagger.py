"""The ``hg-dagger`` method: the paper's demonstration and GA, then ``rounds`` rounds of
autonomous runs on the demonstration track (or ``round_track``; one each way) with the human
intervening by the intervention rule; the interventions of every round are aggregated and the GA
re-run on all cases after each round. With ``learner = "bc"`` backprop (the benchmark's ``bc`` settings) takes
the GA's place: the ``bc`` method's network after the demonstration, fitted again on all cases
after each round."""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset import load_demonstration
from ..dataset.recording import recording_writer
from ..learning.fitness import training_accuracy
from ..learning.ga import evolve
from ..learning.learners import learner_for
from ..policy.controller import Controller
from ..teaching.loop import LoopCounts
from ..teaching.observers import CaseBuffer, Recorder
from . import baseline, paper
from .common import (
    Learned,
    MethodContext,
    add_counts,
    effort_record,
    recording_metadata,
    training_set,
)
from .dagger import DAGGER_LEARNERS
from .takeover import RoundTally, TakeoverConfig, drive_both_ways


@dataclass(frozen=True)
class HGDaggerConfig(TakeoverConfig):
    """Settings of the ``hg-dagger`` method (rounds of autonomous runs with interventions; after
    an intervention the policy drives again once it agreed on the last ``window``)."""

    settings_name = "hg-dagger"

    rounds: int = 3
    """R: rounds of autonomous runs, each followed by re-evolving on all cases (1..1000)."""
    learner: str = "ga"
    """What fits the network after the demonstration and after each round: ``"ga"`` (the
    paper's GA, the benchmark's ``ga`` settings) or ``"bc"`` (backprop, the benchmark's ``bc``
    settings; an MLP only), with mirrored cases as the benchmark says (round 3 of
    ``benchmarks/experiments/human_goal/`` sets ``"bc"``: the map-only network learns by backprop,
    ``benchmarks/experiments/goal/learners_by_kind/``)."""

    round_track: str | None = None
    """The track the rounds drive (once each way), when not the demonstration's: a second
    track the person lays out to watch the taught robot on, e.g. a loop with a sharper corner
    than the demonstrated one (a ``random:train:<i>`` loop: selection never teaches on another
    split). None: the demonstration's track."""

    def to_dict(self) -> dict[str, Any]:
        """The settings as a dict; ``learner`` only when it is not ``"ga"`` and ``round_track``
        only when set (what every run did before the settings existed), so that files written
        before them still match theirs."""
        data = super().to_dict()
        if data["learner"] == "ga":
            del data["learner"]
        if data["round_track"] is None:
            del data["round_track"]
        return data

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("rounds", 1_000)
        if self.learner not in DAGGER_LEARNERS:
            raise ValueError(
                f"hg-dagger learner must be one of {', '.join(DAGGER_LEARNERS)}, got {self.learner!r}"
            )
        if self.round_track is not None and not (
            isinstance(self.round_track, str) and self.round_track.strip()
        ):
            raise ValueError(f"hg-dagger round_track must name a track, got {self.round_track!r}")


def learn(context: MethodContext) -> Learned:
    """The paper's demonstration and GA, then rounds of runs with interventions and re-evolving.

    Each round drives the current controller once each way on ``context.track`` (or on
    ``round_track``; library frozen) with the scripted human watching; intervention cases of
    round r are written to ``rep_dir/interventions_r<r>.lfdemo`` and added to the training set
    before the GA runs again (same settings, continuing the GA's random stream).
    """
    hg: HGDaggerConfig = context.settings
    ga, features, rep_dir = context.ga, context.features, context.rep_dir
    if hg.learner == "bc" and context.policy_kind != "mlp-sigmoid":
        raise ValueError("hg-dagger learner 'bc' fits an MLP (policy_kind 'mlp-sigmoid')")
    first = paper.learn(context) if hg.learner == "ga" else baseline.learn_bc(context)
    demo = load_demonstration(rep_dir / "demonstration.lfdemo")
    inputs = [np.asarray(demo.policy_inputs(features), dtype=np.float64)]
    actions = [np.asarray(demo.commands, dtype=np.intp)]
    controller = first.controller
    library = controller.library
    ga_rng = np.random.default_rng([context.ga_seed, 1])
    round_rng = np.random.default_rng([context.demo_seed, 1])
    rounds_human = dataclasses.replace(context.human, legs=1, library_only_commands=0)
    round_context = (
        context if hg.round_track is None else dataclasses.replace(context, track=hg.round_track)
    )
    totals = LoopCounts()
    per_round: list[dict[str, Any]] = []
    fitness_best, fitness_mean = list(first.fitness_best), list(first.fitness_mean)
    period = context.period_s
    for r in range(1, hg.rounds + 1):
        buffer = CaseBuffer(controller.n_inputs)
        tally = RoundTally()
        human_rng = np.random.default_rng(int(round_rng.integers(2**62)))
        with recording_writer(
            rep_dir / f"interventions_r{r}.lfdemo",
            recording_metadata("hg-dagger", library, round=r),
            controller.perception("frozen", world_geometry=context.map_geometry),
            fsync=False,
            overwrite=True,
            log_library=False,  # the library is the demonstration's, frozen: nothing to log
        ) as w:

            def observers(
                person: Any, w: Any = w, r: int = r, buffer: CaseBuffer = buffer
            ) -> list[Any]:
                return [
                    buffer,
                    Recorder(
                        w,
                        lambda s: {
                            "pose": s.moment.pose,
                            "progress_m": person.progress_m,
                            "phase": "correction" if s.decision.correction else "intervention",
                            "step": s.moment.step,
                        },
                        round=r,
                        source="correction",
                    ),
                ]

            drive_both_ways(
                round_context,
                controller,
                rounds_human,
                hg,
                (human_rng, round_rng),
                observers,
                tally,
            )
            w.close({"round": r, "cases": len(buffer.commands)})
        add_counts(totals, tally.counts)
        x, a = buffer.arrays()
        inputs.append(x)
        actions.append(a)
        all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
        if hg.learner == "ga":
            result = evolve(*training_set(context, all_x, all_a), ga, ga_rng)
            fitted = Controller.from_evolution(
                library,
                result,
                seed=context.ga_seed,
                memory=context.memory,
                features=features,
                frame_size=context.frame_size,
                map_geometry=context.map_geometry,
            )
            fitness_best += result.best_history.tolist()
            fitness_mean += result.mean_history.tolist()
            settings = {"ga": ga.to_dict()}
        else:
            fit = learner_for(context.bc).fit(*training_set(context, all_x, all_a), ga_rng)
            fitted = baseline.controller_of_fit(context, library, fit, context.bc)
            fitness_best += fit.history.tolist()
            settings = {"bc": context.bc.to_dict()}
        controller = fitted.relabelled("hg-dagger", {**hg.to_dict(), **settings})
        per_round.append(
            {
                "round": r,
                "intervention_cases": int(len(a)),
                "corrections": tally.counts.corrections,
                "interventions": tally.reasons,
                "autonomous_drive_s": round(tally.counts.policy_commands * period, 6),
            }
        )
    all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
    return Learned(
        controller=controller,
        demo=dict(first.demo, rounds=per_round, cases=int(len(all_a))),
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=training_accuracy(
            controller.weights, all_x, all_a, hidden=controller.hidden
        ),
        effort=effort_record(
            period, demonstration_commands=first.effort["commands"], counts=totals
        ),
    )


def learn_hg_dagger(rep_dir: str | Path, *, hg: HGDaggerConfig, **context: Any) -> Learned:
    """:func:`learn` with the settings ``hg`` and the context's fields as keywords
    (:class:`~lfd_track.methods.common.MethodContext`)."""
    return learn(MethodContext(Path(rep_dir), settings=hg, **context))


# ------------------------------------------------------------------------------- command line
def add_flags(parser: argparse.ArgumentParser) -> None:
    """The ``hg-dagger`` flags of ``lfd-track benchmark``."""
    parser.add_argument(
        "--hg-dagger-learner",
        choices=DAGGER_LEARNERS,
        default=None,
        help="with --method hg-dagger: what fits the network after the demonstration and after"
        " each round, the GA or backprop (the bc method's settings; default: ga)",
    )
    parser.add_argument(
        "--hg-dagger-round-track",
        default=None,
        metavar="TRACK",
        help="with --method hg-dagger: the track the rounds drive, once each way (e.g."
        " random:train:35, a loop with a sharper corner; default: the demonstration's track)",
    )


def flags_given(args: argparse.Namespace) -> list[str]:
    """The ``hg-dagger`` flags given on the command line."""
    given = {
        "--hg-dagger-learner": args.hg_dagger_learner,
        "--hg-dagger-round-track": args.hg_dagger_round_track,
    }
    return [flag for flag, value in given.items() if value is not None]


def settings_from_flags(args: argparse.Namespace) -> HGDaggerConfig:
    """The ``hg-dagger`` settings of the command line's flags."""
    return HGDaggerConfig(
        learner=args.hg_dagger_learner or "ga", round_track=args.hg_dagger_round_track
    )
