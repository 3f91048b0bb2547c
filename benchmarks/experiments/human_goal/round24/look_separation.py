"""Round 24, part 2: does the road values' felt/carpet separation fall in the rooms whose look
costs laps?

Round 22 (``../round22/``) found that a room's look (felt and carpet colours, light, exposure,
sensor) costs the learned policy and the hand-written rule 9 validation laps of 200 each, and
round 23 that the room's own felt levels give the rule none of them back. Here the perception
itself is scored against the world's truth in the paper world and in each of round 22's ten
look-only rooms (seed 100, repetitions 0-9, each drawn as the study draws it:
``repetition_preset``): ``../../robustness/felt_levels.py``'s part 1 (``separation``), unchanged:
the centreline driver laps the testing track while a careful perception learns its library from
empty, and every frame (and a view from beside the strip every fourth frame) is scored region by
region: the share of regions at least 3/4 felt or at most 1/4 felt whose felt level lies on the
right side of 0.5 (the map's own felt test), with the fixed levels and with the library's.

The reading rule, written before it ran. ``loss`` of a room = its laps in the paper world minus
its laps in the look-only room, the learned policy's and the rule's summed (round 22's tables).
- "Perception binds the look" when the rooms' share right with the fixed levels has a Spearman
  rank correlation of at most -0.5 with their loss (worse separation, more laps lost) and the
  rooms' mean share right lies at least 1 point under the paper world's.
- "Perception does not bind" when every room's share right lies within 1 point of the paper
  world's, or is above it.
- Otherwise: inconclusive.
No test loop is driven; nothing here is a candidate.

Writes ``results/look_separation.json`` and ``results/look_separation.md``.

    .venv/bin/python benchmarks/experiments/human_goal/round24/look_separation.py --workers 2
"""

from __future__ import annotations

import argparse
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.study.spec import load_study

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parent))
from room_measures import (  # noqa: E402
    repetition_laps,
    robustness_felt_levels,
    spearman,
    write_page,
)

OUT = HERE / "results"
STUDY = HERE.parent / "round22" / "room_parts.toml"
LOOK = "look.round20+visual"
#: Round 22's results: the learned policy's (one folder per condition) and the rule's.
ROUND22 = HERE.parent / "round22" / "results"


def _loss() -> np.ndarray:
    """Per room (repetitions 0-9): loop laps in the paper world minus in the look-only room,
    the learned policy's and the rule's summed (round 22's committed results)."""
    folders = {
        "learned": (ROUND22 / "room_parts/paper.round20+visual", ROUND22 / f"room_parts/{LOOK}"),
        "rule": (ROUND22 / "rules_paper", ROUND22 / "rules_look"),
    }
    loss = np.zeros(10)
    for paper, look in folders.values():
        before, after = repetition_laps(paper), repetition_laps(look)
        loss += [before[k][0] - after[k][0] for k in range(10)]
    return loss


def _worlds() -> list[tuple[str, Any]]:
    study = load_study(STUDY)
    config = next(c.config for c in study.conditions if c.name == LOOK)
    rooms = [repetition_preset(config, seed) for seed in repetition_seeds(100, 10)]
    return [("paper", "paper")] + [(f"look{k}", room) for k, room in enumerate(rooms)]


def _one(item: tuple[str, Any]) -> tuple[str, dict[str, Any]]:
    name, world = item
    result = robustness_felt_levels().separation(world)
    return name, result


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    worlds = _worlds()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        results = dict(pool.map(_one, worlds))
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "look_separation.json").write_text(
        json.dumps(results, indent=1, default=float) + "\n", encoding="utf-8"
    )
    paper = results["paper"]["scores"]["fixed"]["share_right"]
    loss = _loss()
    right = np.array([results[f"look{k}"]["scores"]["fixed"]["share_right"] for k in range(10)])
    rho = spearman(right, loss)
    lines = [
        "# Felt/carpet separation of the road values in round 22's look-only rooms",
        "",
        "Share of clearly felt or clearly carpet regions read on the right side of 0.5, over a",
        "lap of the testing track by the centreline driver (and views from beside the strip);",
        "`loss` = the room's laps in the paper world minus in its look-only room, learned + rule.",
        "",
        "| world | loss (of 40) | share right, fixed levels | share right, library levels"
        " | carpet's mean level (fixed) | felt's mean level (fixed) | library levels at the end |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, result in results.items():
        fixed, library = result["scores"]["fixed"], result["scores"]["library"]
        k = None if name == "paper" else int(name[4:])
        levels = result["final_levels"]
        lines.append(
            f"| {name} | {'–' if k is None else int(loss[k])} | {fixed['share_right']:.3f}"
            f" | {library['share_right']:.3f} | {fixed['carpet_mean_level']:.3f}"
            f" | {fixed['felt_mean_level']:.3f}"
            f" | {'–' if levels is None else f'{levels[0]:.2f}, {levels[1]:.2f}'} |"
        )
    mean_gap = float(paper - right.mean())
    within = bool(np.all(right >= paper - 0.01))
    if rho <= -0.5 and mean_gap >= 0.01:
        verdict = "perception binds the look"
    elif within:
        verdict = "perception does not bind"
    else:
        verdict = "inconclusive"
    lines += [
        "",
        f"Spearman (share right, loss) over the 10 rooms: {rho:+.2f}; the rooms' mean share right"
        f" {right.mean():.3f} against the paper world's {paper:.3f} ({100 * mean_gap:+.1f} points"
        f" under it). **By the rule: {verdict}.**",
    ]
    write_page(OUT / "look_separation.md", lines)


if __name__ == "__main__":
    main()
