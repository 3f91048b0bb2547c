"""Does the network's width bind what the human model's demonstrations teach?

The demonstrations of round 17's chosen configuration (``../round17/selection_round17.toml``,
its first condition; seed 0, repetitions 0-9, the selection's repetitions: each a lap each way
of a train loop, ``random:train:36``) are made again as the study makes them
(``learn_repetition``). On each, backprop as the configuration fits it (biases, the cases and
their mirror images, cases weighed ``n_e ** -0.5``, 2000 epochs) fits networks of 5 (the
paper's), 10 and 20 hidden nodes, on the map's five inputs and on its first four (round 15's
map). Each network is scored on the cases of its own demonstration (training accuracy) and on
those of the next repetition's demonstration (other train loops: held-out accuracy). Beside
them, a k-nearest-neighbour vote (k = 15, the same cases and mirror images) says what the inputs
alone let any learner reach on held-out cases, and the hand-written map rule on the same inputs
(``FreshFeltRule`` with the map's settings, as ``../../generalization/rules.py`` drives it; it
learns nothing) how often it gives the human's command. Only demonstrations are read: no run of a learned
policy, no validation or test loop.

    .venv/bin/python benchmarks/experiments/human_goal/capacity/capacity.py

writes ``results/capacity.md`` (a few minutes on one core).
"""

from __future__ import annotations

import dataclasses
import sys
import time
from pathlib import Path

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.dataset import load_demonstration
from lfd_track.learning.bc import fit_bc
from lfd_track.learning.fitness import training_accuracy
from lfd_track.learning.mirror import mirror_cases
from lfd_track.study.spec import load_study
from lfd_track.teaching.handwritten import FreshFeltRule, FreshFeltRuleConfig
from lfd_track.teaching.scripted import HumanConfig
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from study_repetition import learned_repetition  # noqa: E402

STUDY = HERE.parent / "round17" / "selection_round17.toml"
SEED, REPETITIONS = 0, 10
WIDTHS = (5, 10, 20)
K = 15


def knn_accuracy(x: np.ndarray, a: np.ndarray, qx: np.ndarray, qa: np.ndarray) -> float:
    """Share of the query cases ``qx``, ``qa`` whose k nearest cases of ``x`` (Euclidean) vote
    their command (ties to the lowest command)."""
    d = ((qx[:, None, :] - x[None, :, :]) ** 2).sum(axis=2)
    nearest = np.argsort(d, axis=1, kind="stable")[:, :K]
    votes = np.stack([(a[nearest] == c).sum(axis=1) for c in range(3)], axis=1)
    return float((votes.argmax(axis=1) == qa).mean())


def main() -> None:
    import cv2

    cv2.setNumThreads(1)
    config = load_study(STUDY).conditions[0].config
    t0 = time.perf_counter()
    demos = []
    for seed in repetition_seeds(SEED, REPETITIONS):
        with learned_repetition(config, seed) as repetition:
            demo = load_demonstration(repetition.folder / "demonstration.lfdemo")
            demos.append((np.asarray(demo.policy_inputs("none")), np.asarray(demo.commands)))
    md = ["# Does the network's width bind? (the human model's demonstrations)", ""]
    md += [f"Round 17's chosen configuration, seed {SEED}, repetitions 0-{REPETITIONS - 1}:"]
    md += [f"{sum(len(a) for _, a in demos)} demonstration cases. Mean over the repetitions;"]
    md += ["held out: the next repetition's demonstration (other train loops).", ""]
    md += ["| inputs | learner | training accuracy | held-out accuracy |", "|---|---|---|---|"]
    for n_inputs, label in ((4, "4 (round 15's map)"), (5, "5 (round 17's map)")):
        memory = dataclasses.replace(config.memory, branch_turn=n_inputs == 5)
        sets = []
        for x, a in demos:
            x = x[:, :n_inputs]
            mx, ma = mirror_cases(x, a, memory=memory, features="none")
            sets.append((x, a, np.vstack([x, mx]), np.concatenate([a, ma])))
        for hidden in WIDTHS:
            train, held = [], []
            for i, (x, a, fx, fa) in enumerate(sets):
                rng = np.random.default_rng(1000 * hidden + i)
                weights = fit_bc(fx, fa, config.bc, rng, hidden=hidden).weights
                train.append(training_accuracy(weights, x, a, hidden=hidden))
                qx, qa = sets[(i + 1) % len(sets)][:2]
                held.append(training_accuracy(weights, qx, qa, hidden=hidden))
            name = f"backprop, {n_inputs}-{hidden}-3"
            md += [f"| {label} | {name} | {np.mean(train):.1%} | {np.mean(held):.1%} |"]
        held = [
            knn_accuracy(fx, fa, *sets[(i + 1) % len(sets)][:2])
            for i, (_, _, fx, fa) in enumerate(sets)
        ]
        md += [f"| {label} | {K}-nearest neighbours | – | {np.mean(held):.1%} |"]
    rule = FreshFeltRuleConfig(turn_deg=HumanConfig().picture_turn_deg, memory=config.memory)
    agree = []
    for x, a in demos:  # the rule's state (the side it last turned to) runs through the cases
        acting = FreshFeltRule(rule)
        agree.append(float(np.mean([acting.act(row) == c for row, c in zip(x, a, strict=True)])))
    md += [f"| 4 (it reads no fifth) | the map rule, hand-written | – | {np.mean(agree):.1%} |"]
    md += ["", f"{(time.perf_counter() - t0) / 60:.0f} min on one core."]
    out = HERE / "results" / "capacity.md"
    out.parent.mkdir(exist_ok=True)
    atomic_write_text(out, "\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
