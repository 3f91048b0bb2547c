"""Part 51 of ``README.md``: the every-room bar on the 30 rooms of ``rooms30.toml`` (seeds
102-104, validation loops), for the map rule and the goal's learner, each on the goal's map and on
part 12's oracle's map (committed results only; it chooses nothing).

    .venv/bin/python benchmarks/experiments/sharp_corners/rooms30.py

writes ``results/rooms30_summary.md``: per driver the loop laps by sharpest-turn bin, the rooms
at 85 % of their loop laps against the rooms expected at the pooled rate if every room lapped at
it (and the spread of the rooms' laps against the binomial's); every room's laps; and each lap
an oracle run loses in a room it leaves under 85 % (its loop's sharpest turn, how it ended, and
whether the drivers on the goal's map lapped it). Part 52 adds the goal's learner taught again
in every room (``reteach.py``), on each map, and part 53 the same demonstrations refitted: those
runs' rows, and per pair the rooms under the bar in either teaching and in both, the laps whose
outcome differs, and the two teachings' room laps ranked against each other.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE.parent / "human_goal"), str(HERE.parent / "human_goal" / "test_round20")]

from room_measures import (  # noqa: E402
    BINS,
    laps_by_bin,
    loop_bins,
    seed_jobs,
    seeds_loop_outcomes,
    spearman,
    write_page,
)
from rooms_breakdown import BAR, against_chance  # noqa: E402

RESULTS = HERE / "results"
CONDITION = "rooms.round27+sight"
#: driver: its results folder (a ``seed<N>/results.json`` per seed)
DRIVERS = {
    "(a) the map rule, the goal's map": RESULTS / "rooms30_rules" / "sight" / "map-rule",
    "(b) the map rule, the oracle's map": RESULTS
    / "rooms30_rules"
    / "sight_cover_from_30cm"
    / "map-rule",
    "(c) the goal's learner": RESULTS / "rooms30" / CONDITION,
    "(d) the goal's learner, the oracle's map": RESULTS
    / "oracle_visited"
    / "learner_rooms30"
    / CONDITION,
    "(c') the goal's learner, taught again (part 52)": RESULTS / "rooms30_again" / CONDITION,
    "(d') the goal's learner, the oracle's map, taught again (part 52)": RESULTS
    / "oracle_visited"
    / "learner_rooms30_again"
    / CONDITION,
    "(c'') the goal's learner, the same demonstration refitted (part 53)": RESULTS
    / "rooms30_refit"
    / CONDITION,
}
RULE, ORACLE_RULE, LEARNER, ORACLE_LEARNER, LEARNER_AGAIN, ORACLE_AGAIN, LEARNER_REFIT = DRIVERS
ORACLES = (ORACLE_RULE, ORACLE_LEARNER)
#: parts 52-53: (what changed, the learner taught first, the learner taught again)
TAUGHT_AGAIN = (
    ("the goal's map, taught again", LEARNER, LEARNER_AGAIN),
    ("the oracle's map, taught again", ORACLE_LEARNER, ORACLE_AGAIN),
    ("the goal's map, refitted (part 53)", LEARNER, LEARNER_REFIT),
)
SEEDS = (102, 103, 104)
OUT = RESULTS / "rooms30_summary.md"


def main() -> None:
    runs = {name: seeds_loop_outcomes(seed_jobs(folder, SEEDS)) for name, folder in DRIVERS.items()}
    keys = runs[next(iter(runs))].keys()
    for name, laps in runs.items():
        if laps.keys() != keys:
            raise SystemExit(f"{DRIVERS[name]}: not the trials of the other runs")
    sharpest = loop_bins(runs[next(iter(runs))])
    rooms = sorted({k[:2] for k in keys})
    per_room = {
        name: {room: [0, 0] for room in rooms} for name in runs
    }  # driver: room: [lapped, laps]
    for name, laps in runs.items():
        for key, o in laps.items():
            per_room[name][key[:2]][0] += bool(o["success"])
            per_room[name][key[:2]][1] += 1
    n = per_room[next(iter(runs))][rooms[0]][1]
    need = math.ceil(BAR * n)
    md = ["# Parts 51-53: the every-room bar on 30 rooms nothing was chosen on (seeds 102-104)"]
    md += [""]
    md += [f"Validation loops, {n} loop laps a room; a room is at the bar with {need} or more.", ""]
    md += ["| driver | loop laps | " + " | ".join(BINS) + " | pooled p | rooms at 85 % |"]
    md[-1] += " expected at p | laps' variance | binomial's |"
    md += ["|---" * (7 + len(BINS)) + "|"]
    for name, laps in runs.items():
        bins = laps_by_bin(laps, sharpest)
        done = np.array([per_room[name][room][0] for room in rooms])
        cells = " | ".join(f"{k}/{m}" if m else "–" for k, m in bins.values())
        md += [f"| {name} | {done.sum()}/{n * len(rooms)} | {cells} | {against_chance(done, n)}"]
    md += ["", "Every room's loop laps (seed, repetition):", ""]
    md += ["| room | " + " | ".join(name.split()[0] for name in runs) + " |"]
    md += ["|---" * (1 + len(runs)) + "|"]
    for room in rooms:
        cells = " | ".join(
            f"**{k}**" if k < need else str(k) for k, _ in (per_room[name][room] for name in runs)
        )
        md += [f"| {room[0]}, {room[1]} | {cells} |"]
    md += ["", "(bold: under the bar)", ""]
    md += ["## The laps an oracle run loses in the rooms it leaves under the bar", ""]
    md += ["| driver | room | loop | direction | sharpest turn | ended | (a) | (c) |"]
    md += ["|---|---|---|---|---|---|---|---|"]
    goal_rule, goal_learner = runs[RULE], runs[LEARNER]
    for name in ORACLES:
        for key, o in sorted(runs[name].items()):
            if o["success"] or per_room[name][key[:2]][0] >= need:
                continue
            md += [
                f"| {name.split()[0]} | {key[0]}, {key[1]} | {key[2]} | {key[3]} | "
                f"{sharpest[key[2]]} | "
                f"{o['failure']} | {'lapped' if goal_rule[key]['success'] else 'lost'} | "
                f"{'lapped' if goal_learner[key]['success'] else 'lost'} |"
            ]
    md += ["", "## Parts 52-53: the same rooms taught again", ""]
    md += ["| the second teaching | rooms under the bar, first | second | first's at the bar in"]
    md[-1] += " the second | under in both | newly under | laps that differ | Spearman of rooms |"
    md += ["|---" * 8 + "|"]
    for label, first, again in TAUGHT_AGAIN:
        under = {r for r in rooms if per_room[first][r][0] < need}
        under_again = {r for r in rooms if per_room[again][r][0] < need}
        rho = spearman(
            np.array([per_room[first][r][0] for r in rooms], dtype=float),
            np.array([per_room[again][r][0] for r in rooms], dtype=float),
        )
        differ = sum(o["success"] != runs[again][key]["success"] for key, o in runs[first].items())
        md += [
            f"| {label} | {len(under)} | {len(under_again)} | {len(under - under_again)} of "
            f"{len(under)} | {len(under & under_again)} | {len(under_again - under)} | {differ} | "
            f"{rho:+.2f} |"
        ]
    write_page(OUT, md)


if __name__ == "__main__":
    main()
