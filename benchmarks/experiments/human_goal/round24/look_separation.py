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
import importlib.util
import json
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

from lfd_track.benchmark.runner import repetition_preset, repetition_seeds
from lfd_track.study.spec import load_study

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"
STUDY = HERE.parent / "round22" / "room_parts.toml"
LOOK = "look.round20+visual"
#: Round 22's laps per room (of 20), repetitions 0-9: the paper world and the look-only rooms,
#: the learned policy and the rule (../round22/README.md).
LEARNED = {
    "paper": [20, 19, 20, 16, 17, 20, 19, 20, 19, 18],
    "look": [18, 20, 20, 14, 15, 20, 16, 20, 20, 16],
}
RULE = {
    "paper": [20, 18, 20, 14, 15, 20, 15, 20, 19, 19],
    "look": [19, 20, 19, 12, 15, 20, 16, 19, 17, 14],
}


def _felt_levels_module() -> Any:
    path = HERE.parents[1] / "robustness" / "felt_levels.py"
    spec = importlib.util.spec_from_file_location("robustness_felt_levels", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def _worlds() -> list[tuple[str, Any]]:
    study = load_study(STUDY)
    config = next(c.config for c in study.conditions if c.name == LOOK)
    rooms = [repetition_preset(config, seed) for seed in repetition_seeds(100, 10)]
    return [("paper", "paper")] + [(f"look{k}", room) for k, room in enumerate(rooms)]


def _one(item: tuple[str, Any]) -> tuple[str, dict[str, Any]]:
    name, world = item
    result = _felt_levels_module().separation(world)
    return name, result


def _ranks(values: np.ndarray) -> np.ndarray:
    order = np.argsort(values, kind="stable")
    ranks = np.empty(len(values))
    ranks[order] = np.arange(len(values))
    for v in np.unique(values):  # ties share their mean rank
        ranks[values == v] = ranks[values == v].mean()
    return ranks


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
    loss = np.array(LEARNED["paper"]) - LEARNED["look"] + np.array(RULE["paper"]) - RULE["look"]
    right = np.array([results[f"look{k}"]["scores"]["fixed"]["share_right"] for k in range(10)])
    rho = float(np.corrcoef(_ranks(right), _ranks(loss.astype(float)))[0, 1])
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
    (OUT / "look_separation.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
