"""Rounds 21-27 read lap by lap: each world against the paper world on the very same laps.

Every world of rounds 21-27 on one seed drives the same 200 validation laps (that seed,
repetitions 0-9, ten loops once each way; seed 100, and seed 101 for rounds 25 and 27), so two worlds can be compared lap by lap: the laps one world laps and the
other does not (lost) and the other way round (gained). With ``n`` such discordant laps the net
difference moves by about ``sqrt(n)`` between draws of the same worlds (the sign test's spread);
``z`` = net / sqrt(n). Reads the committed results only; runs nothing.

    .venv/bin/python benchmarks/experiments/human_goal/round24/paired_laps.py

Writes ``results/paired_laps.md``.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
GOAL = HERE.parent
sys.path.insert(0, str(GOAL))
from room_measures import loop_laps, write_page  # noqa: E402

OUT = HERE / "results"
R21, R22, R23, R25, R26, R27 = (GOAL / f"round{k}" / "results" for k in (21, 22, 23, 25, 26, 27))
R24 = HERE / "results"


def learned(folder: Path, world: str) -> Path:
    """The results of round 20's winner with the measured motion in ``world`` under ``folder``."""
    return folder / f"{world}.round20+visual"


PARTS, QUARTERS, CAST = R22 / "room_parts", R23 / "room_quarters", R26 / "cast"
BALANCE = R27 / "balance" / "rooms.round20+visual+balance"
#: (label, baseline folder, world folder): the learned policy, then the rule on the same map.
PAIRS = [
    ("learned: look only", learned(PARTS, "paper"), learned(PARTS, "look")),
    ("learned: mount and treads only", learned(PARTS, "paper"), learned(PARTS, "mount")),
    ("learned: camera only", learned(PARTS, "paper"), learned(QUARTERS, "camera")),
    ("learned: treads only", learned(PARTS, "paper"), learned(QUARTERS, "treads")),
    ("learned: full room", learned(PARTS, "paper"), learned(PARTS, "rooms")),
    (
        "learned, full room: library levels (round 21)",
        learned(R21 / "rooms_round21", "rooms"),
        R21 / "rooms_round21/rooms.round20+visual+levels",
    ),
    (
        "learned, full room: without its cast (round 26)",
        learned(PARTS, "rooms"),
        learned(CAST, "rooms_nocast"),
    ),
    (
        "learned, look only: without its cast (round 26)",
        learned(PARTS, "look"),
        learned(CAST, "look_nocast"),
    ),
    (
        "learned, full room: colour balance (round 27, seed 100)",
        learned(PARTS, "rooms"),
        BALANCE / "seed100",
    ),
    (
        "learned, full room: colour balance (round 27, seed 101)",
        learned(R25 / "rooms_round25", "rooms"),
        BALANCE / "seed101",
    ),
    (
        "learned, paper world: colour balance (round 27)",
        learned(PARTS, "paper"),
        R27 / "balance_paper" / "paper.round20+visual+balance",
    ),
    ("rule: look only", R22 / "rules_paper", R22 / "rules_look"),
    ("rule: mount and treads only", R22 / "rules_paper", R22 / "rules_mount"),
    ("rule: camera only", R22 / "rules_paper", R23 / "rules_camera"),
    ("rule: treads only", R22 / "rules_paper", R23 / "rules_treads"),
    ("rule: full room", R22 / "rules_paper", R22 / "rules_rooms"),
    ("rule, look only: library levels", R22 / "rules_look", R23 / "rules_levels_look"),
    ("rule, full room: library levels", R22 / "rules_rooms", R23 / "rules_levels_rooms"),
    (
        "rule, full room: without its cast (round 26)",
        R22 / "rules_rooms",
        R26 / "rules_rooms_nocast",
    ),
    ("rule, look only: without its cast (round 26)", R22 / "rules_look", R26 / "rules_look_nocast"),
    (
        "rule, full room: colour balance (round 27, seed 100)",
        R22 / "rules_rooms",
        R27 / "rules_balance" / "map-rule" / "seed100",
    ),
    (
        "rule, full room: colour balance (round 27, seed 101)",
        R25 / "rules_rooms",
        R27 / "rules_balance" / "map-rule" / "seed101",
    ),
    ("rule, paper world: nominal motion", R22 / "rules_paper", R24 / "rules_nominal_paper"),
    ("rule, look only: nominal motion", R22 / "rules_look", R24 / "rules_nominal_look"),
]


def main() -> None:
    lines = [
        "# Rounds 21-27 lap by lap against the same laps elsewhere",
        "",
        "Of the 200 validation laps: lapped in the first world and not in the second (lost), the",
        "other way round (gained); z = net / sqrt(lost + gained).",
        "",
        "| comparison | first | second | lost | gained | net | z |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, first, second in PAIRS:
        a, b = loop_laps(first), loop_laps(second)
        if set(a) != set(b) or len(a) != 200:
            raise SystemExit(f"{label}: the two folders do not hold the same 200 laps")
        lost = sum(a[k] and not b[k] for k in a)
        gained = sum(b[k] and not a[k] for k in a)
        z = (gained - lost) / math.sqrt(lost + gained) if lost + gained else 0.0
        lines.append(
            f"| {label} | {sum(a.values())} | {sum(b.values())} | {lost} | {gained}"
            f" | {gained - lost:+d} | {z:+.1f} |"
        )
    write_page(OUT / "paired_laps.md", lines)


if __name__ == "__main__":
    main()
