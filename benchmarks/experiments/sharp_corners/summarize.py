"""The README's tables: laps by sharpest-turn bin per condition and rule, pooled over every
results folder of a condition (``results/<condition>``: repetitions 0-1; ``.more``: 2-5 and
``.more2``: 6-8, run with ``run_rules.py --first``), on all scored loops and on the loops (same
repetition, same loop) that all three conditions scored; and the failure classes.

    .venv/bin/python benchmarks/experiments/sharp_corners/summarize.py
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

from classify import CLASSES, CLOSE_M, corners_over

from lfd_track.benchmark.loops import loop_facts
from lfd_track.study.stats import rate_summary
from lfd_track.world.loops import turn_bin

HERE = Path(__file__).resolve().parent
CONDITIONS = ("paper", "wide", "half_pivot")
RULES = ("map-rule", "road-rule")
BINS = ("<=60", "60-100", "100-135", ">135")


def cell(k: int, n: int) -> str:
    if not n:
        return "–"
    low, high = rate_summary(k, n)["ci95"]
    return f"{k}/{n} = {k / n:.0%} [{low:.0%}–{high:.0%}]"


def folders_of(condition: str) -> tuple[str, ...]:
    return (condition, f"{condition}.more", f"{condition}.more2")


def outcomes(condition: str, rule: str) -> list[dict]:
    found = []
    for folder in sorted(HERE.glob(f"results/{condition}*")):
        if folder.name not in folders_of(condition):
            continue
        path = folder / rule / "seed0" / "results.json"
        if path.exists():
            found += [
                o
                for o in json.loads(path.read_text())["outcomes"]
                if o["track"].startswith("random:")  # not the training-track runs
            ]
    return found


def table(rows: dict[str, list[dict]], title: str) -> list[str]:
    lines = [
        f"| {title} | repetitions | loop laps | " + " | ".join(BINS) + " | >100 pooled |",
        "|---|---|---|" + "---|" * (len(BINS) + 1),
    ]
    for name, laps in rows.items():
        bins = {b: [0, 0] for b in BINS}
        for o in laps:
            b = turn_bin(loop_facts(o["track"])[0])
            bins[b][0] += int(o["success"])
            bins[b][1] += 1
        sharp = [bins["100-135"][i] + bins[">135"][i] for i in (0, 1)]
        reps = len({o["repetition"] for o in laps})
        lines.append(
            f"| {name} | {reps} | {cell(sum(o['success'] for o in laps), len(laps))} | "
            + " | ".join(cell(*bins[b]) for b in BINS)
            + f" | {cell(*sharp)} |"
        )
    return lines


def main() -> None:
    lines: list[str] = []
    for rule in RULES:
        got = {c: outcomes(c, rule) for c in CONDITIONS}
        lines += ["", f"### {rule}, every scored loop lap", ""]
        lines += table(got, "condition")
        key = lambda o: (o["repetition"], o["track"], o["direction"])  # noqa: E731
        common = set.intersection(*({key(o) for o in got[c]} for c in CONDITIONS))
        lines += ["", f"### {rule}, the {len(common)} laps all three conditions scored", ""]
        lines += table(
            {c: [o for o in got[c] if key(o) in common] for c in CONDITIONS}, "condition"
        )
    lines += ["", "### Map rule's failed laps by class (classify.py)", ""]
    lines += ["| condition | failed | " + " | ".join(CLASSES) + " |"]  # fmt: skip
    lines += ["|---|---|" + "---|" * len(CLASSES)]
    for c in CONDITIONS:
        rows = []
        for folder in (HERE / "results" / name for name in folders_of(c)):
            path = folder / "failures_map-rule.json"
            if path.exists():
                rows += json.loads(path.read_text())
        n = Counter(r["cls"] for r in rows)
        lines.append(
            f"| {c} | {len(rows)} | "
            + " | ".join(str(n[k]) for k in CLASSES)  # fmt: skip
            + " |"
        )
    lines += [
        "",
        f"### Map rule at every corner over 100° it came within {CLOSE_M} m of (classify.py)",
        "",
        "| condition | corners | negotiated: first pivot toward / away / none"
        " | not negotiated: toward / away / none | map blank on arrival |",
        "|---|---|---|---|---|",
    ]
    for c in CONDITIONS:
        corners = []
        for name in folders_of(c):
            for path in sorted((HERE / "results" / name / "traces").glob("map-rule_rep*.json")):
                for lap in json.loads(path.read_text()):
                    corners += corners_over(lap)
        cells = []
        for ok in (True, False):
            mine = [x for x in corners if x["negotiated"] == ok]
            n = Counter(x["first_pivot"] for x in mine)
            cells.append(f"{len(mine)}: {n['toward']} / {n['away']} / {n[None]}")
        blank = sum(x["blank_at_v"] for x in corners)
        lines.append(f"| {c} | {len(corners)} | {cells[0]} | {cells[1]} | {blank} |")
    text = "\n".join(lines) + "\n"
    (HERE / "results" / "summary.md").write_text(text, encoding="utf-8")
    print(text)


if __name__ == "__main__":
    main()
