"""A candidate of a rooms round against the incumbent (round 33's winner), room by room and lap
by lap, on the 20 validation rooms of seeds 100-101 or, with ``--incumbent`` and ``--seeds``, on
other kept rooms (a frozen winner's test rooms against the goal's configuration's); committed
results only: each round's rule decides.

    .venv/bin/python benchmarks/experiments/human_goal/against_incumbent.py CONDITION_FOLDER --label TEXT --out PAGE.md

e.g. round 37's (``round37/README.md``)::

    .venv/bin/python benchmarks/experiments/human_goal/against_incumbent.py benchmarks/experiments/human_goal/round37/results/checked/rooms.round33+checked --label "one HG-DAgger round on random:train:35" --out benchmarks/experiments/human_goal/round37/results/compare.md

writes the page: per run the loop laps by sharpest-turn bin, the training-track runs, the rooms at
85 % of their loop laps, the human's commands and takeovers per repetition; every room's loop
laps, with the candidate's commands, corrections and intervention cases; the laps the candidate
won and lost, and the rooms that reached the bar or fell under it.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE / "test_round20")]

from room_measures import (  # noqa: E402
    BINS,
    laps_by_bin,
    loop_bins,
    seed_jobs,
    seeds_loop_outcomes,
    write_page,
)
from rooms_breakdown import BAR  # noqa: E402

SEEDS = (100, 101)
INCUMBENT = HERE / "round33" / "results" / "sight" / "rooms.round27+sight"
"""Round 33's winner on these rooms: the incumbent of every rooms round since."""


def effort(results: dict[int, dict]) -> str:
    """The table's cells of the mean human commands and takeovers per repetition ("–" for a
    rules run, which has no teaching of its own)."""
    if any("human_effort" not in job for job in results.values()):
        return "– | –"
    reps = [r for job in results.values() for r in job["human_effort"]["repetitions"]]
    commands = float(np.mean([r["commands"] for r in reps]))
    return f"{commands:.2f} | {float(np.mean([r['takeovers'] for r in reps])):.1f}"


def round_records(results: dict[int, dict]) -> dict[tuple[int, int], tuple[int, int, int]]:
    """Per room (seed, repetition): (human commands, corrections, the rounds' intervention
    cases); empty for a rules run."""
    out = {}
    for seed, job in results.items():
        if "human_effort" not in job:
            continue  # a rules run
        efforts = {r["repetition"]: r for r in job["human_effort"]["repetitions"]}
        for demo in job["demonstrations"]:
            rep = demo["repetition"]
            cases = sum(r["intervention_cases"] for r in demo.get("rounds", []))
            out[(seed, rep)] = (efforts[rep]["commands"], efforts[rep]["corrections"], cases)
    return out


def track_laps(results: dict[int, dict], track: str) -> tuple[int, int]:
    """(runs lapped, runs driven) of the named ``track`` ("training", "testing"; 0, 0: none
    driven)."""
    runs = [
        bool(o["success"])
        for job in results.values()
        for o in job["outcomes"]
        if o["track"] == track
    ]
    return sum(runs), len(runs)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("candidate", type=Path, help="the candidate condition's results folder")
    parser.add_argument("--label", required=True, help="the candidate's name in the tables")
    parser.add_argument("--out", type=Path, required=True, help="the page to write")
    parser.add_argument(
        "--incumbent",
        type=Path,
        default=INCUMBENT,
        help="the incumbent condition's results folder (default: round 33's winner on the 20"
        " validation rooms)",
    )
    parser.add_argument(
        "--incumbent-label", default="round 33's winner", help="the incumbent's name in the tables"
    )
    parser.add_argument("--seeds", type=int, nargs="+", default=list(SEEDS), help="the seeds")
    args = parser.parse_args()
    seeds = tuple(args.seeds)
    runs = {
        f"incumbent ({args.incumbent_label})": args.incumbent,
        f"candidate ({args.label})": args.candidate,
    }
    results = {name: seed_jobs(folder, seeds) for name, folder in runs.items()}
    laps = {name: seeds_loop_outcomes(jobs) for name, jobs in results.items()}
    incumbent, candidate = laps.values()
    if incumbent.keys() != candidate.keys():
        raise SystemExit("the two runs did not drive the same trials")
    sharpest = loop_bins(incumbent)
    rooms = sorted({k[:2] for k in incumbent})
    per_room = {
        name: {room: sum(o["success"] for k, o in run.items() if k[:2] == room) for room in rooms}
        for name, run in laps.items()
    }
    n = sum(1 for k in incumbent if k[:2] == rooms[0])
    need = math.ceil(BAR * n)
    md = ["# The candidate against the incumbent, room by room", ""]
    seed_list = ", ".join(str(seed) for seed in seeds)
    md += [f"{len(rooms)} rooms (seeds {seed_list}), {n} loop laps a room; at the bar with {need}."]
    md += [""]
    md += ["| run | loop laps | " + " | ".join(BINS) + " | training track | testing track |"]
    md[-1] += " rooms at 85 % | human commands / rep. | takeovers / rep. |"
    md += ["|---" * (7 + len(BINS)) + "|"]
    for name, run in laps.items():
        bins = laps_by_bin(run, sharpest)
        training, _ = track_laps(results[name], "training")
        testing, driven = track_laps(results[name], "testing")
        at_bar = sum(per_room[name][room] >= need for room in rooms)
        cells = " | ".join(f"{k}/{m}" for k, m in bins.values())
        md += [
            f"| {name} | {sum(per_room[name].values())}/{n * len(rooms)} | {cells} | "
            f"{training}/{6 * len(rooms)} | {f'{testing}/{driven}' if driven else '–'} | "
            f"{at_bar} of {len(rooms)} | {effort(results[name])} |"
        ]
    won = sum(not o["success"] and candidate[k]["success"] for k, o in incumbent.items())
    lost = sum(o["success"] and not candidate[k]["success"] for k, o in incumbent.items())
    first, second = per_room.values()
    reached = [r for r in rooms if first[r] < need <= second[r]]
    fell = [r for r in rooms if second[r] < need <= first[r]]
    md += ["", f"Lap by lap: the candidate won {won} laps and lost {lost}.", ""]
    md += [
        f"Rooms that reached the bar: {reached or 'none'}; rooms that fell under: {fell or 'none'}."
    ]
    records = round_records(results[f"candidate ({args.label})"])
    md += ["", "| room (seed, repetition) | incumbent | candidate | the candidate's human commands"]
    md[-1] += " | corrections | the round's intervention cases |"
    md += ["|---" * 6 + "|"]
    for room in rooms:
        cells = [f"**{k}**" if k < need else str(k) for k in (first[room], second[room])]
        taught = " | ".join(str(x) for x in records[room]) if room in records else "– | – | –"
        md += [f"| {room[0]}, {room[1]} | {cells[0]} | {cells[1]} | {taught} |"]
    md += ["", "(bold: under the bar)", ""]
    if records:  # the candidate was taught (not a rules run)
        corrected = sum(records[r][1] > 0 for r in rooms)
        if any(records[r][2] for r in rooms):  # it had rounds of interventions
            md += [f"Rooms where the human took control back in a round: {corrected} of"]
            md[-1] += f" {len(rooms)}."
        over = sum(records[r][0] > 360 for r in rooms)
        md += [f"Repetitions over 360 human commands: {over} (the rule reads the mean)."]
    write_page(args.out, md)


if __name__ == "__main__":
    main()
