"""Pool a study's job results per condition: study.json, study.md and study.png.

Rates pool every trial of a condition over its seeds and repetitions, with Wilson 95 % intervals
(``ci95``). The Wilson interval treats trials as independent; trials of one repetition share a
controller, so it can be narrower than the spread between controllers warrants. Each pooled rate
therefore also carries ``ci95_controllers``: a bootstrap interval that resamples whole learned
controllers (seed × repetition), and ``per_seed`` shows the spread between seeds.

Length: one module, because study.json, study.md and study.png are three views of one summary, built
once here, so a number can never differ between them.
"""

from __future__ import annotations

import json
import math
import statistics
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ..benchmark.loops import is_drawn_loop
from ..benchmark.paper import TRACK_RESULT_KEYS
from ..benchmark.runner import config_dict, trial_directions
from ..benchmark.tables import MAX_COUNT, TrialOutcome, results_json_text
from ..utils.atomic import atomic_write_text
from ..utils.provenance import environment
from .loops import random_loops_markdown, random_loops_summary
from .schema import STUDY_SCHEMA
from .spec import Job, Study
from .stats import controller_interval, rate_summary

PAPER_TRACKS = tuple(TRACK_RESULT_KEYS)
"""The paper's two tracks ("training", "testing"); any other track scored is an unseen track."""


def human_commands(results: Mapping[str, Any]) -> int:
    """Commands the (scripted) human gave in one job, demonstrations and corrections together.

    ``results`` is a job's results.json in the current schema
    (:func:`~lfd_track.benchmark.schema.migrate_results`). Taken from its human-effort totals
    (``human_effort.total.commands``); a run from before the benchmark reported them (the paper
    method, which only demonstrates) counts every demonstration command: the recorded cases plus
    the library-only commands at the start of each demonstration.
    """
    reported = _reported_commands(results)
    if reported is not None:
        return reported
    library_only = int(results["config"]["human"]["library_only_commands"])
    return sum(int(d["cases"]) + library_only for d in results["demonstrations"])


EFFORT_KEYS = ("corrections", "takeovers", "learning_drive_s", "autonomous_drive_s", "put_backs")
"""Human-effort totals besides commands that a benchmark may report (``human_effort.total``)."""


def human_effort(results: Mapping[str, Any]) -> dict[str, float]:
    """Corrections, takeovers and seconds of driving while learning in one job.

    Read from the results' ``human_effort`` totals; a job from a build that did not report
    them (the paper method only demonstrates) counts 0 corrections and takeovers, and 0 s.
    """
    effort = results.get("human_effort")
    total = effort.get("total", {}) if isinstance(effort, Mapping) else {}
    out: dict[str, float] = {}
    for key in EFFORT_KEYS:
        value = total.get(key, 0) if isinstance(total, Mapping) else 0
        out[key] = float(value) if isinstance(value, int | float) else 0.0
    return out


def check_job_results(
    results: Mapping[str, Any],
    repetitions: int,
    trials_per_direction: int | None = None,
    test_tracks: Sequence[str] | None = None,
    random_loops: int = 0,
) -> None:
    """Raise ``ValueError`` (one line) unless ``results`` holds, with the right types, every
    field this module reads from a job's results.json.

    ``results`` is in the current schema (:func:`~lfd_track.benchmark.schema.migrate_results`).
    That is: ``outcomes``, a list of trial outcomes (each as
    :meth:`~lfd_track.benchmark.tables.TrialOutcome.from_dict` reads it, ``repetition`` below
    ``repetitions``; given ``trials_per_direction`` and ``test_tracks``, exactly the job's
    trials: each direction it drives, repetition and trial once, and each repetition's
    ``random_loops`` procedural loops once each way); if present,
    ``timing_s.wall``, ``training_accuracy`` and the ``human_effort`` totals as finite
    numbers (counts as integers 0 to :data:`MAX_COUNT`); if present, ``failed_repetitions``
    (repetitions that learned no controller, each with its ``repetition`` and why, ``failed``);
    and, for a job that reports no command count, ``demonstrations`` with integer ``cases``.
    """
    outcomes = results.get("outcomes")
    if "outcomes" not in results:
        raise ValueError("missing 'outcomes'")
    if not isinstance(outcomes, list):
        raise ValueError(f"'outcomes' must be a list, got {type(outcomes).__name__}")
    for index, o in enumerate(outcomes):
        _check_outcome(o, f"outcomes[{index}]", repetitions)
    if trials_per_direction is not None and test_tracks is not None:
        _check_trials(outcomes, repetitions, trials_per_direction, tuple(test_tracks), random_loops)
    timing = results.get("timing_s", {})
    if not isinstance(timing, Mapping):
        raise ValueError("'timing_s' must be an object")
    if "wall" in timing:
        _number(timing["wall"], "timing_s.wall")
    accuracy = results.get("training_accuracy", [])
    if not isinstance(accuracy, list):
        raise ValueError("'training_accuracy' must be a list of numbers")
    for index, a in enumerate(accuracy):
        _number(a, f"training_accuracy[{index}]")
    effort = results.get("human_effort", {})
    if not isinstance(effort, Mapping):
        raise ValueError("'human_effort' must be an object")
    total = effort.get("total", {})
    if not isinstance(total, Mapping):
        raise ValueError("'human_effort.total' must be an object")
    if "commands" in total:
        _count(total["commands"], "human_effort.total.commands")
    for key in EFFORT_KEYS:
        if key in total:
            _number(total[key], f"human_effort.total.{key}")
    _check_failed(results.get("failed_repetitions", []), repetitions)
    if _reported_commands(results) is None:  # counted from the demonstrations
        demos = results.get("demonstrations")
        if not isinstance(demos, list):
            raise ValueError("'demonstrations' must be a list (no command count is reported)")
        for index, d in enumerate(demos):
            if not isinstance(d, Mapping):
                raise ValueError(f"'demonstrations[{index}]' must be an object")
            _count(d.get("cases"), f"demonstrations[{index}].cases")


def _check_failed(failed: Any, repetitions: int) -> None:
    """``failed_repetitions``: a list of ``{"repetition": index, "failed": why, ...}``, each
    repetition once."""
    if not isinstance(failed, list):
        raise ValueError("'failed_repetitions' must be a list")
    seen: set[int] = set()
    for index, f in enumerate(failed):
        where = f"failed_repetitions[{index}]"
        if not isinstance(f, Mapping):
            raise ValueError(f"'{where}' must be an object")
        rep = f.get("repetition")
        if isinstance(rep, bool) or not isinstance(rep, int) or not 0 <= rep < repetitions:
            raise ValueError(f"'{where}.repetition' must be an integer below {repetitions}")
        if rep in seen:
            raise ValueError(f"'{where}': repetition {rep} is listed twice")
        seen.add(rep)
        if not isinstance(f.get("failed"), str):
            raise ValueError(f"'{where}.failed' must say why (a string)")


def failed_repetitions(jobs: Sequence[tuple[Job, Mapping[str, Any]]]) -> list[dict[str, Any]]:
    """The repetitions of ``jobs`` that learned no controller: seed, repetition and why."""
    return [
        {"seed": job.seed, "repetition": int(f["repetition"]), "failed": str(f["failed"])}
        for job, r in jobs
        for f in r.get("failed_repetitions", [])
    ]


def _check_outcome(o: Any, where: str, repetitions: int) -> None:
    TrialOutcome.from_dict(o, where)  # fields, types and consistency: the benchmark's definition
    if o["repetition"] >= repetitions:
        raise ValueError(
            f"{where}: 'repetition' must be below the job's {repetitions} repetition(s), "
            f"got {o['repetition']}"
        )


def _check_trials(
    outcomes: list[Mapping[str, Any]],
    repetitions: int,
    trials: int,
    test_tracks: tuple[str, ...],
    random_loops: int = 0,
) -> None:
    """The outcomes must be the job's trials, each once: a missing trial would pool as fewer
    laps, a repeated one as more."""
    grid = {(track, direction): 0 for track, _, direction in trial_directions(test_tracks)}
    seen: set[tuple[str, str, int, int]] = set()
    loop_laps = [0] * repetitions
    for index, o in enumerate(outcomes):
        track, direction = o["track"], o["direction"]
        if is_drawn_loop(
            str(track), test_tracks
        ):  # drawn per repetition: once each way, counted below
            trial = (track, direction, o["repetition"], o["trial"])
            if o["trial"] != 0 or trial in seen:
                raise ValueError(
                    f"outcomes[{index}]: procedural loop {track}/{direction} is lapped once per"
                    f" repetition (trial 0), got trial {o['trial']} of repetition {o['repetition']}"
                )
            seen.add(trial)
            loop_laps[o["repetition"]] += 1
            continue
        if (track, direction) not in grid:
            raise ValueError(
                f"outcomes[{index}]: the job drives no track '{track}' {direction} "
                f"(its test tracks: {', '.join(test_tracks)})"
            )
        if o["trial"] >= trials:
            raise ValueError(
                f"outcomes[{index}]: 'trial' must be below the job's {trials} trial(s) per "
                f"direction, got {o['trial']}"
            )
        trial = (track, direction, o["repetition"], o["trial"])
        if trial in seen:
            raise ValueError(
                f"outcomes[{index}]: {track}/{direction} repetition {o['repetition']} "
                f"trial {o['trial']} is listed twice"
            )
        seen.add(trial)
        grid[track, direction] += 1
    for repetition, held in enumerate(loop_laps):
        if held != 2 * random_loops:
            raise ValueError(
                f"'outcomes' holds {held} laps of procedural loops in repetition {repetition},"
                f" not the job's {2 * random_loops} ({random_loops} loops, both ways)"
            )
    for (track, direction), held in grid.items():
        if held != repetitions * trials:
            raise ValueError(
                f"'outcomes' holds {held} of the {repetitions * trials} trial(s) of "
                f"{track}/{direction} ({repetitions} repetition(s) x {trials} per direction)"
            )


def _number(value: Any, name: str) -> None:
    """``value`` must be a finite number >= 0 (and at most :data:`MAX_COUNT`)."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"'{name}' must be a finite number, got {type(value).__name__}")
    try:
        ok = math.isfinite(float(value)) and 0 <= value <= MAX_COUNT
    except OverflowError:
        ok = False
    if not ok:
        raise ValueError(f"'{name}' must be a finite number from 0 to {MAX_COUNT}")


def _count(value: Any, name: str) -> None:
    """``value`` must be an integer from 0 to :data:`MAX_COUNT`."""
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= MAX_COUNT:
        shown = type(value).__name__ if not isinstance(value, int) else "a number out of range"
        raise ValueError(f"'{name}' must be an integer from 0 to {MAX_COUNT}, got {shown}")


def _reported_commands(results: Mapping[str, Any]) -> int | None:
    """The job's human commands where its results report them (see :func:`human_commands`)."""
    effort = results.get("human_effort")
    total = effort.get("total") if isinstance(effort, Mapping) else None
    commands = total.get("commands") if isinstance(total, Mapping) else None
    return commands if isinstance(commands, int) and not isinstance(commands, bool) else None


def _track_counts(outcomes: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
    """Per track: successes, trials, corner failures and failure kinds."""
    tracks: dict[str, dict[str, Any]] = {}
    for o in outcomes:
        t = tracks.setdefault(
            str(o["track"]), {"successes": 0, "trials": 0, "corners": {}, "failure_kinds": {}}
        )
        t["trials"] += 1
        t["successes"] += bool(o["success"])
        for label in o["corner_order"]:
            t["corners"].setdefault(str(label), 0)
        corner = TrialOutcome.from_dict(o).charged_corner
        if corner is not None:
            t["corners"][corner] += 1
        if o["failure"] is not None:
            kinds = t["failure_kinds"]
            kinds[o["failure"]] = kinds.get(o["failure"], 0) + 1
    return tracks


def _controller_counts(
    jobs: Sequence[tuple[Job, Mapping[str, Any]]], tracks: set[str]
) -> list[tuple[int, int]]:
    """``(successes, trials)`` on ``tracks`` of each learned controller (seed × repetition)."""
    groups: dict[tuple[int, int], list[int]] = {}
    for job, r in jobs:
        for o in r["outcomes"]:
            if str(o["track"]) in tracks:
                group = groups.setdefault((job.seed, int(o["repetition"])), [0, 0])
                group[0] += bool(o["success"])
                group[1] += 1
    return [(k, n) for k, n in groups.values()]


def condition_summary(
    study: Study, name: str, jobs: Sequence[tuple[Job, Mapping[str, Any]]]
) -> dict[str, Any]:
    """One entry of study.json's ``conditions`` from the condition's finished jobs."""
    condition = next(c for c in study.conditions if c.name == name)
    outcomes = [o for _, r in jobs for o in r["outcomes"]]
    named = condition.config.test_tracks
    tracks = _track_counts([o for o in outcomes if not is_drawn_loop(str(o["track"]), named)])
    unseen = sorted(t for t in tracks if t not in PAPER_TRACKS)

    def rate(track_names: Sequence[str]) -> dict[str, Any]:
        summary = rate_summary(
            sum(tracks[t]["successes"] for t in track_names if t in tracks),
            sum(tracks[t]["trials"] for t in track_names if t in tracks),
        )
        summary["ci95_controllers"] = controller_interval(
            _controller_counts(jobs, set(track_names))
        )
        return summary

    commands = [human_commands(r) for _, r in jobs]
    efforts = [human_effort(r) for _, r in jobs]
    accuracy = [float(a) for _, r in jobs for a in r.get("training_accuracy", [])]
    reps = study.repetitions * len(jobs)
    per_seed = []
    for job, r in jobs:
        seed_tracks = _track_counts(r["outcomes"])
        per_seed.append(
            {
                "seed": job.seed,
                **{
                    t: rate_summary(
                        seed_tracks.get(t, {}).get("successes", 0),
                        seed_tracks.get(t, {}).get("trials", 0),
                    )
                    for t in PAPER_TRACKS
                },
                "wall_s": float(r.get("timing_s", {}).get("wall", 0.0)),
            }
        )
    summary = {
        "name": name,
        "description": condition.description,
        "method": condition.method,
        "preset": condition.config.preset,
        "seeds": list(study.seeds),
        "repetitions": study.repetitions,
        "trials_per_direction": condition.config.trials_per_direction,
        "test_tracks": list(condition.test_tracks),
        "config": {
            k: v
            for k, v in config_dict(condition.config).items()
            if k not in ("seed", "repetitions")
        },
        "training": rate(["training"]),
        "testing": rate(["testing"]),
        "unseen_tracks": {t: rate([t]) for t in unseen},
        "unseen": rate(unseen),
        "corner_failures": {t: tracks[t]["corners"] for t in sorted(tracks)},
        "failure_kinds": {t: tracks[t]["failure_kinds"] for t in sorted(tracks)},
        "human_commands": {
            "total": sum(commands),
            "per_repetition": sum(commands) / reps if reps else None,
        },
        "human_effort": {
            key: {
                "total": sum(e[key] for e in efforts),
                "per_repetition": sum(e[key] for e in efforts) / reps if reps else None,
            }
            for key in EFFORT_KEYS
        },
        "training_accuracy": statistics.mean(accuracy) if accuracy else None,
        "wall_s": sum(float(r.get("timing_s", {}).get("wall", 0.0)) for _, r in jobs),
        "per_seed": per_seed,
        "jobs": [job.key for job, _ in jobs],
    }
    failed = failed_repetitions(jobs)
    if failed:  # only then: a condition without one is summarised as it always was
        summary["failed_repetitions"] = failed
    loops = random_loops_summary(jobs, named)
    return summary if loops is None else {**summary, "random_loops": loops}


def build_study_results(
    study: Study, finished: Sequence[tuple[Job, Mapping[str, Any]]]
) -> dict[str, Any]:
    """The study.json dict: one pooled entry per condition, in the study file's order."""
    from ..benchmark.paper import paper_results

    paper = paper_results()
    return {
        "schema": STUDY_SCHEMA,
        "study": study.name,
        "description": study.description,
        "seeds": list(study.seeds),
        "repetitions": study.repetitions,
        "conditions": [
            condition_summary(study, c.name, [(j, r) for j, r in finished if j.condition == c.name])
            for c in study.conditions
        ],
        "paper": {
            t: rate_summary(paper[k]["successes"], paper[k][_trial_key(t)])
            for t, k in TRACK_RESULT_KEYS.items()
        },
        "wall_s": sum(float(r.get("timing_s", {}).get("wall", 0.0)) for _, r in finished),
        # Versions and BLAS kernel of the machine that pooled the jobs, and the distinct ones the
        # jobs ran with (each job's results.json has its own; jobs written before have none).
        "environment": environment(),
        "job_environments": _job_environments(finished),
    }


def _job_environments(finished: Sequence[tuple[Job, Mapping[str, Any]]]) -> list[Any]:
    seen: dict[str, Any] = {}
    for _, r in finished:
        env = r.get("environment")
        if env is not None:
            seen.setdefault(json.dumps(env, sort_keys=True), env)
    return [seen[k] for k in sorted(seen)]


def _trial_key(track: str) -> str:
    from ..benchmark.paper import TRIAL_COUNT_KEYS

    return TRIAL_COUNT_KEYS[track]


# ------------------------------------------------------------------------------------ markdown
def _cell(r: Mapping[str, Any]) -> str:
    if not r["trials"]:
        return "–"
    low, high = r["ci95"]
    return f"{r['successes']}/{r['trials']} = {100 * r['rate']:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"


def _controller_cell(r: Mapping[str, Any]) -> str:
    interval = r.get("ci95_controllers")
    if not r["trials"] or interval is None:
        return "–"
    low, high = interval
    return f"{100 * r['rate']:.0f} % [{100 * low:.0f}–{100 * high:.0f}]"


def study_markdown(results: Mapping[str, Any]) -> str:
    """The study's tables as Markdown (the table a paper would print)."""
    seeds = ", ".join(str(s) for s in results["seeds"])
    lines = [
        f"# Study `{results['study']}`",
        "",
        *([results["description"], ""] if results["description"] else []),
        f"Each condition runs the paper protocol for seeds {seeds} (matched across conditions), "
        f"{results['repetitions']} repetition(s) per seed: a fresh demonstration, learning, then "
        "autonomous runs on the training track, laps of the testing track and laps of any unseen "
        "tracks. Cells: successes/trials = rate [Wilson 95 % interval], pooled over seeds and "
        "repetitions.",
        "",
        "| condition | method | preset | training track | testing track | unseen tracks "
        "| human commands / repetition | training accuracy | wall (s) |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for c in results["conditions"]:
        accuracy = c["training_accuracy"]
        commands = c["human_commands"]["per_repetition"]
        lines.append(
            f"| {c['name']} | {c['method']} | {c['preset']} | {_cell(c['training'])} "
            f"| {_cell(c['testing'])} | {_cell(c['unseen'])} "
            f"| {'–' if commands is None else f'{commands:.0f}'} "
            f"| {'–' if accuracy is None else f'{100 * accuracy:.1f} %'} | {c['wall_s']:.0f} |"
        )
    paper = results["paper"]
    lines.append(
        f"| paper (reported) | paper | – | {_cell(paper['training'])} | {_cell(paper['testing'])} "
        "| – | – | – | – |"
    )
    lines += _failed_markdown(results["conditions"])
    lines += [
        "",
        "The same rates with 95 % intervals that resample whole learned controllers (bootstrap "
        "over seed × repetition): trials of one controller are not independent, so where these "
        "are wider than the Wilson intervals above, they are the ones to read.",
        "",
        "| condition | training track | testing track | unseen tracks |",
        "|---|---|---|---|",
    ]
    for c in results["conditions"]:
        cells = [_controller_cell(c[key]) for key in ("training", "testing", "unseen")]
        lines.append(f"| {c['name']} | " + " | ".join(cells) + " |")
    for track in ("testing", "training"):
        corner_rows = [
            (c["name"], c["corner_failures"].get(track, {})) for c in results["conditions"]
        ]
        labels = sorted({label for _, corners in corner_rows for label in corners})
        if not labels:
            continue
        lines += [
            "",
            f"Failures charged to each corner of the {track} track (both directions, all trials):",
            "",
            "| condition | " + " | ".join(f"corner {label}" for label in labels) + " |",
            "|---|" + "---|" * len(labels),
        ]
        for name, corners in corner_rows:
            lines.append(f"| {name} | " + " | ".join(str(corners.get(x, 0)) for x in labels) + " |")
    lines += [
        "",
        "Human effort while learning, per repetition: commands the human gave (demonstration, "
        "corrections and interventions), times the human took control back, times the policy "
        "took control, simulated seconds the robot drove while learning and, of those, seconds "
        "the policy drove, and times the robot was put back on the felt by hand:",
        "",
        "| condition | human commands | corrections | takeovers | driving (s) | policy driving (s) "
        "| put-backs |",
        "|---|---|---|---|---|---|---|",
    ]
    for c in results["conditions"]:
        commands = c["human_commands"]["per_repetition"]
        effort = c.get("human_effort", {})
        cells = [
            "–"
            if effort.get(k, {}).get("per_repetition") is None
            else f"{effort[k]['per_repetition']:.1f}"
            for k in EFFORT_KEYS
        ]
        lines.append(
            f"| {c['name']} | {'–' if commands is None else f'{commands:.0f}'} | "
            + " | ".join(cells)
            + " |"
        )
    lines += random_loops_markdown(results["conditions"], _cell)
    unseen = sorted({t for c in results["conditions"] for t in c["unseen_tracks"]})
    if unseen:
        lines += [
            "",
            "Unseen tracks one by one:",
            "",
            "| condition | " + " | ".join(unseen) + " |",
            "|---|" + "---|" * len(unseen),
        ]
        for c in results["conditions"]:
            cells = [
                _cell(c["unseen_tracks"][t]) if t in c["unseen_tracks"] else "–" for t in unseen
            ]
            lines.append(f"| {c['name']} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "The Wilson intervals treat every trial as independent; the controller-resampling "
        "intervals and the spread between seeds (study.json, `per_seed`) show how much a result "
        "depends on which controllers were learned.",
        f"Summed job time: {results['wall_s']:.0f} s.",
    ]
    return "\n".join(lines) + "\n"


def _failed_markdown(conditions: Sequence[Mapping[str, Any]]) -> list[str]:
    """study.md's note naming the repetitions that learned no controller and why (none: no
    lines)."""
    rows = [(c["name"], f) for c in conditions for f in c.get("failed_repetitions", [])]
    if not rows:
        return []
    lines = [
        "",
        "Failed repetitions: these learned no controller, and each trial they would have run is"
        " counted as a failure (`no_controller`) in every rate above.",
        "",
        "| condition | seed | repetition | why |",
        "|---|---|---|---|",
    ]
    lines += [f"| {name} | {f['seed']} | {f['repetition']} | {f['failed']} |" for name, f in rows]
    return lines


# ------------------------------------------------------------------------------------ picture
_SERIES = (
    ("training", (44, 160, 44)),
    ("testing", (31, 119, 180)),
    ("unseen", (214, 39, 40)),
)


def study_plot(results: Mapping[str, Any]) -> np.ndarray:
    """Success rate of every condition with Wilson 95 % bars; RGB uint8 image."""
    import cv2

    conditions = results["conditions"]
    group_w, left, right, top, bottom = 130, 60, 20, 60, 70
    width = max(640, left + right + group_w * len(conditions))
    group_w = (width - left - right) // max(len(conditions), 1)  # spread out when few
    height = 460
    plot_h = height - top - bottom
    img = np.full((height, width, 3), 255, np.uint8)
    font = cv2.FONT_HERSHEY_SIMPLEX

    def y_of(rate: float) -> int:
        return int(round(top + plot_h * (1.0 - rate)))

    for k in range(6):
        rate = k / 5
        y = y_of(rate)
        cv2.line(img, (left, y), (width - right, y), (225, 225, 225), 1)
        cv2.putText(img, f"{100 * rate:.0f}%", (8, y + 4), font, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    paper_rate = results["paper"]["testing"]["rate"]
    y = y_of(paper_rate)
    for x in range(left, width - right, 12):
        cv2.line(img, (x, y), (min(x + 6, width - right), y), _SERIES[1][1], 1)
    cv2.putText(
        img,
        "paper, testing",
        (width - right - 110, y - 4),
        font,
        0.4,
        _SERIES[1][1],
        1,
        cv2.LINE_AA,
    )
    cv2.rectangle(img, (left, top), (width - right, top + plot_h), (0, 0, 0), 1)
    title = f"study {results['study']}: success rate, Wilson 95 % interval"
    cv2.putText(img, title, (left, 22), font, 0.5, (0, 0, 0), 1, cv2.LINE_AA)
    for i, (name, colour) in enumerate(_SERIES):
        x = left + 10 + 110 * i
        cv2.circle(img, (x, 42), 4, colour, -1, cv2.LINE_AA)
        cv2.putText(img, name, (x + 8, 46), font, 0.4, (0, 0, 0), 1, cv2.LINE_AA)
    for g, c in enumerate(conditions):
        x0 = left + g * group_w
        for s, (series, colour) in enumerate(_SERIES):
            r = c[series]
            if not r["trials"]:
                continue
            x = x0 + group_w // 2 - 30 + 30 * s
            low, high = r["ci95"]
            cv2.line(img, (x, y_of(low)), (x, y_of(high)), colour, 2)
            for yy in (y_of(low), y_of(high)):
                cv2.line(img, (x - 5, yy), (x + 5, yy), colour, 2)
            cv2.circle(img, (x, y_of(r["rate"])), 5, colour, -1, cv2.LINE_AA)
        label = c["name"] if len(c["name"]) <= 16 else c["name"][:15] + "."
        (text_w, _), _ = cv2.getTextSize(label, font, 0.45, 1)
        cv2.putText(
            img,
            label,
            (x0 + (group_w - text_w) // 2, top + plot_h + 22),
            font,
            0.45,
            (0, 0, 0),
            1,
            cv2.LINE_AA,
        )
        method = f"{c['method']}, {c['preset']}"
        (text_w, _), _ = cv2.getTextSize(method, font, 0.35, 1)
        cv2.putText(
            img,
            method,
            (x0 + (group_w - text_w) // 2, top + plot_h + 42),
            font,
            0.35,
            (90, 90, 90),
            1,
            cv2.LINE_AA,
        )
    return img


def write_study_outputs(
    out: Path, study: Study, finished: Sequence[tuple[Job, Mapping[str, Any]]]
) -> dict[str, Any]:
    """Write study.json, study.md and study.png (with its numbers, study.csv) into ``out``;
    returns the study.json dict."""
    from ..viz.plot_data import study_table, write_picture

    results = build_study_results(study, finished)
    atomic_write_text(out / "study.json", results_json_text(results))
    atomic_write_text(out / "study.md", study_markdown(results))
    write_picture(out / "study.png", study_plot(results), study_table(results))
    return results
