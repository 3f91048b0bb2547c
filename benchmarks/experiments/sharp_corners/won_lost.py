"""Lap by lap against the map rule as it is: how many loop laps each map-rule run of parts 8-49
laps that the rule as it is does not (won) and the other way round (lost), on the same trials
(committed results only; it chooses nothing). Part 16 reads its two runs aimed at nothing by it.

    .venv/bin/python benchmarks/experiments/sharp_corners/won_lost.py

``--against NAME`` counts against another run of :data:`rooms_at_85.RUNS` instead (parts 28-49:
against part 27's (a), the rule with fresh sight).
"""

from __future__ import annotations

import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "human_goal")]

from room_measures import loop_laps  # noqa: E402
from rooms_at_85 import RUNS  # noqa: E402

AS_IT_IS = "the map rule as it is"
SEEDS = ("seed100", "seed101")


def main() -> None:
    against = AS_IT_IS
    if "--against" in sys.argv:
        against = sys.argv[sys.argv.index("--against") + 1]
        if against not in RUNS:
            raise SystemExit(f"--against: no run {against!r}")
    base = {seed: loop_laps(RUNS[against] / seed) for seed in SEEDS}
    print("| run | loop laps | won | lost |")
    print("|---|---|---|---|")
    for name, folder in RUNS.items():
        if not name.startswith("the map rule") or name == against or not folder.is_dir():
            continue
        lapped = won = lost = total = 0
        for seed in SEEDS:
            laps = loop_laps(folder / seed)
            if laps.keys() != base[seed].keys():
                raise SystemExit(f"{folder / seed}: not the trials of {against}")
            for key, success in laps.items():
                lapped += success
                total += 1
                won += success and not base[seed][key]
                lost += base[seed][key] and not success
        print(f"| {name} | {lapped}/{total} | {won} | {lost} |")


if __name__ == "__main__":
    main()
