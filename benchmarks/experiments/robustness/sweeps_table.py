"""The sweeps table (README.md, part 3): each one-change world without and with calibration.

Reads ``results/sweeps/<point>.<geometry>/seed<k>/results.json`` and the paper world's
``results/rooms/paper-world.chosen+levels/`` (the same configuration, seeds, repetitions and
loops) and writes ``results/sweeps_table.md``: per point, procedural test-loop laps and
testing-track laps with 95 % Wilson intervals for the map assuming the paper's robot and for the
calibrated map, the calibrations' measured step and pivot (median over the repetitions, against
the world's), the failed repetitions, and the verdict of the rule written before the run (with
calibration, no point's pooled loop-lap rate more than 10 points below the paper world's).

    .venv/bin/python benchmarks/experiments/robustness/sweeps_table.py
"""

from __future__ import annotations

import json
import statistics
from pathlib import Path
from typing import Any

from lfd_track.envs.presets import load_preset
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.study.stats import rate_summary
from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
SWEEPS = HERE / "results" / "sweeps"
PAPER_WORLD = HERE / "results" / "rooms" / "paper-world.chosen+levels"
OUT = HERE / "results" / "sweeps_table.md"
POINTS = (
    "pivot_slow",
    "pivot_fast",
    "forward_slow",
    "forward_fast",
    "slip",
    "pitch_26",
    "pitch_34",
    "height_28",
    "height_34",
)
GEOMETRIES = ("paper-geometry", "calibrated")
MARGIN = 0.10  # with calibration: at most 10 points below the paper world


def _jobs(folder: Path) -> list[dict[str, Any]]:
    return [
        json.loads(p.read_text(encoding="utf-8")) for p in sorted(folder.glob("seed*/results.json"))
    ]


def _count(jobs: list[dict[str, Any]], loops: bool) -> tuple[int, int]:
    chosen = [
        o
        for j in jobs
        for o in j["outcomes"]
        if (o["track"].startswith("random:") if loops else o["track"] == "testing")
    ]
    return sum(bool(o["success"]) for o in chosen), len(chosen)


def _rate(ok: int, n: int) -> str:
    if not n:
        return "–"
    low, high = rate_summary(ok, n)["ci95"]
    return f"{ok}/{n} = {100 * ok / n:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"


def _calibration(jobs: list[dict[str, Any]], point: str) -> str:
    measured = [c for j in jobs for c in j.get("calibrations", []) if c]
    if not measured:
        return "–"
    world = MapGeometry.from_preset(load_preset(str(HERE / "presets" / f"{point}.toml")))
    step = statistics.median(c["step_m"] for c in measured)
    pivot = statistics.median(c["pivot_deg"] for c in measured)
    return (
        f"{step:.3f} m, {pivot:.1f}° of {len(measured)} (world {world.step_m:.3f} m,"
        f" {world.pivot_deg:.1f}°)"
    )


def main() -> None:
    paper = _count(_jobs(PAPER_WORLD), True)
    paper_rate = paper[0] / paper[1]
    lines = [
        "# Sweeps: one change to the paper world, the map without and with calibration",
        "",
        f"The paper world (`rooms.toml`, `paper-world.chosen+levels`): test loops {_rate(*paper)},"
        f" testing track {_rate(*_count(_jobs(PAPER_WORLD), False))}.",
        "",
        "| point | test loops, paper geometry | test loops, calibrated | testing, paper geometry |"
        " testing, calibrated | calibrated: points below the paper world | measured (median) |"
        " failed repetitions |",
        "|---|---|---|---|---|---|---|---|",
    ]
    worst = None
    for point in POINTS:
        jobs = {g: _jobs(SWEEPS / f"{point}.{g}") for g in GEOMETRIES}
        loops = {g: _count(jobs[g], True) for g in GEOMETRIES}
        testing = {g: _count(jobs[g], False) for g in GEOMETRIES}
        ok, n = loops["calibrated"]
        below = None if not n else 100 * (paper_rate - ok / n)
        if below is not None:
            worst = below if worst is None else max(worst, below)
        failed = [
            f"{g} seed {j['seed']} rep. {f['repetition']}: {f['failed']}"
            for g in GEOMETRIES
            for j in jobs[g]
            for f in j.get("failed_repetitions", [])
        ]
        lines.append(
            f"| {point} | {_rate(*loops['paper-geometry'])} | {_rate(ok, n)} |"
            f" {_rate(*testing['paper-geometry'])} | {_rate(*testing['calibrated'])} |"
            f" {'–' if below is None else f'{below:+.0f}'} | {_calibration(jobs['calibrated'], point)} |"
            f" {'; '.join(failed) or 'none'} |"
        )
    met = worst is not None and worst <= 100 * MARGIN
    lines += [
        "",
        f"The rule's verdict: with calibration the worst point lies"
        f" {'–' if worst is None else f'{worst:.0f}'} points below the paper world"
        f" (at most {100 * MARGIN:.0f} allowed): goal {'met' if met else 'not met'}.",
    ]
    text = "\n".join(lines) + "\n"
    atomic_write_text(OUT, text)
    print(text)


if __name__ == "__main__":
    main()
