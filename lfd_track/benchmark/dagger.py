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

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.recording import recording_writer
from ..demo.demonstrator import HumanConfig
from ..envs.presets import Preset
from ..envs.track_env import LfDTrackEnv
from ..learning.bc import BCConfig, fit_bc
from ..learning.fitness import training_accuracy
from ..learning.ga import GAConfig, evolve
from ..learning.result import check_bool, shown_int
from ..policy.controller import Controller
from ..policy.features import DEFAULT_FEATURES
from ..policy.memory import MemoryConfig
from ..policy.mlp import MAX_HIDDEN, N_HIDDEN, check_hidden
from ..teaching.arbiter import Arbiter
from ..teaching.loop import LoopCounts, TeachingLoop
from ..teaching.scripted import ProtocolHuman
from ..teaching.types import Step
from ..world.track import load_track
from .methods import Learned, TakeoverConfig, _add, _demonstrate, _period_s, _training_set

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
        self.agreed += step.decision.driver == "policy" and int(step.command) == int(label)
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


def learn_dagger(
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    preset: str | Preset,
    human: HumanConfig,
    ga: GAConfig,
    bc: BCConfig,
    dagger: DaggerConfig,
    memory: MemoryConfig | None = None,
    mirror: bool = False,
    track: str = "training",
    features: str = DEFAULT_FEATURES,
) -> Learned:
    """The paper's demonstration and a first fit, then DAgger rounds with every state labelled.

    Round 0 is the paper's demonstration fitted with ``ga_seed`` (so with ``learner = "ga"`` its
    controller is the ``paper`` method's); later fits continue one random stream. Round r's labels
    are written to ``rep_dir/labels_r<r>.lfdemo`` (interventions as ``correction`` cases).
    """
    summary, demo, library, _ = _demonstrate(
        rep_dir, demo_seed=demo_seed, preset=preset, human=human, memory=memory, track=track
    )
    inputs = [np.asarray(demo.policy_inputs(features), dtype=np.float64)]
    actions = [np.asarray(demo.commands, dtype=np.intp)]
    fitter = ga if dagger.learner == "ga" else bc
    learner_config = {**dagger.to_dict(), dagger.learner: fitter.to_dict()}
    fitness_best: list[float] = []
    fitness_mean: list[float] = []

    def fit(x: np.ndarray, a: np.ndarray, rng: np.random.Generator) -> Controller:
        tx, ta = _training_set(x, a, memory, mirror, features)
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
            seed=ga_seed,
            fitness_history=best,
            memory=memory,
            features=features,
            hidden=dagger.hidden,
        )

    controller = fit(inputs[0], actions[0], np.random.default_rng(ga_seed))
    period = _period_s(preset)
    curve: list[dict[str, Any]] = [
        {
            "round": 0,
            "cases": int(len(actions[0])),
            "training_accuracy": training_accuracy(
                controller.weights, inputs[0], actions[0], hidden=dagger.hidden
            ),
        }
    ]
    fit_rng = np.random.default_rng([ga_seed, 1])
    round_rng = np.random.default_rng([demo_seed, 1])
    rounds_human = labelling_human(human, dagger.label_noise)
    totals = LoopCounts()
    labels_total = 0
    for r in range(1, dagger.rounds + 1):
        round_counts = LoopCounts()
        reasons: dict[str, int] = {}
        runs: list[dict[str, Any]] = []
        human_rng = np.random.default_rng(int(round_rng.integers(2**62)))
        path = rep_dir / f"labels_r{r}.lfdemo"
        metadata = {
            "kind": "simulated",
            "method": "dagger",
            "round": r,
            "bins": library.bins,
            "label_noise": dagger.label_noise,
        }
        with recording_writer(
            path,
            metadata,
            controller.perception("frozen"),
            fsync=False,
            overwrite=True,
            log_library=False,  # the library is the demonstration's, frozen: nothing to log
        ) as w:
            buffer = LabelBuffer(controller.n_inputs, w, round=r)
            for reverse in (False, True):
                env = LfDTrackEnv(track=track, reverse=reverse, preset=preset)
                legs = (env.track, load_track(track, reverse=not reverse))
                person = ProtocolHuman(
                    legs,
                    rounds_human,
                    human_rng,
                    intervention=dagger.intervention,
                    rover=env.preset.rover,
                    label_all=True,
                    memory=memory,
                )
                buffer.person = person
                loop = TeachingLoop(
                    env,
                    controller.perception("frozen"),
                    Arbiter(
                        "takeover",
                        window=dagger.window,
                        threshold=dagger.threshold,
                        initial_driver="policy",
                    ),
                    human=person,
                    policy=controller.commander(),
                    observers=[buffer],
                )
                loop.reset(seed=int(round_rng.integers(2**62)))
                loop.run()
                _add(round_counts, loop.counts)
                for why, n in person.interventions.items():
                    reasons[why] = reasons.get(why, 0) + n
                runs.append(
                    {
                        "reverse": reverse,
                        "commands": loop.counts.steps,
                        "corrections": loop.counts.corrections,
                        "unaided": loop.counts.corrections == 0 and bool(loop.info.get("success")),
                    }
                )
                env.close()
            w.close({"round": r, "cases": len(buffer.labels)})
        _add(totals, round_counts)
        x, a = buffer.arrays()
        labels_total += len(a)
        inputs.append(x)
        actions.append(a)
        all_x, all_a = np.concatenate(inputs), np.concatenate(actions)
        policy_steps = round_counts.policy_commands
        controller = fit(all_x, all_a, fit_rng)
        curve.append(
            {
                "round": r,
                "labels": int(len(a)),
                "cases": int(len(all_a)),
                "corrections": round_counts.corrections,
                "interventions": reasons,
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
    demo_period = round(summary.commands * period, 6)
    effort = {
        "commands": summary.commands + labels_total,
        "corrections": totals.corrections,
        "takeovers": totals.takeovers,
        "learning_drive_s": round(demo_period + totals.steps * period, 6),
        "autonomous_drive_s": round(totals.policy_commands * period, 6),
        "labels": labels_total,
    }
    return Learned(
        controller=controller,
        demo={
            "cases": int(len(all_a)),
            "counts": summary.counts,
            "turnarounds": list(summary.turnarounds),
            "library_models": summary.library_models,
            "library_types": summary.library_types,
            "learned_off_felt": summary.learned_off_felt,
            "learner": dagger.learner,
            "hidden": dagger.hidden,
            "label_noise": dagger.label_noise,
            "rounds": curve,
        },
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=training_accuracy(controller.weights, all_x, all_a, hidden=dagger.hidden),
        effort=effort,
    )
