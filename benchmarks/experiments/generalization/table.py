"""The generalization table: every condition of the study and the two hand-written rules, pooled
over seeds, with the teacher of each row and the rule on the same inputs beside it.

Reads the study's jobs (``results/generalization/<condition>/seed<k>/results.json``) and the
rules' (``results/rules/<rule>/seed<k>/results.json``, written by ``rules.py``) and writes
``results/table.md``: procedural test-loop laps pooled with a 95 % Wilson interval and by the
loop's sharpest turn, testing-track laps, and per repetition the human's commands (corrections
included) and the robot's driving time while learning (the demonstration, the learner's own
driving and, for ``direct`` and ``mu-plus-one``, evolution on the robot), with the put-backs
those need.

    .venv/bin/python benchmarks/experiments/generalization/table.py
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from lfd_track.study.stats import rate_summary

HERE = Path(__file__).resolve().parent
STUDY = HERE / "results" / "generalization"
RULES = HERE / "results" / "rules"
OUT = HERE / "results" / "table.md"
BINS = ("<=60", "60-100", "100-135", ">135")

#: Who teaches each row, and the hand-written rule on the same inputs.
PAPER_HUMAN = "the paper's human model (centreline; default delays and lapses)"
ROWS: list[tuple[str, str, str, str]] = [
    # (row, folder, taught by, the rule on the same inputs)
    ("paper", "paper", f"learned from {PAPER_HUMAN}", "road-rule"),
    ("online", "online", f"learned from {PAPER_HUMAN}, with corrections", "road-rule"),
    ("hg-dagger", "hg-dagger", f"learned from {PAPER_HUMAN}, with interventions", "road-rule"),
    ("bc", "bc", f"learned from {PAPER_HUMAN}", "road-rule"),
    ("cma-es", "cma-es", f"learned from {PAPER_HUMAN}", "road-rule"),
    ("dagger", "dagger", f"learned from {PAPER_HUMAN}, relabelling", "road-rule"),
    ("direct", "direct", "no teacher: evolved on progress along the training track", "road-rule"),
    ("mu-plus-one", "mu-plus-one", "no teacher: evolved on board, never reset", "road-rule"),
    (
        "chosen",
        "chosen",
        "distilled from a hand-written rule on its own inputs (the map rule, no delays or lapses)",
        "map-rule",
    ),
]
RULE_ROWS = {
    "road-rule": "hand-written rule on the 40 road values and the last bend; learns nothing",
    "map-rule": "hand-written rule on the fresh_felt map's three inputs; learns nothing",
}


def _jobs(folder: Path) -> list[dict[str, Any]]:
    return [json.loads(p.read_text()) for p in sorted(folder.glob("seed*/results.json"))]


def pooled(jobs: list[dict[str, Any]]) -> dict[str, Any]:
    """Loop laps (pooled and by sharpest turn), testing laps and effort over ``jobs``."""
    loops = [0, 0]
    bins = {b: [0, 0] for b in BINS}
    testing = [0, 0]
    commands = robot_s = put_backs = 0.0
    repetitions = 0
    for r in jobs:
        section = r["random_loops"]
        loops[0] += section["successes"]
        loops[1] += section["laps"]
        for b in BINS:
            row = section["by_sharpest_turn"].get(b, {"successes": 0, "laps": 0})
            bins[b][0] += row["successes"]
            bins[b][1] += row["laps"]
        for o in r["outcomes"]:
            if o["track"] == "testing":
                testing[0] += bool(o["success"])
                testing[1] += 1
        effort = r.get("human_effort", {}).get("total", {})
        commands += effort.get("commands", 0) + effort.get("corrections", 0)
        robot_s += effort.get("learning_drive_s", 0.0)
        put_backs += effort.get("put_backs", 0)
        repetitions += int(r["repetitions"])
    return {
        "seeds": len(jobs),
        "loops": loops,
        "bins": bins,
        "testing": testing,
        "commands": commands / max(repetitions, 1),
        "robot_s": robot_s / max(repetitions, 1),
        "put_backs": put_backs / max(repetitions, 1),
    }


def cell(k: int, n: int) -> str:
    if not n:
        return "–"
    low, high = rate_summary(k, n)["ci95"]
    return f"{k}/{n} = {100 * k / n:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"


def main() -> None:
    head = (
        "| row | taught by | rule on the same inputs | test loops | sharpest ≤ 60° | 60–100°"
        " | 100–135° | > 135° | testing track | human commands / rep. | robot time while"
        " learning / rep. |"
    )
    lines = [
        "# The generalization table",
        "",
        "Procedural test loops (10 per repetition, once each way; the same loops and worlds for"
        " every row), testing track 3 laps each way per repetition; seeds 0–2 × 4 repetitions,"
        " pooled, 95 % Wilson intervals. Human commands include corrections; robot time is the"
        " driving the learning needed (demonstration, the learner's own runs, evolution on the"
        " robot). Written by `table.py` from `generalization/` and `rules/`.",
        "",
        head,
        "|" + "---|" * (head.count("|") - 1),
    ]
    rule_cells: dict[str, dict[str, Any]] = {}
    for rule in RULE_ROWS:
        jobs = _jobs(RULES / rule)
        if jobs:
            rule_cells[rule] = pooled(jobs)
    for row, folder, teacher, rule in ROWS:
        jobs = _jobs(STUDY / folder)
        if not jobs:
            continue
        p = pooled(jobs)
        beside = rule_cells.get(rule)
        beside_text = f"{rule}: {cell(*beside['loops'])}" if beside else rule
        effort = f"{p['robot_s']:.0f} s" + (
            f", {p['put_backs']:.0f} put-backs" if p["put_backs"] else ""
        )
        lines.append(
            f"| {row} (seeds {p['seeds']}) | {teacher} | {beside_text} | {cell(*p['loops'])} | "
            + " | ".join(cell(*p["bins"][b]) for b in BINS)
            + f" | {cell(*p['testing'])} | {p['commands']:.0f} | {effort} |"
        )
    for rule, p in rule_cells.items():
        lines.append(
            f"| {rule} (seeds {p['seeds']}) | {RULE_ROWS[rule]} | – | {cell(*p['loops'])} | "
            + " | ".join(cell(*p["bins"][b]) for b in BINS)
            + f" | {cell(*p['testing'])} | as paper (the demonstration its library is learned"
            " from) | as paper |"
        )
    OUT.write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
