"""Corner-success counting and reporting: the paper's Tables 2 and 3, ours beside the paper's.

Counting follows the paper's progressive rule (rules in ``lfd_track/world/episode.py``): a trial that does not succeed is
charged to the first corner it did not negotiate, whatever ended it — reversing, leaving the felt
or running out of steps (a timeout), on the corner itself or on the straight before it.

"Times reached" of a corner therefore counts the trials that negotiated every earlier corner, so
that, as in the paper's tables, ``reached(next corner) = reached(corner) - failures(corner)`` and
``successes = trials - sum(failures)`` whenever no trial fails after its last corner. (A trial that
negotiates every corner and then fails before the end is counted under
``failures_after_last_corner``.) The physical count — progress came within 0.30 m of the corner —
is reported beside it as ``physically_reached``; it is lower when a trial fails on the straight.

In results.json the corner dicts list corners in the order the direction meets them; since the
file is written with sorted keys, each direction also stores that order as ``corner_order``.
"""

from __future__ import annotations

import json
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..utils.atomic import atomic_write_text
from .loops import is_drawn_loop, random_loop_results
from .paper import (
    CORNER_ORDER,
    DIRECTION_TITLES,
    DIRECTIONS,
    PAPER_NOTES,
    TRACK_RESULT_KEYS,
    TRIAL_COUNT_KEYS,
    paper_results,
)
from .schema import RESULTS_SCHEMA

FAILURE_KINDS = ("reversed", "off_track", "timeout")
"""Why a trial ended unsuccessfully: the paper's two failures, plus the step budget running out."""
NO_CONTROLLER = "no_controller"
"""The failure of a trial that was never driven: its repetition learned no controller (its
demonstration did not finish, ``failed_repetitions`` in results.json). Counted like any failure,
charged to the first corner; the ``failure_kinds`` tables list it only where it occurred, so a
run without a failed repetition writes what it always wrote."""
OUTCOME_FIELDS: dict[str, tuple[type, ...]] = {
    "track": (str,),
    "direction": (str,),
    "corner_order": (list,),
    "corners_reached": (list,),
    "corners_negotiated": (list,),
    "failure": (str, type(None)),
    "success": (bool,),
    "repetition": (int,),
    "trial": (int,),
    "steps": (int,),
}
"""Every field of a trial outcome in results.json and its JSON type (lists hold corner labels;
``failure`` is one of :data:`FAILURE_KINDS`, :data:`NO_CONTROLLER` or null): what :meth:`TrialOutcome.to_dict` writes
and :meth:`TrialOutcome.from_dict` reads back."""
MAX_COUNT = 2**53
"""Largest count (steps, trials, commands ...) a results.json may hold: exact as a float."""
LOOP_DIRECTIONS = ("cw", "ccw")
"""Directions of a loop track (the testing track's and those of extra test loops)."""
_FLOAT_DECIMALS = 6  # results.json precision: byte-stable and far below any meaningful difference
_SMALL = 1e-3  # below this, results.json keeps 6 significant digits rather than 6 decimals


@dataclass(frozen=True)
class TrialOutcome:
    """How one autonomous trial went (one run on the training track or one lap on the loop)."""

    track: str
    """"training", "testing", or the name (or path) of an extra test loop."""
    direction: str
    """"direction_1"/"direction_2" (training) or "cw"/"ccw" (testing)."""
    corner_order: tuple[str, ...]
    """Corner labels in the order this trial meets them."""
    corners_reached: tuple[str, ...]
    """Corners physically reached (progress within 0.30 m before them), in the order met."""
    corners_negotiated: tuple[str, ...]
    """Corners negotiated (progress 0.30 m past them, on the felt), in the order met."""
    failure: str | None
    """"reversed", "off_track", "timeout", None for a success, or "no_controller" for a trial
    its repetition could not drive (:data:`NO_CONTROLLER`)."""
    success: bool
    repetition: int
    """Repetition index (one demonstration + evolution each)."""
    trial: int
    """Trial index within the repetition, track and direction."""
    steps: int
    """Control steps the trial took."""
    trajectory: np.ndarray | None = field(default=None, compare=False, repr=False)
    """Optional (T, 3) float64 poses (x [m], y [m], theta [rad]) for plots; never in JSON."""

    def __post_init__(self) -> None:
        for name in ("corner_order", "corners_reached", "corners_negotiated"):
            object.__setattr__(self, name, tuple(str(c) for c in getattr(self, name)))
        where = f"trial {self.track}/{self.direction} rep {self.repetition} #{self.trial}"
        if not self.track:
            raise ValueError(f"{where}: track must be named")
        # Any other track is an extra loop (BenchmarkConfig.test_tracks), driven both ways.
        allowed = DIRECTIONS.get(self.track, LOOP_DIRECTIONS)
        if self.direction not in allowed:
            raise ValueError(f"{where}: direction must be one of {allowed}")
        order = self.corner_order
        if not order or len(set(order)) != len(order):
            raise ValueError(f"{where}: corner_order must list distinct corners, got {order}")
        for name in ("corners_reached", "corners_negotiated"):
            met = getattr(self, name)
            if met != order[: len(met)]:
                raise ValueError(f"{where}: {name} {met} is not a prefix of corner_order {order}")
        if len(self.corners_negotiated) > len(self.corners_reached):
            raise ValueError(f"{where}: negotiated a corner it never reached")
        if self.failure is not None and self.failure not in (*FAILURE_KINDS, NO_CONTROLLER):
            kinds = (*FAILURE_KINDS, NO_CONTROLLER)
            raise ValueError(f"{where}: failure must be one of {kinds} or None")
        if bool(self.success) != (self.failure is None):
            raise ValueError(f"{where}: a trial succeeds exactly when it has no failure")
        if self.success and self.corners_negotiated != order:
            raise ValueError(f"{where}: a success must negotiate every corner")
        for name in ("repetition", "trial", "steps"):
            if int(getattr(self, name)) < 0:
                raise ValueError(f"{where}: {name} must be >= 0")

    @property
    def charged_corner(self) -> str | None:
        """The corner this trial's failure is charged to (first not negotiated), else None."""
        k = len(self.corners_negotiated)
        if self.success or k == len(self.corner_order):
            return None
        return self.corner_order[k]

    def to_dict(self) -> dict[str, Any]:
        """JSON-friendly dict of every field of :data:`OUTCOME_FIELDS` (not the trajectory)."""
        data = {name: getattr(self, name) for name in OUTCOME_FIELDS}
        for name in ("corner_order", "corners_reached", "corners_negotiated"):
            data[name] = list(data[name])
        data["success"] = bool(self.success)
        for name in ("repetition", "trial", "steps"):
            data[name] = int(data[name])
        return data

    @classmethod
    def from_dict(cls, data: Any, where: str = "trial outcome") -> TrialOutcome:
        """Inverse of :meth:`to_dict`: every field of :data:`OUTCOME_FIELDS` with its JSON type
        (counts from 0 to :data:`MAX_COUNT`), consistent by the rules of this class.

        Raises ``ValueError`` in one line starting with ``where`` (how the caller names it).
        """
        if not isinstance(data, Mapping):
            raise ValueError(f"{where} must be an object, got {type(data).__name__}")
        for key, types in OUTCOME_FIELDS.items():
            if key not in data:
                raise ValueError(f"{where}: missing '{key}'")
            value = data[key]
            if not isinstance(value, types) or (bool not in types and isinstance(value, bool)):
                kinds = " or ".join("null" if t is type(None) else t.__name__ for t in types)
                raise ValueError(f"{where}: '{key}' must be {kinds}, got {type(value).__name__}")
            if isinstance(value, list) and not all(isinstance(v, str) for v in value):
                raise ValueError(f"{where}: '{key}' must list corner labels (strings)")
            if isinstance(value, int) and types == (int,) and not 0 <= value <= MAX_COUNT:
                raise ValueError(f"{where}: '{key}' must be an integer from 0 to {MAX_COUNT}")
        try:
            return cls(**{key: data[key] for key in OUTCOME_FIELDS})
        except ValueError as exc:
            raise ValueError(f"{where}: {str(exc).splitlines()[0]}") from None


# --------------------------------------------------------------------------- counting


def _rate(successes: int, trials: int) -> float | None:
    return round(successes / trials, _FLOAT_DECIMALS) if trials else None


def _failure_kinds(trials: Sequence[TrialOutcome]) -> dict[str, int]:
    """Trials per failure kind: every one of :data:`FAILURE_KINDS`, and :data:`NO_CONTROLLER`
    where some trial had it."""
    kinds: tuple[str, ...] = FAILURE_KINDS
    if any(t.failure == NO_CONTROLLER for t in trials):
        kinds = (*kinds, NO_CONTROLLER)
    return {kind: sum(t.failure == kind for t in trials) for kind in kinds}


def _direction_results(track: str, direction: str, trials: list[TrialOutcome]) -> dict[str, Any]:
    orders = {t.corner_order for t in trials}
    if len(orders) > 1:
        raise ValueError(f"{track}/{direction}: trials disagree on the corner order: {orders}")
    order = orders.pop() if orders else CORNER_ORDER.get(direction, ())
    corners: dict[str, Any] = {}
    for index, label in enumerate(order):
        charged = [t for t in trials if t.charged_corner == label]
        corners[label] = {
            "reached": sum(len(t.corners_negotiated) >= index for t in trials),
            "failures": len(charged),
            "physically_reached": sum(label in t.corners_reached for t in trials),
            "failure_kinds": _failure_kinds(charged),
        }
    successes = sum(t.success for t in trials)
    return {
        TRIAL_COUNT_KEYS.get(track, "laps"): len(trials),
        "successes": successes,
        "success_rate": _rate(successes, len(trials)),
        "corner_order": list(order),
        "corners": corners,
        "failures_after_last_corner": sum(
            not t.success and t.charged_corner is None for t in trials
        ),
        "failure_kinds": _failure_kinds(trials),
    }


def _loop_results(track: str, outcomes: list[TrialOutcome]) -> dict[str, Any]:
    """Results of one extra test loop: each direction as on the testing track, plus totals."""
    section: dict[str, Any] = {}
    total = successes = 0
    for direction in LOOP_DIRECTIONS:
        trials = [t for t in outcomes if t.track == track and t.direction == direction]
        section[direction] = _direction_results(track, direction, trials)
        total += len(trials)
        successes += section[direction]["successes"]
    section["laps"] = total
    section["successes"] = successes
    section["success_rate"] = _rate(successes, total)
    return section


def build_results(
    outcomes: Iterable[TrialOutcome],
    *,
    repetitions: int,
    seed: int,
    timing_s: Mapping[str, float],
    random_loops: Mapping[str, Any] | None = None,
    test_tracks: Sequence[str] = (),
) -> dict[str, Any]:
    """Count ``outcomes`` into the results.json dict, with the paper's numbers beside ours.

    Every direction of both tracks is present, with zero trials if none were run. Laps of
    procedural loops drawn per repetition (any not among the named ``test_tracks``) are counted
    together (``random_loops``, :func:`~lfd_track.benchmark.loops.random_loop_results`, with the
    draw's record ``random_loops``), not loop by loop. Raises
    ValueError if two outcomes share track, direction, repetition and trial, or if the trials of
    one direction disagree on the corner order.
    """
    outcomes = list(outcomes)
    seen: set[tuple[str, str, int, int]] = set()
    for t in outcomes:
        key = (t.track, t.direction, int(t.repetition), int(t.trial))
        if key in seen:
            raise ValueError(f"duplicate trial {key}")
        seen.add(key)
    results: dict[str, Any] = {"schema": RESULTS_SCHEMA, "repetitions": int(repetitions)}
    results["seed"] = int(seed)
    for track, track_key in TRACK_RESULT_KEYS.items():
        section: dict[str, Any] = {}
        total = successes = 0
        for direction in DIRECTIONS[track]:
            trials = [t for t in outcomes if t.track == track and t.direction == direction]
            section[direction] = _direction_results(track, direction, trials)
            total += len(trials)
            successes += section[direction]["successes"]
        section[TRIAL_COUNT_KEYS[track]] = total
        section["successes"] = successes
        section["success_rate"] = _rate(successes, total)
        results[track_key] = section
    extra = sorted({t.track for t in outcomes} - set(TRACK_RESULT_KEYS))
    named = [name for name in extra if not is_drawn_loop(name, test_tracks)]
    if named:
        results["test_tracks"] = {name: _loop_results(name, outcomes) for name in named}
    if len(named) < len(extra) or random_loops:
        drawn = [t for t in outcomes if is_drawn_loop(t.track, test_tracks)]
        results["random_loops"] = random_loop_results(drawn, random_loops)
    results["paper"] = paper_results()
    results["timing_s"] = dict(timing_s)
    results["outcomes"] = [t.to_dict() for t in outcomes]
    return results


# --------------------------------------------------------------------------- reporting


def _corner_order(direction_result: Mapping[str, Any]) -> list[str]:
    order = direction_result.get("corner_order")
    return [str(c) for c in order] if order is not None else list(direction_result["corners"])


def _count(direction_result: Mapping[str, Any] | None, label: str, key: str) -> str:
    if not direction_result:
        return "–"
    corner = direction_result.get("corners", {}).get(label)
    return "–" if corner is None or corner.get(key) is None else str(corner[key])


def _markdown_table(rows: Sequence[Sequence[str]]) -> list[str]:
    """Pipe table with padded columns: valid markdown that also reads well in a terminal."""
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]

    def line(row: Sequence[str]) -> str:
        cells = (cell.ljust(w) for cell, w in zip(row, widths, strict=True))
        return "| " + " | ".join(cells) + " |"

    rule = "|" + "|".join("-" * (w + 2) for w in widths) + "|"
    return [line(rows[0]), rule, *(line(r) for r in rows[1:])]


def _corner_table(results: Mapping[str, Any], paper: Mapping[str, Any], track: str) -> list[str]:
    """One pipe table per direction (columns = corners in the order met), stacked."""
    track_key = TRACK_RESULT_KEYS[track]
    ours_track = results.get(track_key, {})
    paper_track = paper.get(track_key, {})
    lines: list[str] = []
    for direction in DIRECTIONS[track]:
        ours = ours_track.get(direction)
        theirs = paper_track.get(direction)
        order = _corner_order(ours) if ours else list(CORNER_ORDER[direction])
        header = [DIRECTION_TITLES[direction]]
        reached = ["Times reached"]
        failures = ["Failures"]
        physical = ["Physically reached"]
        for label in order:
            header.append(f"Corner {label}")
            reached.append(f"{_count(ours, label, 'reached')} ({_count(theirs, label, 'reached')})")
            failures.append(
                f"{_count(ours, label, 'failures')} ({_count(theirs, label, 'failures')})"
            )
            physical.append(_count(ours, label, "physically_reached"))
        rows = [header, reached, failures]
        blank = [""] * (len(order) - 1)
        after = _value(ours, "failures_after_last_corner")
        if track == "training" or after not in ("0", "–"):
            # The open track can still be failed between the last corner and the finish (on the
            # loop, the finish is the last corner); this row makes reached - failures - failures
            # after the last corner = successes.
            rows.append(["Failures after the last corner", *blank, f"{after} (–)"])
        rows.append(
            ["Successes", *blank, f"{_value(ours, 'successes')} ({_value(theirs, 'successes')})"]
        )
        rows.append(physical)
        if lines:
            lines.append("")
        lines += _markdown_table(rows)
    return lines


def _value(direction_result: Mapping[str, Any] | None, key: str) -> str:
    if not direction_result or direction_result.get(key) is None:
        return "–"
    return str(direction_result[key])


def _fraction(section: Mapping[str, Any] | None, count_key: str) -> str:
    if not section or not section.get(count_key):
        return "n/a"
    n, k = int(section[count_key]), int(section["successes"])
    return f"{k}/{n} = {100.0 * k / n:.1f} %"


def _success_table(results: Mapping[str, Any], paper: Mapping[str, Any]) -> list[str]:
    rows = [["Track, direction", "Ours", "Paper"]]
    for track, track_key in TRACK_RESULT_KEYS.items():
        count_key = TRIAL_COUNT_KEYS[track]
        ours_track = results.get(track_key, {})
        paper_track = paper.get(track_key, {})
        for direction in DIRECTIONS[track]:
            rows.append(
                [
                    f"{track.capitalize()}, {DIRECTION_TITLES[direction].lower()}",
                    _fraction(ours_track.get(direction), count_key),
                    _fraction(paper_track.get(direction), count_key) + " ¹",
                ]
            )
        rows.append(
            [
                f"{track.capitalize()}, all",
                _fraction(ours_track, count_key),
                _fraction(paper_track, count_key),
            ]
        )
    return _markdown_table(rows)


def _failure_summary(results: Mapping[str, Any]) -> list[str]:
    lines = []
    for track, track_key in TRACK_RESULT_KEYS.items():
        section = results.get(track_key, {})
        parts = []
        for direction in DIRECTIONS[track]:
            d = section.get(direction) or {}
            kinds = d.get("failure_kinds") or {}
            shown = (*FAILURE_KINDS, *(k for k in (NO_CONTROLLER,) if kinds.get(k)))
            text = ", ".join(f"{kinds.get(k, 0)} {k.replace('_', ' ')}" for k in shown)
            after = d.get("failures_after_last_corner", 0)
            if after:
                text += f"; {after} after the last corner"
            parts.append(f"{DIRECTION_TITLES[direction].lower()}: {text}")
        lines.append(f"- {track.capitalize()} track failures by kind — " + "; ".join(parts) + ".")
    return lines


def format_tables(results: Mapping[str, Any], *, ours: str | None = None) -> str:
    """Tables 2 and 3 and the success rates as markdown, each cell ``ours (paper)``.

    ``ours`` says what was run (default: the repetitions and the seed of ``results``).
    """
    paper = results.get("paper") or paper_results()
    reps = results.get("repetitions", "?")
    paper_reps = paper.get("repetitions", "?")
    plural = "" if reps == 1 else "s"
    if ours is None:
        ours = f"{reps} repetition{plural}, seed {results.get('seed', '?')}"
    lines = [
        f"Cells read `ours (paper)`. Ours: {ours}; "
        f"paper: {paper_reps} repetitions (30 trials per direction).",
        "",
        "**Table 2** — training track: times each corner was reached and failures there. ²",
        "",
        *_corner_table(results, paper, "training"),
        "",
        "**Table 3** — testing track, laps starting at corner 4. ² ³",
        "",
        *_corner_table(results, paper, "testing"),
        "",
        "**Success rates**",
        "",
        *_success_table(results, paper),
        "",
        *_failure_summary(results),
        "",
        f"¹ {PAPER_NOTES[0]}",
        "",
        "² Progressive counting: a trial that does not succeed — reversing, leaving the felt or "
        "timing out, at a corner or on the straight before it — is charged to the first corner it "
        "did not negotiate, and 'times reached' counts the trials that negotiated every earlier "
        "corner, so reached(next) = reached - failures as in the paper. On the training track a trial "
        "can also fail after negotiating its last corner, before the finish line; those are "
        "counted in their own row, so reached - failures - failures after the last corner = "
        "successes. 'Physically reached' "
        "(ours only) counts trials whose progress came within 0.30 m of the corner.",
        "",
        f"³ {PAPER_NOTES[1]}",
    ]
    return "\n".join(lines) + "\n"


#: results.json timing key -> what it measured, in words (all in seconds).
TIMING_NAMES = {
    "wall": "Whole benchmark (wall clock)",
    "learning_sum": "Learning the controllers (demonstrating and training)",
    "demonstration_sum": "Recording the demonstrations",
    "evolution_sum": "Evolving the controllers",
    "trials_sum": "Driving the autonomous trials",
}


def _timing_lines(timing: Mapping[str, Any]) -> list[str]:
    if not timing:
        return []
    rows = [["Stage", "Time"]]
    names = [k for k in TIMING_NAMES if k in timing]
    names += sorted(k for k in timing if k not in TIMING_NAMES and k != "workers")
    for name in names:
        value = timing[name]
        shown = f"{value:.1f} s" if isinstance(value, int | float) else str(value)
        rows.append([TIMING_NAMES.get(name, str(name).replace("_", " ")), shown])
    lines = ["## Timing", "", *_markdown_table(rows), ""]
    workers = timing.get("workers")
    if isinstance(workers, int | float):
        n = int(workers)
        lines += [
            f"Run on {n} worker process{'es' if n != 1 else ''}. The stage times are summed over"
            " the repetitions, each timed inside its worker, so with more than one worker they add"
            " up to more than the whole run.",
            "",
        ]
    return lines


BENCHMARK_TITLE = "Corner-success benchmark"
BENCHMARK_INTRO = (
    "The paper's protocol (§4.2.5): each repetition records a fresh demonstration, evolves a "
    "controller and runs it 3 times in each direction on the training track and 3 laps each "
    "way on the testing track."
)


def write_report(
    out_dir: str | Path,
    results: Mapping[str, Any],
    *,
    extra_sections: Sequence[str] = (),
    title: str = BENCHMARK_TITLE,
    intro: str = BENCHMARK_INTRO,
    ours: str | None = None,
) -> Path:
    """Write ``out_dir/report.md`` atomically (tables, success rates, timing, extra sections).

    ``title`` and ``intro`` open the report (the benchmark's by default); ``ours`` is passed to
    :func:`format_tables`.
    """
    path = Path(out_dir) / "report.md"
    body = [
        f"# {title}",
        "",
        intro,
        "",
        format_tables(results, ours=ours).rstrip("\n"),
        "",
        *_timing_lines(results.get("timing_s") or {}),
    ]
    for section in extra_sections:
        body += [section.rstrip("\n"), ""]
    atomic_write_text(path, "\n".join(body).rstrip("\n") + "\n")
    return path


def _normalise(value: Any) -> Any:
    """JSON-ready copy: numpy scalars to Python, floats rounded, non-finite floats to null."""
    if isinstance(value, Mapping):
        return {str(k): _normalise(v) for k, v in value.items()}
    if isinstance(value, list | tuple | np.ndarray):
        return [_normalise(v) for v in value]
    if isinstance(value, bool | np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        x = float(value)
        if not math.isfinite(x):
            return None
        if 0.0 < abs(x) < _SMALL:
            # Six decimals would round a small setting (e.g. BC's epsilon, 1e-8) to 0, which
            # could not be loaded back: small values keep six significant digits instead.
            return float(f"{x:.6g}")
        return round(x, _FLOAT_DECIMALS) + 0.0  # + 0.0 turns -0.0 into 0.0
    if value is None or isinstance(value, str):
        return value
    raise TypeError(f"results hold a {type(value).__name__}, which JSON cannot store")


def results_json_text(results: Mapping[str, Any]) -> str:
    """results.json text: sorted keys, floats rounded to 6 decimals (6 significant digits below
    1e-3), same input -> same bytes."""
    return json.dumps(_normalise(results), sort_keys=True, indent=2, allow_nan=False) + "\n"


def write_results_json(path: str | Path, results: Mapping[str, Any]) -> Path:
    """Write ``results`` to ``path`` atomically as :func:`results_json_text`."""
    path = Path(path)
    atomic_write_text(path, results_json_text(results))
    return path
