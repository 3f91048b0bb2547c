"""Write the benchmark's outputs: results.json, report.md, trajectories.png and fitness.png."""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any

import numpy as np

from ..plots import fitness_plot, stack_images, trajectory_map, write_png
from ..world.track import load_track
from .runner import DIRECTIONS, BenchmarkConfig, RepetitionResult, config_dict
from .tables import build_results, format_tables, write_report, write_results_json


def _spread(values: list[float], fmt: str = "{:.0f}") -> str:
    if not values:
        return "-"
    return f"{fmt.format(statistics.mean(values))} (min {fmt.format(min(values))}, max {fmt.format(max(values))})"


def demonstration_section(reps: list[RepetitionResult]) -> str:
    """Markdown on the demonstrations and the evolution (DESIGN §6 calibration targets)."""
    cases = [r.demo["cases"] for r in reps]
    models = [r.demo["library_models"] for r in reps]
    forward = [r.demo["counts"]["forward"] / max(r.demo["cases"], 1) for r in reps]
    left = sum(r.demo["turnarounds"].count("left") for r in reps)
    right = sum(r.demo["turnarounds"].count("right") for r in reps)
    off = sum(r.demo["learned_off_felt"] for r in reps)
    acc = [r.training_accuracy for r in reps]
    best = [r.fitness_best[-1] for r in reps if r.fitness_best]
    lines = [
        "## Demonstrations and evolution",
        "",
        "| quantity | ours | target (DESIGN §6) / paper |",
        "|---|---|---|",
        f"| cases per demonstration | {_spread(cases)} | 120–200 (paper: 120–160) |",
        f"| library models at the end | {_spread(models)} | ≥ 40 (paper: ~100) |",
        f"| forward share of commands | {_spread([100 * f for f in forward], '{:.0f}')} % | majority (paper: ~10:1) |",
        f"| turn-arounds left / right | {left} / {right} | equal |",
        f"| library updates from frames with the safe box off the felt | {off} | 0 |",
        f"| GA training accuracy (argmax = command) | {_spread([100 * a for a in acc], '{:.1f}')} % | — |",
        f"| best fitness after 200 generations (lower is better) | {_spread(best, '{:.3f}')} | — |",
        "",
    ]
    return "\n".join(lines)


def effort_section(results: dict[str, Any]) -> str:
    """Markdown on the human's effort and the robot's driving while learning (all methods)."""
    total = results["human_effort"]["total"]
    return "\n".join(
        [
            f"## Learning method `{results['method']}`: human effort (all repetitions)",
            "",
            "| human commands | corrections | takeovers | driving while learning [s] "
            "| of which the policy drove [s] |",
            "|---|---|---|---|---|",
            f"| {total['commands']} | {total['corrections']} | {total['takeovers']} "
            f"| {total['learning_drive_s']:.1f} | {total['autonomous_drive_s']:.1f} |",
            "",
        ]
    )


def test_tracks_section(tracks: dict[str, Any]) -> str:
    """Markdown table of the extra test loops: full laps per direction."""
    lines = ["## Extra test loops", "", "| track | ccw | cw | all |", "|---|---|---|---|"]
    for name, section in tracks.items():
        cells = [f"{section[d]['successes']}/{section[d]['laps']}" for d in ("ccw", "cw")]
        lines.append(
            f"| {name} | {cells[0]} | {cells[1]} | {section['successes']}/{section['laps']} |"
        )
    return "\n".join([*lines, ""])


def write_benchmark_outputs(
    out: Path, config: BenchmarkConfig, reps: list[RepetitionResult], *, wall_s: float, workers: int
) -> str:
    """Write every output file into ``out`` and return the tables as text."""
    outcomes = [o for r in reps for o in r.outcomes]
    timing: dict[str, Any] = {
        "wall": wall_s,
        "workers": workers,
        "learning_sum": sum(r.timing_s["learning"] for r in reps),
        "trials_sum": sum(r.timing_s["trials"] for r in reps),
    }
    results = build_results(
        outcomes, repetitions=config.repetitions, seed=config.seed, timing_s=timing
    )
    results["config"] = config_dict(config)
    results["demonstrations"] = [dict(r.demo, repetition=r.index) for r in reps]
    results["training_accuracy"] = [r.training_accuracy for r in reps]
    results["best_fitness"] = [r.fitness_best[-1] if r.fitness_best else None for r in reps]
    results["method"] = config.method
    results["human_effort"] = {
        "repetitions": [dict(r.effort, repetition=r.index) for r in reps],
        "total": {
            key: sum(r.effort.get(key, 0) for r in reps)
            for key in (
                "commands",
                "corrections",
                "takeovers",
                "learning_drive_s",
                "autonomous_drive_s",
            )
        },
    }

    pictures = []
    for track_name in ("training", "testing"):
        for track, reverse, direction in DIRECTIONS:
            if track != track_name:
                continue
            chosen = [o for o in outcomes if o.direction == direction and o.trajectory is not None]
            picture = trajectory_map(
                load_track(track, reverse=reverse),
                [o.trajectory for o in chosen],
                [(o.success, o.failure) for o in chosen],
                title=f"{track} {direction}: green success, red failure, orange timeout",
                size_px=640,
            )
            pictures.append(picture)
    rows = [stack_images(pictures[:2]), stack_images(pictures[2:])]
    write_png(str(out / "trajectories.png"), stack_images(rows, vertical=True))

    palette = [
        (31, 119, 180),
        (255, 127, 14),
        (44, 160, 44),
        (214, 39, 40),
        (148, 103, 189),
        (140, 86, 75),
        (227, 119, 194),
        (127, 127, 127),
        (188, 189, 34),
        (23, 190, 207),
    ]
    curves = [
        (f"rep {r.index}", np.asarray(r.fitness_best), palette[r.index % len(palette)])
        for r in reps
    ]
    write_png(
        str(out / "fitness.png"),
        fitness_plot(curves, title="best fitness per generation, one curve per repetition"),
    )

    write_results_json(out / "results.json", results)
    extra = [demonstration_section(reps), effort_section(results)]
    if results.get("test_tracks"):
        extra.append(test_tracks_section(results["test_tracks"]))
    if not config.human.careful:
        extra.insert(
            0,
            "**Careless demonstrator**: the road library kept learning while the safe box was off the felt.\n",
        )
    write_report(out, results, extra_sections=extra)
    return format_tables(results)
