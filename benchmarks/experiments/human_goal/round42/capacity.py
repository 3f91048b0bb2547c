"""Round 42's measurement: does the network's size bind how well it imitates the human model?

Leave one room out over the saved demonstrations of ``results/prior_cases`` (twenty rooms of the
same centreline human: round 41's ten on random:train:36 and round 42's ten on random:train:35):
for each of the ten random:train:36 rooms, fit one network (the goal's backprop settings: biases,
class balance 0.5, 2000 epochs, ensemble 1) on the other nineteen rooms' cases with 5 (the
paper's), 10 and 20 hidden nodes, and score it on the held-out room's cases: the share of cases
where the network's command is the human's, and the mean of the per-command shares (forward, left,
right). The same starting seed for every fit of a size. Writes a markdown table.

    .venv/bin/python benchmarks/experiments/human_goal/round42/capacity.py --out benchmarks/experiments/human_goal/round42/results/capacity.md
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.extra_cases import case_files, load_cases
from lfd_track.policy.mlp import ensemble_forward

HERE = Path(__file__).resolve().parent
SIZES = (5, 10, 20)


def scores(weights: np.ndarray, x: np.ndarray, a: np.ndarray, hidden: int) -> tuple[float, float]:
    """(accuracy, mean per-command recall) of ``weights`` on cases ``x``, ``a``."""
    chosen = np.argmax(ensemble_forward(np.atleast_2d(weights), x, hidden=hidden), axis=1)
    recalls = [float(np.mean(chosen[a == c] == c)) for c in range(3) if np.any(a == c)]
    return float(np.mean(chosen == a)), float(np.mean(recalls))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", default=str(HERE / "results" / "prior_cases"))
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    files = case_files(args.cases)
    rooms = [load_cases(f) for f in files]
    held = [i for i, f in enumerate(files) if f.name in _round41_names()]
    config = BCConfig(bias=True, class_balance=0.5, ensemble=1)
    rows = {h: [] for h in SIZES}
    for i in held:
        tx = np.concatenate([r[0] for j, r in enumerate(rooms) if j != i])
        ta = np.concatenate([r[1] for j, r in enumerate(rooms) if j != i])
        for h in SIZES:
            start = time.time()
            fit = fit_bc(tx, ta, config, np.random.default_rng(0), hidden=h)
            train = scores(fit.weights, tx, ta, h)
            test = scores(fit.weights, *rooms[i], h)
            rows[h].append((*train, *test))
            print(
                f"room {files[i].stem} hidden {h}: held-out {test[0]:.3f} ({time.time() - start:.0f} s)"
            )
    lines = [
        "# Does the network's size bind imitation? Leave one room out (capacity.py)",
        "",
        "Ten held-out rooms (round 41's, random:train:36), each fitted on the other nineteen rooms'"
        " cases of results/prior_cases; one network, the goal's backprop settings; mean over the ten"
        " folds (range in brackets).",
        "",
        "| hidden nodes | training accuracy | training per-command | held-out accuracy | held-out per-command |",
        "|---|---|---|---|---|",
    ]
    for h in SIZES:
        r = np.array(rows[h])
        cells = [
            f"{r[:, k].mean():.3f} [{r[:, k].min():.3f}–{r[:, k].max():.3f}]" for k in range(4)
        ]
        lines.append(f"| {h} | " + " | ".join(cells) + " |")
    Path(args.out).write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


def _round41_names() -> set[str]:
    """The file names of round 41's ten saved demonstrations (random:train:36)."""
    return {f.name for f in case_files(HERE.parent / "round41" / "results" / "prior_cases")}


if __name__ == "__main__":
    main()
