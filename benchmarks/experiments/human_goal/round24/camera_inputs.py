"""Round 24, part 3: which of the map's inputs does a room's camera move in the human's cases?

Round 23 (``../round23/``) found that a room's camera alone costs the learned policy 7
validation laps of 200 (lap by lap 10 lost, 3 gained) and the hand-written rule none. The
centreline human steers by the track, not the picture, so with only the camera drawn it gives the
same commands as in the paper world; what differs is the inputs its cases carry. Here each
repetition's demonstration (seed 100, repetitions 0-9, made and learned as the study makes them:
``../study_repetition.py``) is made in the paper world (round 22's ``paper.round20+visual``) and
in the repetition's camera-only room (round 23's ``camera.round20+visual``), and the cases are
compared one by one where the two demonstrations drove the same steps (same command, poses
within 1 cm and 1 deg; the share that does is reported): for each of the four map inputs
(bearing, amount, distance, branch side) the mean absolute change, over its spread (standard
deviation) in the paper world's cases; and, per room, beside the learned policy's laps lost.

The reading rule, written before it ran:
- "The camera moves <input>" for each input whose mean change is at least 0.3 of its spread;
  "the camera leaves <input>" for each under 0.1.
- If the camera leaves the bearing and the side (the inputs the rule reads) and moves the amount
  or the distance, the next design gives the learner the amount and distance measured
  independently of the camera's floor sampling (or without them).
No learned policy is driven; no validation or test loop is read.

Writes ``results/camera_inputs.md``.

    .venv/bin/python benchmarks/experiments/human_goal/round24/camera_inputs.py --workers 2
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.dataset import load_demonstration
from lfd_track.study.spec import load_study

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from room_measures import repetition_laps, write_page  # noqa: E402
from study_repetition import learned_repetition  # noqa: E402

OUT = HERE / "results"
WORLDS = {
    "paper": (HERE.parent / "round22" / "room_parts.toml", "paper.round20+visual"),
    "camera": (HERE.parent / "round23" / "room_quarters.toml", "camera.round20+visual"),
}
INPUTS = ("bearing", "amount", "distance", "branch side")


def _cases(job: tuple[str, int, int]) -> tuple[str, int, np.ndarray, np.ndarray, np.ndarray]:
    import cv2

    cv2.setNumThreads(1)
    world, index, seed = job
    study, name = WORLDS[world]
    config = next(c.config for c in load_study(study).conditions if c.name == name)
    with learned_repetition(config, seed) as repetition:
        demo = load_demonstration(repetition.folder / "demonstration.lfdemo")
        memory = np.asarray(demo.policy_inputs("none"), dtype=np.float64)
        return world, index, memory, np.asarray(demo.commands), np.asarray(demo.poses)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    seeds = repetition_seeds(100, 10)
    jobs = [(w, i, s) for w in WORLDS for i, s in enumerate(seeds)]
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        got = {(w, i): (m, c, p) for w, i, m, c, p in pool.map(_cases, jobs)}
    paper_all = np.concatenate([got[("paper", i)][0] for i in range(10)])
    spread = paper_all.std(axis=0)
    paper_laps = repetition_laps(HERE.parent / "round22/results/room_parts/paper.round20+visual")
    camera_laps = repetition_laps(
        HERE.parent / "round23/results/room_quarters/camera.round20+visual"
    )
    lost = [paper_laps[i][0] - camera_laps[i][0] for i in range(10)]
    rows, changes, matched, total = [], [], 0, 0
    for i in range(10):
        (mp, cp, pp), (mc, cc, pc) = got[("paper", i)], got[("camera", i)]
        n = min(len(cp), len(cc))
        turn = np.abs((pp[:n, 2] - pc[:n, 2] + math.pi) % (2 * math.pi) - math.pi)
        same = (cp[:n] == cc[:n]) & (np.hypot(*(pp[:n, :2] - pc[:n, :2]).T) < 0.01)
        same &= turn < math.radians(1.0)
        # cases after the first step where the two drives part do not compare
        first_apart = int(np.argmin(same)) if not same.all() else n
        keep = np.zeros(n, dtype=bool)
        keep[:first_apart] = True
        matched += int(keep.sum())
        total += max(len(cp), len(cc))
        delta = np.abs(mp[:n][keep] - mc[:n][keep])
        changes.append(delta)
        per = delta.mean(axis=0) / spread
        rows.append(
            f"| {i} | {len(cp)} / {len(cc)} | {int(keep.sum())} | "
            + " | ".join(f"{v:.2f}" for v in per)
            + f" | {lost[i]:+d} |"
        )
    pooled = np.concatenate(changes).mean(axis=0) / spread
    verdicts = []
    for name, value in zip(INPUTS, pooled, strict=True):
        if value >= 0.3:
            verdicts.append(f"the camera moves the {name} ({value:.2f})")
        elif value < 0.1:
            verdicts.append(f"the camera leaves the {name} ({value:.2f})")
        else:
            verdicts.append(f"the {name} in between ({value:.2f})")
    lines = [
        "# Which map inputs a room's camera moves in the human's cases",
        "",
        "Seed 100, repetitions 0-9: each demonstration made in the paper world and in the",
        "repetition's camera-only room; cases compared where both drove the same steps.",
        f"Cases compared: {matched} of {total}. Change = mean |paper - camera| over the input's",
        "spread (standard deviation) in the paper world's cases.",
        "",
        "| repetition | cases (paper / camera) | compared | "
        + " | ".join(INPUTS)
        + " | laps lost by the learned policy |",
        "|---|---|---|" + "---|" * len(INPUTS) + "---|",
        *rows,
        "| pooled | | "
        + str(matched)
        + " | "
        + " | ".join(f"{v:.2f}" for v in pooled)
        + f" | {sum(lost):+d} |",
        "",
        "Spread in the paper world's cases: "
        + ", ".join(f"{n} {s:.3f}" for n, s in zip(INPUTS, spread, strict=True))
        + ".",
        "",
        "**By the rule:** " + "; ".join(verdicts) + ".",
    ]
    write_page(OUT / "camera_inputs.md", lines)


if __name__ == "__main__":
    main()
