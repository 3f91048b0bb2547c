"""The goal's configuration beside the map rule on its very inputs, on the test loops: pools the
six runs of ``../where_they_part.py --test-split`` (``../../goal/chosen.toml`` as it was then,
``../../goal/chosen_round27.toml`` now; conditions ``paper`` and ``rooms``, seeds 0-2) into one
table per world and checks that every learned lap reproduced the study's. Reads only ``results/same_inputs/``; nothing is run or chosen here.

    .venv/bin/python benchmarks/experiments/human_goal/test_round27/same_inputs.py

writes ``results/same_inputs/same_inputs.md`` (a second).
"""

from __future__ import annotations

import json
from pathlib import Path

from lfd_track.utils.atomic import atomic_write_text
from lfd_track.world.loops import TURN_BIN_LABELS

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results" / "same_inputs"
SEEDS = (0, 1, 2)


def pooled(world: str) -> dict:
    """The world's laps over seeds 0-2: per driver all and per bin, the paired outcomes, and the
    check of the learned laps against the study's."""
    laps, paired, check = [], {}, {"laps": 0, "same outcome": 0, "same steps": 0}
    for seed in SEEDS:
        data = json.loads((RESULTS / f"where_they_part_chosen_{world}_seed{seed}.json").read_text())
        laps += [{**lap, "seed": seed} for lap in data["laps"]]
        for key, count in data["paired_outcomes"].items():
            paired[key] = paired.get(key, 0) + count
        for row in data["check_against_study"].values():
            for key in check:
                check[key] += row[key]
    table = {}
    for driver in ("learned", "rule"):
        mine = [lap for lap in laps if lap["driver"] == driver]
        cells = [(sum(x["success"] for x in mine), len(mine))]
        for label in TURN_BIN_LABELS:
            some = [x for x in mine if x["turn_bin"] == label]
            cells.append((sum(x["success"] for x in some), len(some)))
        table[driver] = cells
    return {"table": table, "paired": paired, "check": check}


def main() -> None:
    md = ["# The goal's configuration beside the map rule on its very inputs (test loops)", ""]
    md += ["Seeds 0-2 x 10 repetitions of `../../../goal/chosen_round27.toml`, each one's 10"]
    md += ["test loops once each way, driven by the learned policy and by the map rule reading the"]
    md += ["learned controller's own perception (its library, map, branch side, measured motion"]
    md += ["and colour balance); `../where_they_part.py --test-split`, one page per seed beside"]
    md += ["this one.", ""]
    md += ["| world | driver | test loops | " + " | ".join(TURN_BIN_LABELS) + " |"]
    md += ["|---" * (3 + len(TURN_BIN_LABELS)) + "|"]
    notes = []
    for world in ("paper", "rooms"):
        done = pooled(world)
        for driver, cells in done["table"].items():
            text = " | ".join(f"{a}/{n}" for a, n in cells)
            md += [f"| {world} | {driver} | {text} |"]
        paired = "; ".join(f"{k} {v}" for k, v in done["paired"].items())
        check = done["check"]
        notes += [
            f"* {world}: the same loop the same way: {paired}. The learned laps reproduce the"
            f" study's: {check['same outcome']} of {check['laps']} outcomes, {check['same steps']}"
            " step counts."
        ]
    md += [""] + notes
    atomic_write_text(RESULTS / "same_inputs.md", "\n".join(md) + "\n")
    print("\n".join(md))


if __name__ == "__main__":
    main()
