"""Rounds 21-26 read lap by lap: each world against the paper world on the very same laps.

Every world of rounds 21-26 on seed 100 drives the same 200 validation laps (seed 100, repetitions 0-9, ten
loops once each way), so two worlds can be compared lap by lap: the laps one world laps and the
other does not (lost) and the other way round (gained). With ``n`` such discordant laps the net
difference moves by about ``sqrt(n)`` between draws of the same worlds (the sign test's spread);
``z`` = net / sqrt(n). Reads the committed results only; runs nothing.

    .venv/bin/python benchmarks/experiments/human_goal/round24/paired_laps.py

Writes ``results/paired_laps.md``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

HERE = Path(__file__).resolve().parent
GOAL = HERE.parent
OUT = HERE / "results"
R21, R22, R23, R26 = (GOAL / f"round{k}" / "results" for k in (21, 22, 23, 26))
R24 = HERE / "results"
#: (label, baseline folder, world folder): the learned policy, then the rule on the same map.
PAIRS = [
    (
        "learned: look only",
        R22 / "room_parts/paper.round20+visual",
        R22 / "room_parts/look.round20+visual",
    ),
    (
        "learned: mount and treads only",
        R22 / "room_parts/paper.round20+visual",
        R22 / "room_parts/mount.round20+visual",
    ),
    (
        "learned: camera only",
        R22 / "room_parts/paper.round20+visual",
        R23 / "room_quarters/camera.round20+visual",
    ),
    (
        "learned: treads only",
        R22 / "room_parts/paper.round20+visual",
        R23 / "room_quarters/treads.round20+visual",
    ),
    (
        "learned: full room",
        R22 / "room_parts/paper.round20+visual",
        R22 / "room_parts/rooms.round20+visual",
    ),
    (
        "learned, full room: library levels (round 21)",
        R21 / "rooms_round21/rooms.round20+visual",
        R21 / "rooms_round21/rooms.round20+visual+levels",
    ),
    (
        "learned, full room: without its cast (round 26)",
        R22 / "room_parts/rooms.round20+visual",
        R26 / "cast/rooms_nocast.round20+visual",
    ),
    (
        "learned, look only: without its cast (round 26)",
        R22 / "room_parts/look.round20+visual",
        R26 / "cast/look_nocast.round20+visual",
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
    ("rule, paper world: nominal motion", R22 / "rules_paper", R24 / "rules_nominal_paper"),
    ("rule, look only: nominal motion", R22 / "rules_look", R24 / "rules_nominal_look"),
]


def laps(folder: Path) -> dict[tuple, bool]:
    """Each loop lap's success, keyed by (repetition, loop, direction, trial)."""
    out: dict[tuple, bool] = {}
    for path in sorted(folder.rglob("results.json")):
        for o in json.loads(path.read_text(encoding="utf-8"))["outcomes"]:
            if o["track"] not in ("training", "testing"):
                out[(o["repetition"], o["track"], o["direction"], o.get("trial", 0))] = o["success"]
    return out


def main() -> None:
    lines = [
        "# Rounds 21-26 lap by lap against the same laps elsewhere",
        "",
        "Of the 200 validation laps: lapped in the first world and not in the second (lost), the",
        "other way round (gained); z = net / sqrt(lost + gained).",
        "",
        "| comparison | first | second | lost | gained | net | z |",
        "|---|---|---|---|---|---|---|",
    ]
    for label, first, second in PAIRS:
        a, b = laps(first), laps(second)
        if set(a) != set(b) or len(a) != 200:
            raise SystemExit(f"{label}: the two folders do not hold the same 200 laps")
        lost = sum(a[k] and not b[k] for k in a)
        gained = sum(b[k] and not a[k] for k in a)
        z = (gained - lost) / math.sqrt(lost + gained) if lost + gained else 0.0
        lines.append(
            f"| {label} | {sum(a.values())} | {sum(b.values())} | {lost} | {gained}"
            f" | {gained - lost:+d} | {z:+.1f} |"
        )
    OUT.mkdir(parents=True, exist_ok=True)
    (OUT / "paired_laps.md").write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
