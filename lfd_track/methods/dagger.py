"""The ``dagger`` method: classic DAgger (Ross et al. 2011) with the scripted human as labeller.

The paper's demonstration and a first fit (the GA of Table 1 or backprop, ``learner``); then
``rounds`` rounds in which the current controller drives the training track once each way
(library frozen, as HG-DAgger's rounds) and the scripted human labels **every** state the robot
visits with the command it would give there, not only the states where it intervenes. The labels
of every round are added to the cases and the learner is fitted again on all of them after each
round.

The labeller is the demonstration's human with its noise switched off for the rounds
(``label_noise = false``, the default: no reaction delays, no lapses; its dead-band, lookahead
and the rate limit through forward between left and right stay, so a label is what the
noise-free human would press, given its own previous label). With ``label_noise = true`` the
labels keep the human's reaction delays and lapses, as its demonstration did.

When the run would fail, the human takes over by the intervention rule of HG-DAgger
(:class:`~lfd_track.teaching.scripted.InterventionConfig`) and hands control back once the
policy agrees on ``threshold`` of its last ``window`` commands, so a round always drives the
whole track; the commands it drives with are labels like the others.

Effort: ``commands`` counts the demonstration's commands plus every label (DAgger's labels are
commands the human gave, even where the robot did not execute them); ``labels`` counts the labels
alone; ``corrections`` the times the human took control back; ``learning_drive_s`` and
``autonomous_drive_s`` the robot's seconds during the rounds (plus the demonstration's) and the
policy's share of them. ``rounds`` in the demonstration record is the learning curve: cases,
labels, interventions, training accuracy on all cases so far and whether each of the two runs
reached the end of the track without the human taking over.
"""

from __future__ import annotations

import argparse
import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.recording import recording_writer
from ..demo.demonstrator import HumanConfig
from ..learning.bc import fit_bc
from ..learning.fitness import training_accuracy
from ..learning.ga import evolve
from ..learning.result import check_bool, shown_int
from ..policy.controller import Controller
from ..policy.mlp import MAX_HIDDEN, N_HIDDEN, check_hidden
from ..teaching.loop import LoopCounts
from ..teaching.scripted import ProtocolHuman
from ..teaching.types import Step
from .common import (
    Learned,
    MethodContext,
    add_counts,
    demonstrate,
    demonstration_record,
    effort_record,
    recording_metadata,
    training_set,
)
from .takeover import RoundTally, TakeoverConfig, drive_both_ways

DAGGER_LEARNERS = ("ga", "bc")
"""What fits the network in ``dagger``: the paper's GA or backprop (behaviour cloning)."""


@dataclass(frozen=True)
class DaggerConfig(TakeoverConfig):
    """Settings of the ``dagger`` method (every visited state labelled by the human)."""

    settings_name = "dagger"

    rounds: int = 3
    """R: rounds of runs on the training track (one each way), each followed by a fit on all
    cases (1..1000)."""
    learner: str = "ga"
    """What fits the network: ``ga`` (the GA settings of the benchmark) or ``bc`` (its BC
    settings)."""
    hidden: int = N_HIDDEN
    """Hidden nodes of the network (the paper's 5; 1..1000). Another width needs ``bc``."""
    label_noise: bool = False
    """Keep the human's reaction delays and lapses while it labels (default: noise-free)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("rounds", 1_000)
        if self.learner not in DAGGER_LEARNERS:
            raise ValueError(
                f"dagger learner must be one of {', '.join(DAGGER_LEARNERS)}, got {self.learner!r}"
            )
        try:
            check_hidden(self.hidden)
        except ValueError:
            raise ValueError(
                f"dagger hidden must be an integer in 1..{MAX_HIDDEN}, got {_shown(self.hidden)}"
            ) from None
        if self.learner == "ga" and self.hidden != N_HIDDEN:
            raise ValueError(
                f"dagger hidden {self.hidden} needs learner 'bc' (the GA evolves the paper's"
                f" {N_HIDDEN} hidden nodes)"
            )
        check_bool("dagger label_noise", self.label_noise)


def _shown(value: Any) -> str:
    """A setting's value in one short line (a 400-digit integer is not printed whole)."""
    if isinstance(value, int) and not isinstance(value, bool):
        return shown_int(value)
    return repr(value)[:40]


def labelling_human(human: HumanConfig, label_noise: bool) -> HumanConfig:
    """The human of the rounds: one leg, no library-only commands, noise off unless kept."""
    rounds = dataclasses.replace(human, legs=1, library_only_commands=0)
    if not label_noise:
        rounds = dataclasses.replace(rounds, reaction_delay_prob=0.0, lapse_prob=0.0)
    return rounds


class LabelBuffer:
    """Observer keeping every executed step's policy inputs with the human's label for it (and
    writing them to a recording when given one)."""

    def __init__(self, n_inputs: int, writer: Any = None, round: int = 0) -> None:
        self.n_inputs = n_inputs
        self.writer = writer
        self.round = int(round)
        self.person: ProtocolHuman | None = None
        """The labeller of the current run."""
        self.values: list[np.ndarray] = []
        self.labels: list[int] = []
        self.agreed = 0
        """Labels equal to the command the policy executed."""

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        assert self.person is not None
        label = self.person.label
        if label is None:  # the protocol is over (nothing left to label)
            return
        self.values.append(np.asarray(step.percept.inputs, dtype=np.float64))
        self.labels.append(int(label))
        executed = step.command
        self.agreed += (
            step.decision.driver == "policy" and executed is not None and int(executed) == label
        )
        if self.writer is not None:
            fields: dict[str, Any] = {}
            if len(step.percept.memory):
                fields["memory"] = step.percept.memory
            human_drove = step.decision.driver == "human"
            self.writer.append(
                int(label),
                step.percept.values,
                step.percept.histograms,
                learned=step.percept.learned,
                pose=step.moment.pose,
                progress_m=self.person.progress_m,
                phase="intervention" if human_drove else "label",
                step=step.moment.step,
                source="correction" if human_drove else "demonstration",
                round=self.round,
                **fields,
            )

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(N, n_inputs) float64 inputs and (N,) intp labels."""
        if not self.values:
            return np.empty((0, self.n_inputs)), np.empty(0, dtype=np.intp)
        return np.stack(self.values), np.asarray(self.labels, dtype=np.intp)


def learn(context: MethodContext) -> Learned:
    """The paper's demonstration and a first fit, then DAgger rounds with every state labelled.

    Round 0 is the paper's demonstration fitted with ``ga_seed`` (so with ``learner = "ga"`` its
    controller is the ``paper`` method's); later fits continue one random stream. Round r's labels
    are written to ``rep_dir/labels_r<r>.lfdemo`` (interventions as ``correction`` cases).
    """
    dagger: DaggerConfig = context.settings
    ga, bc, features = context.ga, context.bc, context.features
    summary, demo, library, _ = demonstrate(context)
    inputs = [np.asarray(demo.policy_inputs(features), dtype=np.float64)]
    actions = [np.asarray(demo.commands, dtype=np.intp)]
    fitter = ga if dagger.learner == "ga" else bc
    learner_config = {**dagger.to_dict(), dagger.learner: fitter.to_dict()}
    fitness_best: list[float] = []
    fitness_mean: list[float] = []

    def fit(x: np.ndarray, a: np.ndarray, rng: np.random.Generator) -> Controller:
        tx, ta = training_set(context, x, a)
        if dagger.learner == "ga":
            result = evolve(tx, ta, ga, rng)
            weights, bias = result.best_weights, ga.bias
            best, mean = result.best_history.tolist(), result.mean_history.tolist()
        else:
            fitted = fit_bc(tx, ta, bc, rng, hidden=dagger.hidden)
            weights, bias = fitted.weights, bc.bias
            best, mean = fitted.history.tolist(), []
        fitness_best.extend(best)
        fitness_mean.extend(mean)
        return Controller(
            library,
            weights,
            bias=bias,
            learner="dagger",
            learner_config=learner_config,
            seed=context.ga_seed,
            fitness_history=best,
            memory=context.memory,
            features=features,
            hidden=dagger.hidden,
            frame_size=context.frame_size,
            map_geometry=context.map_geometry,
        )

    controller = fit(inputs[0], actions[0], np.random.default_rng(context.ga_seed))
    period = context.period_s
    curve: list[dict[str, Any]] = [
        {
            "round": 0,
            "cases": int(len(actions[0])),
            "training_accuracy": training_accuracy(
                controller.weights, inputs[0], actions[0], hidden=dagger.hidden
            ),
        }
    ]
    fit_rng = np.random.default_rng([context.ga_seed, 1])
    round_rng = np.random.default_rng([context.demo_seed, 1])
    rounds_human = labelling_human(context.human, dagger.label_noise)
    totals = LoopCounts()
    labels_total = 0
    for r in range(1, dagger.rounds + 1):
        tally = RoundTally()
        human_rng = np.random.default_rng(int(round_rng.integers(2**62)))
        with recording_writer(
            context.rep_dir / f"labels_r{r}.lfdemo",
            recording_metadata("dagger", library, round=r, label_noise=dagger.label_noise),
            controller.perception("frozen", world_geometry=context.map_geometry),
            fsync=False,
            overwrite=True,
            log_library=False,  # the library is the demonstration's, frozen: nothing to log
        ) as w:
            buffer = LabelBuffer(controller.n_inputs, w, round=r)

            def observers(person: ProtocolHuman, buffer: LabelBuffer = buffer) -> list[Any]:
                buffer.person = person
                return [buffer]

            runs = [
                {
                    "reverse": reverse,
                    "commands": loop.counts.steps,
                    "corrections": loop.counts.corrections,
                    "unaided": loop.counts.corrections == 0 and bool(loop.info.get("success")),
                }
                for reverse, (loop, _) in zip(
                    (False, True),
                    drive_both_ways(
                        context,
                        controller,
                        rounds_human,
                        dagger,
                        (human_rng, round_rng),
                        observers,
                        tally,
                        label_all=True,
                    ),
                    strict=True,
                )
            ]
            w.close({"round": r, "cases": len(buffer.labels)})
        add_counts(totals, tally.counts)
        x, a = buffer.arrays()
        labels_total += len(a)
        inputs.append(x)
        actions.append(a)
        all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
        policy_steps = tally.counts.policy_commands
        controller = fit(all_x, all_a, fit_rng)
        curve.append(
            {
                "round": r,
                "labels": int(len(a)),
                "cases": int(len(all_a)),
                "corrections": tally.counts.corrections,
                "interventions": tally.reasons,
                "label_agreement": round(buffer.agreed / policy_steps, 6) if policy_steps else None,
                "unaided_runs": sum(run["unaided"] for run in runs),
                "runs": runs,
                "autonomous_drive_s": round(policy_steps * period, 6),
                "training_accuracy": training_accuracy(
                    controller.weights, all_x, all_a, hidden=dagger.hidden
                ),
            }
        )
    all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
    return Learned(
        controller=controller,
        demo=demonstration_record(
            summary,
            cases=int(len(all_a)),
            learner=dagger.learner,
            hidden=dagger.hidden,
            label_noise=dagger.label_noise,
            rounds=curve,
        ),
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=training_accuracy(controller.weights, all_x, all_a, hidden=dagger.hidden),
        effort=effort_record(
            period,
            demonstration_commands=summary.commands,
            counts=totals,
            human_commands=labels_total,
            labels=labels_total,
        ),
    )


def learn_dagger(rep_dir: str | Path, *, dagger: DaggerConfig, **context: Any) -> Learned:
    """:func:`learn` with the settings ``dagger`` and the context's fields as keywords
    (:class:`~lfd_track.methods.common.MethodContext`; the learner's settings are ``ga`` or
    ``bc``)."""
    return learn(MethodContext(Path(rep_dir), settings=dagger, **context))


# ------------------------------------------------------------------------------- command line
def add_flags(parser: argparse.ArgumentParser) -> None:
    """The ``dagger`` flags of ``lfd-track benchmark``."""
    from ..cli.types import whole_number_in

    parser.add_argument(
        "--dagger-learner",
        choices=DAGGER_LEARNERS,
        default=None,
        help="with --method dagger: what fits the network, the GA or backprop (default: ga)",
    )
    parser.add_argument(
        "--hidden",
        type=whole_number_in(1, MAX_HIDDEN),
        default=None,
        help=f"with --method dagger --dagger-learner bc: hidden nodes of the network, 1..{MAX_HIDDEN}"
        " (default: the paper's 5)",
    )
    parser.add_argument(
        "--label-noise",
        action="store_true",
        help="with --method dagger: the human keeps its reaction delays and lapses while"
        " labelling (default: noise-free labels)",
    )


def flags_given(args: argparse.Namespace) -> list[str]:
    """The ``dagger`` flags given on the command line."""
    given = (
        ("--dagger-learner", args.dagger_learner is not None),
        ("--hidden", args.hidden is not None),
        ("--label-noise", args.label_noise),
    )
    return [flag for flag, on in given if on]


def settings_from_flags(args: argparse.Namespace) -> DaggerConfig:
    """The ``dagger`` settings of the command line's flags."""
    return DaggerConfig(
        learner=args.dagger_learner or "ga",
        hidden=args.hidden or N_HIDDEN,
        label_noise=args.label_noise,
    )
