"""The teacher's ceiling on the procedural test loops, and the distribution's turning angles.

The scripted human with its default traits (``lfd_track.benchmark.loops.teacher_lap``: the very
check that admits a loop to a benchmark's score) drives test loops 0..N-1 once each way in the
paper preset, each direction in its own world. Writes ``results/teacher_ceiling.json`` and
``.md`` (laps, failures by loop with its sharpest turn and width), and ``results/turn_angles.png``
with ``results/turn_angles.md`` (histograms of every corner's turning angle and of each loop's
sharpest turn, their counts beside the picture).

    .venv/bin/python benchmarks/experiments/generalization/teacher_ceiling.py --loops 300 --workers 2
"""

from __future__ import annotations

import argparse
import json
import math
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from lfd_track.benchmark.loops import teacher_lap
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.study.stats import wilson_interval
from lfd_track.world.loops import loop_name, sharpest_turn_deg
from lfd_track.world.track import loop_track

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results"
CEILING_SEED = 20261203
"""The worlds of every loop and direction are drawn from this (with the loop's index)."""
PRESET = "paper"


def world_seed(index: int, reverse: bool) -> int:
    """The world of test loop ``index`` in one direction."""
    state = np.random.SeedSequence([CEILING_SEED, index, int(reverse)]).generate_state(2)
    return int(state[0]) << 30 ^ int(state[1])


def drive(index: int) -> dict[str, Any]:
    """The teacher's two laps of test loop ``index``, with the loop's facts."""
    name = loop_name("test", index)
    track = loop_track("test", index)
    laps = {}
    for reverse, direction in ((False, "ccw"), (True, "cw")):
        env = LfDTrackEnv(track=name, reverse=reverse, preset=PRESET)
        laps[direction] = teacher_lap(env, world_seed(index, reverse))
        env.close()
    return {
        "loop": name,
        "corners": len(track.corners),
        "width_m": track.width_m,
        "perimeter_m": round(track.length_m, 3),
        "turns_deg": [round(c.turn_deg, 2) for c in track.corners],
        "sharpest_turn_deg": round(sharpest_turn_deg(track), 2),
        "laps": laps,
    }


def histogram(values: list[float], edges: np.ndarray) -> list[int]:
    counts, _ = np.histogram(np.asarray(values), bins=edges)
    return [int(c) for c in counts]


def draw_histograms(panels: list[tuple[str, np.ndarray, list[int]]]) -> np.ndarray:
    """Bar charts stacked vertically, one per (title, bin edges, counts)."""
    width, height, margin = 900, 260, 40
    picture = np.full((height * len(panels), width, 3), 255, np.uint8)
    for p, (title, edges, counts) in enumerate(panels):
        top = p * height
        cv2.putText(picture, title, (margin, top + 24), cv2.FONT_HERSHEY_SIMPLEX, 0.55, 0, 1)
        base = top + height - margin
        peak = max(counts) or 1
        bar_w = (width - 2 * margin) / len(counts)
        for i, count in enumerate(counts):
            x0 = int(margin + i * bar_w)
            x1 = int(margin + (i + 1) * bar_w) - 2
            y0 = base - int((height - 2 * margin - 20) * count / peak)
            cv2.rectangle(picture, (x0, y0), (x1, base), (180, 120, 40), -1)
        cv2.line(picture, (margin, base), (width - margin, base), (0, 0, 0), 1)
        for i in range(0, len(edges), max(1, len(edges) // 10)):
            x = int(margin + i * bar_w)
            cv2.putText(
                picture, f"{edges[i]:g}", (x - 10, base + 16), cv2.FONT_HERSHEY_SIMPLEX, 0.4, 0, 1
            )
        cv2.putText(
            picture,
            f"max {peak}",
            (width - margin - 80, top + 24),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.45,
            0,
            1,
        )
    return picture


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--loops", type=int, default=300)
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    t0 = time.perf_counter()
    with ProcessPoolExecutor(max_workers=args.workers) as pool:
        loops = list(pool.map(drive, range(args.loops), chunksize=4))
    wall = time.perf_counter() - t0
    both = [lp for lp in loops if all(lap["success"] for lap in lp["laps"].values())]
    laps = [lap for lp in loops for lap in lp["laps"].values()]
    lapped = sum(lap["success"] for lap in laps)
    low, high = wilson_interval(len(both), len(loops))
    failed = [lp for lp in loops if lp not in both]
    summary = {
        "split": "test",
        "loops": len(loops),
        "lapped_both_ways": len(both),
        "share_lapped_both_ways": len(both) / len(loops),
        "ci95": [low, high],
        "laps": len(laps),
        "laps_lapped": lapped,
        "excluded_share": len(failed) / len(loops),
        "wall_s": round(wall, 1),
        "workers": args.workers,
        "world_seed": CEILING_SEED,
        "preset": PRESET,
        "loops_detail": loops,
    }
    RESULTS.mkdir(exist_ok=True)
    (RESULTS / "teacher_ceiling.json").write_text(json.dumps(summary, indent=1) + "\n")
    lines = [
        "# The teacher's ceiling on the test split",
        "",
        f"The scripted human (default traits) on test loops 0–{len(loops) - 1}, once each way,"
        f" preset `{PRESET}`: **{len(both)}/{len(loops)} loops lapped both ways"
        f" ({len(both) / len(loops):.1%}, 95 % Wilson {low:.1%}–{high:.1%})**; {lapped}/{len(laps)}"
        f" laps. Excluded by the rule: {len(failed)} loops ({len(failed) / len(loops):.1%}).",
        f"Wall time {wall:.0f} s on {args.workers} workers.",
        "",
    ]
    if failed:
        lines += [
            "| loop | corners | width [m] | sharpest turn [°] | ccw | cw |",
            "|---|---|---|---|---|---|",
        ]
        for lp in failed:
            cells = [
                "lap" if lap["success"] else str(lap["failure"]) for lap in lp["laps"].values()
            ]
            lines.append(
                f"| {lp['loop']} | {lp['corners']} | {lp['width_m']:.3f}"
                f" | {lp['sharpest_turn_deg']:.1f} | {cells[0]} | {cells[1]} |"
            )
    (RESULTS / "teacher_ceiling.md").write_text("\n".join(lines) + "\n")

    turns = [t for lp in loops for t in lp["turns_deg"]]
    sharpest = [lp["sharpest_turn_deg"] for lp in loops]
    turn_edges = np.arange(-180, 181, 10)
    sharp_edges = np.arange(0, 181, 10)
    turn_counts = histogram(turns, turn_edges)
    sharp_counts = histogram(sharpest, sharp_edges)
    picture = draw_histograms(
        [
            (f"every corner's turning angle [deg], {len(turns)} corners", turn_edges, turn_counts),
            (f"each loop's sharpest turn [deg], {len(loops)} loops", sharp_edges, sharp_counts),
        ]
    )
    cv2.imwrite(str(RESULTS / "turn_angles.png"), picture)
    widths = [lp["width_m"] for lp in loops]
    corners = [lp["corners"] for lp in loops]
    table = [
        "# Turning angles of the test split",
        "",
        f"Test loops 0–{len(loops) - 1}: {len(turns)} corners; left turns positive. "
        f"Right turns: {sum(t < 0 for t in turns)} ({sum(t < 0 for t in turns) / len(turns):.1%});"
        f" corners per loop {min(corners)}–{max(corners)} (mean {np.mean(corners):.1f}); widths"
        f" {min(widths):.3f}–{max(widths):.3f} m; |turn| {min(abs(t) for t in turns):.1f}–"
        f"{max(abs(t) for t in turns):.1f}°. Picture: `turn_angles.png`.",
        "",
        "| turn [°] | corners |",
        "|---|---|",
        *(
            f"| {turn_edges[i]:g} to {turn_edges[i + 1]:g} | {c} |"
            for i, c in enumerate(turn_counts)
            if c
        ),
        "",
        "| sharpest turn of the loop [°] | loops |",
        "|---|---|",
        *(
            f"| {sharp_edges[i]:g} to {sharp_edges[i + 1]:g} | {c} |"
            for i, c in enumerate(sharp_counts)
            if c
        ),
        "",
    ]
    (RESULTS / "turn_angles.md").write_text("\n".join(table))
    print("\n".join(lines))
    print(
        f"mean |turn| {np.mean(np.abs(turns)):.1f} deg; {math.fsum(sharpest) / len(sharpest):.1f}"
    )


if __name__ == "__main__":
    main()
