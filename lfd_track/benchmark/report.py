"""Write the benchmark's outputs: results.json, report.md, trajectories.png and fitness.png (each
picture with its numbers beside it: trajectories.csv, fitness.csv)."""

from __future__ import annotations

import statistics
from pathlib import Path
from typing import Any

import numpy as np

from ..envs.presets import load_preset
from ..methods.common import calibrates
from ..policy.features import DEFAULT_FEATURES
from ..study.stats import wilson_interval
from ..utils.provenance import environment
from ..viz.plot_data import fitness_table, trajectories_table, write_picture
from ..viz.plots import (
    DirectionRuns,
    TrackRun,
    fitness_notes,
    fitness_plot,
    trajectory_grid,
)
from ..world.episode import EpisodeTracker
from ..world.loops import TURN_BIN_LABELS, WIDTH_BIN_LABELS
from ..world.track import load_track
from .loops import merged_record
from .paper import DIRECTION_TITLES
from .paper import DIRECTIONS as TABLE_DIRECTIONS
from .runner import DIRECTIONS, BenchmarkConfig, RepetitionResult, config_dict
from .schema import read_results
from .tables import (
    TrialOutcome,
    build_results,
    format_tables,
    write_report,
    write_results_json,
)

PALETTE = (
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
)
"""Curve colours of the fitness plot (repetition index modulo 10)."""


def _spread(values: list[float], fmt: str = "{:.0f}") -> str:
    if not values:
        return "-"
    return f"{fmt.format(statistics.mean(values))} (min {fmt.format(min(values))}, max {fmt.format(max(values))})"


def demonstration_section(results: dict[str, Any]) -> str:
    """Markdown on the demonstrations and the evolution, beside the demonstrator's targets.

    Reads the ``demonstrations``, ``training_accuracy`` and ``best_fitness`` lists of a
    results.json dict.
    """
    demos = results.get("demonstrations") or []
    cases = [d["cases"] for d in demos]
    models = [d["library_models"] for d in demos]
    forward = [d["counts"]["forward"] / max(d["cases"], 1) for d in demos]
    left = sum(d["turnarounds"].count("left") for d in demos)
    right = sum(d["turnarounds"].count("right") for d in demos)
    off = sum(d["learned_off_felt"] for d in demos)
    acc = [a for a in results.get("training_accuracy") or [] if a is not None]
    best = [b for b in results.get("best_fitness") or [] if b is not None]
    accuracy_row = "GA training accuracy (argmax = command)"
    fitness_row = "best fitness after 200 generations (lower is better)"
    if results.get("method") in ("direct", "mu-plus-one"):  # evolved without the demonstration
        accuracy_row = "agreement with the demonstration's commands (not learned from)"
        fitness_row = "best fitness: progress along the track [m] (higher is better)"
    lines = [
        "## Demonstrations and evolution",
        "",
        "| quantity | ours | target |",
        "|---|---|---|",
        f"| cases per demonstration | {_spread(cases)} | 120–200 (paper: 120–160) |",
        f"| library models at the end | {_spread(models)} | ≥ 40 (paper: ~100) |",
        f"| forward share of commands | {_spread([100 * f for f in forward], '{:.0f}')} % | majority (paper: ~10:1) |",
        f"| turn-arounds left / right | {left} / {right} | equal |",
        f"| library updates from frames with the safe box off the felt | {off} | 0 |",
        f"| {accuracy_row} | {_spread([100 * a for a in acc], '{:.1f}')} % | — |",
        f"| {fitness_row} | {_spread(best, '{:.3f}')} | — |",
        "",
        "Targets are the calibration goals of the scripted demonstrator"
        ' (`lfd_track/demo/demonstrator.py`; README, "Choices where the paper and the spec are'
        " silent\"), with the paper's own numbers beside them.",
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
            "| human commands | corrections | takeovers | robot driving while learning [s] "
            "| of which the policy drove [s] | put back by hand |",
            "|---|---|---|---|---|---|",
            f"| {total['commands']} | {total['corrections']} | {total['takeovers']} "
            f"| {total['learning_drive_s']:.1f} | {total['autonomous_drive_s']:.1f} "
            f"| {total.get('put_backs', 0)} |",
            "",
            "Robot driving while learning counts every command the robot executed before its"
            " trials (the demonstration's included), whoever gave it; put back by hand counts the"
            " times a person set the robot back on the felt.",
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


def random_loops_section(results: dict[str, Any]) -> str:
    """Markdown: laps of the procedural loops pooled with their 95 % Wilson interval, by
    direction, by the loop's sharpest turn and by strip width, and the teacher's exclusions."""
    section = results["random_loops"]
    split = results.get("config", {}).get("random_split", "?")

    def cell(row: dict[str, Any]) -> str:
        if not row["laps"]:
            return "–"
        low, high = wilson_interval(row["successes"], row["laps"])
        rate = row["successes"] / row["laps"]
        return f"{row['successes']}/{row['laps']} {rate:.0%} [{low:.0%}–{high:.0%}]"

    excluded = section.get("excluded", [])
    drawn = section.get("drawn", section["loops"])
    lines = [
        f"## Procedural loops ({split} split)",
        "",
        f"{section['loops']} loops, each lapped once each way; {len(excluded)} of {drawn} loops"
        " drawn were excluded because the scripted human did not lap them both ways"
        " (lfd_track/benchmark/loops.py).",
        "",
        "| laps | ccw | cw |",
        "|---|---|---|",
        f"| {cell(section)} | {cell(section['ccw'])} | {cell(section['cw'])} |",
        "",
        "| sharpest turn | loops | laps |",
        "|---|---|---|",
        *(
            f"| {label} | {row['loops']} | {cell(row)} |"
            for label, row in ((x, section["by_sharpest_turn"][x]) for x in TURN_BIN_LABELS)
        ),
        "",
        "| strip width [m] | loops | laps |",
        "|---|---|---|",
        *(
            f"| {label} | {row['loops']} | {cell(row)} |"
            for label, row in ((x, section["by_width"][x]) for x in WIDTH_BIN_LABELS)
        ),
        "",
    ]
    return "\n".join(lines)


def plotted_outcomes(
    outcomes: list[TrialOutcome], track: str, direction: str
) -> list[TrialOutcome]:
    """The runs drawn in trajectories.png's panel of ``track`` and ``direction``: those with a
    trajectory (an extra test loop's runs, whose directions are named like the testing track's,
    are not in the picture)."""
    return [
        o
        for o in outcomes
        if o.track == track and o.direction == direction and o.trajectory is not None
    ]


def all_plotted_outcomes(outcomes: list[TrialOutcome]) -> list[TrialOutcome]:
    """Every run drawn in trajectories.png, panel by panel (the rows of trajectories.csv)."""
    return [
        o
        for track, directions in TABLE_DIRECTIONS.items()
        for direction in directions
        for o in plotted_outcomes(outcomes, track, direction)
    ]


def trajectories_picture(
    config: BenchmarkConfig, outcomes: list[TrialOutcome], *, title: str | None = None
) -> np.ndarray:
    """trajectories.png: per direction (the report's order), successes beside the other runs.

    ``title`` heads the picture (default: the repetitions, runs per direction and seed of
    ``config``).
    """
    rules = load_preset(config.preset).episode
    reverse_of = {direction: reverse for _, reverse, direction in DIRECTIONS}
    panels = []
    for track_name, directions in TABLE_DIRECTIONS.items():
        for direction in directions:
            track = load_track(track_name, reverse=reverse_of[direction])
            chosen = plotted_outcomes(outcomes, track_name, direction)
            where = " (laps start at corner 4)" if track_name == "testing" else ""
            panels.append(
                DirectionRuns(
                    title=f"{track_name.capitalize()} track, "
                    f"{DIRECTION_TITLES[direction].lower()}{where}",
                    track=track,
                    runs=[
                        TrackRun(o.trajectory, o.success, o.failure)
                        for o in chosen
                        if o.trajectory is not None  # always: chosen are the runs with one
                    ],
                    finish_m=EpisodeTracker(track, rules).goal_progress_m,
                    start_pose=EpisodeTracker(track, rules).start_pose(),
                )
            )
    reps = config.repetitions
    if title is None:
        title = (
            f"Paths of every autonomous run: {reps} repetition{'s' if reps != 1 else ''} x "
            f"{config.trials_per_direction} per direction, seed {config.seed}"
        )
    return trajectory_grid(panels, title=title)


def fitness_curves(reps: list[RepetitionResult]) -> list[tuple[str, np.ndarray, tuple]]:
    """The curves of fitness.png: (label, fitness per generation or epoch, colour) per repetition
    that learned a controller (a failed one has no curve)."""
    return [
        (f"rep {r.index}", np.asarray(r.fitness_best), PALETTE[r.index % len(PALETTE)])
        for r in reps
        if r.failed is None
    ]


def fitness_x_label(config: BenchmarkConfig) -> str:
    """What fitness.png's x axis counts: epochs of behaviour cloning, evaluations of
    (μ+1)-ONLINE, else generations."""
    return {"bc": "epoch", "mu-plus-one": "evaluation"}.get(config.method, "generation")


def fitness_picture(config: BenchmarkConfig, reps: list[RepetitionResult]) -> np.ndarray:
    """fitness.png: the Algorithm 3 fitness over training, one curve per repetition."""
    curves = fitness_curves(reps)
    if config.method == "bc":
        return fitness_plot(
            curves,
            title="Fitness after each epoch of behaviour cloning, one curve per repetition",
            x_label="epoch",
        )
    if config.method == "cma-es":
        return fitness_plot(
            curves, title="Best fitness of each CMA-ES generation, one curve per repetition"
        )
    if config.method in ("direct", "mu-plus-one"):
        how = "after each generation" if config.method == "direct" else "on board after each"
        return fitness_plot(
            curves,
            title=f"Best fitness {how} {fitness_x_label(config)}, one curve per repetition",
            notes=[
                "fitness: progress along the track's centreline [m], higher is better"
                + (" (minus 1 m per put-back)" if config.method == "mu-plus-one" else "")
            ],
            x_label=fitness_x_label(config),
        )
    return fitness_plot(
        curves,
        title="Best fitness of each generation, one curve per repetition",
        notes=fitness_notes(config.ga.elitism),
    )


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
    loop_record = merged_record((r.index, r.random_loops) for r in reps)
    results = build_results(
        outcomes,
        repetitions=config.repetitions,
        seed=config.seed,
        timing_s=timing,
        random_loops=loop_record,
        test_tracks=config.test_tracks,
    )
    results["config"] = config_dict(config)
    # Per repetition that learned a controller; a failed one is in "failed_repetitions" only
    # (its effort so far is in "human_effort", its trials in "outcomes" as failures).
    learned = [r for r in reps if r.failed is None]
    results["demonstrations"] = [dict(r.demo, repetition=r.index) for r in learned]
    results["training_accuracy"] = [r.training_accuracy for r in learned]
    results["best_fitness"] = [r.fitness_best[-1] if r.fitness_best else None for r in learned]
    failed = [failed_record(r) for r in reps if r.failed is not None]
    if failed:  # only then: a run without one writes what it always wrote
        results["failed_repetitions"] = failed
    if calibrates(
        config.memory
    ):  # only then, likewise: what each repetition's calibration measured
        results["calibrations"] = [
            dict(r.calibration, repetition=r.index) for r in reps if r.calibration
        ]
    results["method"] = config.method
    # Versions and BLAS kernel this run was computed with (files written before have none).
    results["environment"] = environment()
    # How the camera rendered its frames (files written before have none: they used "bilinear").
    results["renderer"] = {"texture_filter": load_preset(config.preset).camera.texture_filter}
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
                "put_backs",
            )
        },
    }

    write_picture(
        out / "trajectories.png",
        trajectories_picture(config, outcomes),
        trajectories_table(all_plotted_outcomes(outcomes)),
    )
    write_picture(
        out / "fitness.png",
        fitness_picture(config, reps),
        fitness_table(fitness_curves(reps), fitness_x_label(config)),
    )

    path = write_results_json(out / "results.json", results)
    # The report is drawn from the file as written, so re-rendering it later gives the same text.
    stored = read_results(path)
    write_report_from_results(out, stored)
    return format_tables(stored)


def failed_record(rep: RepetitionResult) -> dict[str, Any]:
    """results.json's record of a repetition that learned no controller: its index, why
    (``failed``), and the human's commands and the robot's driving seconds so far where known
    (``commands``, ``learning_drive_s``)."""
    record: dict[str, Any] = {"repetition": rep.index, "failed": rep.failed}
    for key in ("commands", "learning_drive_s"):
        if key in rep.effort:
            record[key] = rep.effort[key]
    return record


def failed_section(results: dict[str, Any]) -> str:
    """Markdown on the repetitions that learned no controller and why (``failed_repetitions``)."""
    failed = results["failed_repetitions"]
    reps = results.get("repetitions", "?")
    lines = [
        "## Failed repetitions",
        "",
        f"{len(failed)} of {reps} repetitions learned no controller: each trial such a repetition"
        " would have run is scored as a failure (`no_controller`, charged to the first corner) in"
        " every table and rate of this report.",
        "",
        "| repetition | why | human commands | robot driving [s] |",
        "|---|---|---|---|",
    ]
    for f in failed:
        commands = f.get("commands")
        drive = f.get("learning_drive_s")
        lines.append(
            f"| {f['repetition']} | {f['failed']} | {'–' if commands is None else commands} "
            f"| {'–' if drive is None else f'{drive:.1f}'} |"
        )
    return "\n".join([*lines, ""])


def write_report_from_results(out: str | Path, results: dict[str, Any]) -> Path:
    """Write ``out/report.md`` from a results.json dict in the current schema (no re-run needed
    to redraw it; a file is read by :func:`~lfd_track.benchmark.schema.read_results`)."""
    extra = [demonstration_section(results)]
    if results.get("failed_repetitions"):
        extra.insert(0, failed_section(results))
    if results.get("human_effort"):
        extra.append(effort_section(results))
    if results.get("test_tracks"):
        extra.append(test_tracks_section(results["test_tracks"]))
    if "random_loops" in results:
        extra.append(random_loops_section(results))
    config = results.get("config", {})
    if not config.get("human", {}).get("careful", True):
        extra.insert(
            0,
            "**Careless demonstrator**: the road library kept learning while the safe box was off the felt.\n",
        )
    notes = []
    features = config.get("features", DEFAULT_FEATURES)
    if features != DEFAULT_FEATURES:
        notes.append(f"the network reads the per-region features `{features}`")
    memory_kind = config.get("memory", {}).get("kind", "none")
    if memory_kind == "previous_command":
        notes.append("the network also reads the command it executed the step before")
    elif memory_kind != "none":
        # A bend is 2 pivots (the constant BEND_PIVOTS; files written before it was one held
        # bend_pivots = 2): the line keeps the words it always had.
        pivots = config["memory"].get("bend_pivots", 2)
        notes.append(
            f"the network also reads memory inputs ({memory_kind}, {pivots} pivots make a bend)"
        )
    if config.get("mirror"):
        notes.append("it learned from its cases and their mirror images")
    if config.get("policy_kind") == "elman-sigmoid":
        notes.append(
            "the network is an Elman network (its hidden activations of the step before fed back)"
        )
    if config.get("shifted_views"):
        notes.append(
            "it learned also from each case's views one command before it (a step behind, a pivot"
            " either way), labelled with that command"
        )
    turnarounds = config.get("human", {}).get("turnarounds", "alternate")
    if turnarounds != "alternate":
        notes.append(f"the human's turn-arounds were `{turnarounds}`")
    if notes:
        extra.insert(0, f"**Beyond the paper's pipeline**: {'; '.join(notes)}.\n")
    extra.append(renderer_line(results))
    return write_report(out, results, extra_sections=extra)


#: The texture filter of every run whose results.json predates the ``renderer`` field.
FILTER_BEFORE_RECORDING = "bilinear"


def renderer_line(results: dict[str, Any]) -> str:
    """The report's line on how the camera rendered the frames of this run (a file written
    before runs recorded it used ``FILTER_BEFORE_RECORDING``, then the only filter runs used)."""
    renderer = results.get("renderer")
    if renderer is None:
        used = (
            f"`{FILTER_BEFORE_RECORDING}` filter (the file predates the `renderer` field;"
            " every run before it used this filter)"
        )
    else:
        used = f"`{renderer['texture_filter']}` filter"
    return (
        f"**Renderer**: the camera sampled the ground texture with the {used}"
        ' (`envs/README.md`, "Texture filter").\n'
    )
