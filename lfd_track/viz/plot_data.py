"""The numbers beside every picture: each PNG a command writes has a CSV of the same stem.

``fitness.png`` comes with ``fitness.csv``, ``laps.png`` with ``laps.csv``, ``c.fitness.png``
with ``c.fitness.csv``, ``study.png`` with ``study.csv`` (:func:`data_path`). Each CSV has one
header row, then one row per plotted number, written with full float precision (``repr``), so
reading it back gives the very numbers the picture was drawn from. The columns
(``docs/command-line.md``, "Pictures and their numbers"):

* fitness curves (:func:`fitness_table`): ``curve`` (the legend's label), ``generation`` (or
  ``epoch``, the x axis, from 1), ``fitness``;
* paths of drives (:func:`laps_table`, :func:`trajectories_table`): what identifies the run
  (``lap``; or ``track``, ``direction``, ``repetition``, ``trial``), its ``outcome``
  (``success``, ``reversed``, ``off_track`` or ``timeout``), then one row per pose: ``point``
  (from 0), ``x_m``, ``y_m``;
* success rates (:func:`study_table`): ``condition``, ``method``, ``preset``, ``series``
  (``training``, ``testing`` or ``unseen``), ``successes``, ``trials``, ``rate``, ``ci95_low``,
  ``ci95_high``; the paper's testing rate (the dashed line) is the row of condition ``paper``.

A picture and its numbers are written like one output (:func:`write_picture`): both go to
hidden files beside their names first and are moved into place only when both are complete, the
numbers first and the picture last; a failure before that leaves earlier files as they were.
"""

from __future__ import annotations

import csv
import io
import os
import shutil
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..utils.atomic import atomic_write_text, replace_file, temporary_beside
from ..utils.outputs import refuse_unsafe_output

DATA_SUFFIX = ".csv"


def data_path(png: str | Path) -> Path:
    """The CSV beside the picture ``png``: the same name with ``.csv`` for its suffix."""
    return Path(png).with_suffix(DATA_SUFFIX)


def _cell(value: Any) -> str:
    if value is None:
        return ""
    if isinstance(value, bool | np.bool_):
        return "true" if value else "false"
    if isinstance(value, int | np.integer):
        return str(int(value))
    if isinstance(value, float | np.floating):
        return repr(float(value))
    return str(value)


@dataclass
class Table:
    """Rows of numbers under a header row, as CSV."""

    header: tuple[str, ...]
    rows: list[tuple[Any, ...]] = field(default_factory=list)

    def csv_text(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow(self.header)
        for row in self.rows:
            if len(row) != len(self.header):
                raise ValueError(f"a row of {len(row)} cells under {len(self.header)} columns")
            writer.writerow([_cell(v) for v in row])
        return buf.getvalue()


def read_table(path: str | Path) -> list[dict[str, str]]:
    """The rows of a CSV written here, as dicts keyed by the header (cells as text)."""
    with open(path, newline="", encoding="utf-8") as fh:
        return list(csv.DictReader(fh))


# ------------------------------------------------------------------------------- the tables
def fitness_table(
    curves: Sequence[tuple[str, np.ndarray, Any]], x_label: str = "generation"
) -> Table:
    """The numbers of :func:`~lfd_track.viz.plots.fitness_plot`'s ``curves`` (label, values,
    colour): one row per curve and generation (``x_label``), from 1."""
    table = Table(("curve", x_label, "fitness"))
    for label, values, _ in curves:
        for i, value in enumerate(np.asarray(values, dtype=float)):
            table.rows.append((label, i + 1, float(value)))
    return table


def outcome_name(success: bool, failure: str | None) -> str:
    """``success``, or how the run failed (``reversed``, ``off_track``, ``timeout``)."""
    return "success" if success else (failure or "timeout")


def _path_rows(key: tuple[Any, ...], outcome: str, path: np.ndarray | None) -> Iterator[tuple]:
    pts = np.zeros((0, 2)) if path is None else np.asarray(path, dtype=np.float64)[:, :2]
    for i, (x, y) in enumerate(pts):
        yield (*key, outcome, i, float(x), float(y))


def laps_table(runs: Iterable[Any]) -> Table:
    """The paths of :func:`~lfd_track.viz.plots.laps_plot` (``TrackRun``s, lap k = the k-th)."""
    table = Table(("lap", "outcome", "point", "x_m", "y_m"))
    for lap, run in enumerate(runs, start=1):
        table.rows += _path_rows((lap,), outcome_name(run.success, run.failure), run.path)
    return table


def trajectories_table(outcomes: Iterable[Any]) -> Table:
    """The paths of a benchmark's trajectories picture (``TrialOutcome``s with a trajectory)."""
    table = Table(("track", "direction", "repetition", "trial", "outcome", "point", "x_m", "y_m"))
    for o in outcomes:
        key = (o.track, o.direction, o.repetition, o.trial)
        table.rows += _path_rows(key, outcome_name(o.success, o.failure), o.trajectory)
    return table


STUDY_SERIES = ("training", "testing", "unseen")


def study_table(results: Mapping[str, Any]) -> Table:
    """The success rates of ``study.png``: each condition's series with trials, and the paper's
    testing rate."""
    table = Table(
        (
            "condition",
            "method",
            "preset",
            "series",
            "successes",
            "trials",
            "rate",
            "ci95_low",
            "ci95_high",
        )
    )

    def row(name: str, method: str, preset: str, series: str, r: Mapping[str, Any]) -> tuple:
        low, high = r["ci95"]
        return (name, method, preset, series, r["successes"], r["trials"], r["rate"], low, high)

    for c in results["conditions"]:
        for series in STUDY_SERIES:
            if c[series]["trials"]:
                table.rows.append(row(c["name"], c["method"], c["preset"], series, c[series]))
    table.rows.append(row("paper", "paper", "", "testing", results["paper"]["testing"]))
    return table


# ------------------------------------------------------------------------------- writing
def _keep_copy(path: Path) -> Path:
    """A hidden copy of ``path`` beside it (a hard link where the file system has them), so
    that ``path`` can be put back if a later move of the same output fails."""
    copy = temporary_beside(path)
    copy.unlink()
    try:
        os.link(path, copy)
    except OSError:
        shutil.copy2(path, copy)
    return copy


@dataclass
class StagedFiles:
    """Finished files under hidden names, each waiting to be moved over its own name: one
    output whose files are replaced together or not at all."""

    moves: list[tuple[Path, Path]] = field(default_factory=list)
    """(staged file, its name), in the order they are moved into place."""

    def add(self, final: str | Path) -> Path:
        """A new hidden file beside ``final`` to write; it is moved over ``final`` after the
        files added before it."""
        staged = temporary_beside(Path(final))
        self.moves.append((staged, Path(final)))
        return staged

    def publish(self) -> None:
        """Move every staged file into place, in order. If one move fails (a full disk, a file
        that became a link meanwhile), the files already moved are put back as they were and the
        error is raised: the earlier output stays whole."""
        done: list[tuple[Path, Path | None]] = []  # (name, copy of what it held before)
        try:
            for staged, final in self.moves:
                refuse_unsafe_output(final)
                done.append((final, _keep_copy(final) if final.is_file() else None))
                replace_file(staged, final)
        except BaseException:
            for final, copy in reversed(done):
                try:
                    if copy is not None:
                        os.replace(copy, final)
                    elif not any(s.exists() for s, f in self.moves if f == final):
                        final.unlink(missing_ok=True)  # it was new: moved in, now taken out
                except OSError:
                    continue
            raise
        finally:
            for _, copy in done:
                if copy is not None:
                    copy.unlink(missing_ok=True)
        self.moves.clear()

    def discard(self) -> None:
        """Remove the staged files not moved into place."""
        for staged, _ in self.moves:
            staged.unlink(missing_ok=True)
        self.moves.clear()


def stage_picture(
    png: str | Path, rgb: np.ndarray, table: Table, staged: StagedFiles | None = None
) -> StagedFiles:
    """Write ``table`` and ``rgb`` to hidden files beside :func:`data_path` and ``png`` (added to
    ``staged``, or to a new :class:`StagedFiles`, which is returned); the caller publishes or
    discards them."""
    from .plots import write_png

    png = Path(png)
    staged = StagedFiles() if staged is None else staged
    first = len(staged.moves)
    try:
        atomic_write_text(staged.add(data_path(png)), table.csv_text())
        write_png(str(staged.add(png)), rgb)
    except BaseException:
        for path, _ in staged.moves[first:]:
            path.unlink(missing_ok=True)
        del staged.moves[first:]
        raise
    return staged


def write_picture(png: str | Path, rgb: np.ndarray, table: Table) -> None:
    """Write the picture ``png`` and its numbers (:func:`data_path`) as one output."""
    staged = stage_picture(png, rgb, table)
    try:
        staged.publish()
    finally:
        staged.discard()
