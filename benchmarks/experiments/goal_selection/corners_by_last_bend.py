"""Corner failures of a study's loop laps, split by which way the bend before each corner turned.

For every lap of a loop other than the training track, each corner the lap arrived at is put in
one class: ``first`` (no corner before it in the lap, so a last-bend memory holds nothing yet),
``same`` (the corner before it in the lap turns the same way) or ``other`` (it turns the other
way). A lap arrives at a corner when it negotiated every corner before it; its first corner not
negotiated is where it failed (the benchmark's own counting: a lap that turns back on the
straight after a corner is charged to the next corner). This is what a memory of the last bend can and cannot help with
(``lfd_track/policy/memory.py``): it points the right way at ``same`` corners only.

Run: ``.venv/bin/python benchmarks/experiments/goal_selection/corners_by_last_bend.py STUDY_OUT_DIR [--track NAME ...]`` —
prints, per condition, failures / arrivals in each class, pooled over the condition's seeds
(and over every loop lapped, or the ``--track`` ones).
"""

from __future__ import annotations

import argparse
from collections import Counter
from pathlib import Path

from lfd_track.benchmark.schema import read_results
from lfd_track.world.track import load_track

CLASSES = ("first", "same", "other")


def corner_turns(track: str, direction: str) -> dict[str, float]:
    """Turn [deg] (left +) of every corner of ``track`` driven ``ccw`` or ``cw``."""
    loop = load_track(track, reverse=direction == "cw")
    return {c.label: c.turn_deg for c in loop.corners}


def classify(outcomes: list[dict], tracks: set[str] | None = None) -> tuple[Counter, Counter]:
    """(failures, arrivals) per class over the loop laps in ``outcomes`` (results.json's), of
    the loops in ``tracks`` (None: every loop)."""
    failures: Counter = Counter()
    arrivals: Counter = Counter()
    turns_of: dict[tuple[str, str], dict[str, float]] = {}
    for lap in outcomes:
        if lap["track"] == "training" or (tracks is not None and lap["track"] not in tracks):
            continue
        key = (lap["track"], lap["direction"])
        if key not in turns_of:
            turns_of[key] = corner_turns(*key)
        turns = turns_of[key]
        previous = None
        for corner in lap["corner_order"]:
            if previous is None:
                kind = "first"
            else:
                kind = "same" if (turns[corner] > 0) == (turns[previous] > 0) else "other"
            arrivals[kind] += 1
            if corner not in lap["corners_negotiated"]:
                failures[kind] += 1
                break
            previous = corner
    return failures, arrivals


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("study_out", type=Path, help="a study's --out folder")
    parser.add_argument(
        "--track", action="append", help="count only this loop (repeatable; default: every loop)"
    )
    args = parser.parse_args(argv)
    folders = sorted(p for p in args.study_out.iterdir() if p.is_dir())
    if not folders:
        parser.error(f"{args.study_out}: no condition folders")
    print(f"{'condition':<28}" + "".join(f"{c:>14}" for c in CLASSES))
    for folder in folders:
        failures: Counter = Counter()
        arrivals: Counter = Counter()
        for results in sorted(folder.glob("seed*/results.json")):
            outcomes = read_results(results)["outcomes"]
            f, a = classify(outcomes, set(args.track) if args.track else None)
            failures += f
            arrivals += a
        cells = "".join(f"{failures[c]:>7}/{arrivals[c]:<6}" for c in CLASSES)
        print(f"{folder.name:<28}{cells}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
