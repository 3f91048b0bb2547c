"""A benchmark's output folder changes only when the whole run has succeeded.

A run writes everything (``repetitions/rep_<i>/``, the plots, ``report.md``, ``results.json``)
into a hidden staging folder beside the output folder; only when the run has finished without
error are the staged entries moved into the output folder, each by a rename in the same file
system. So a run that fails at any point (a bad track, an error in a trial, a full disk, Ctrl-C)
leaves the previous output byte for byte, and nothing beside it.

* A first run (no output folder yet): the staging folder is renamed to the output folder, one
  atomic step.
* Over an earlier output: each entry the new run wrote replaces the entry of the same name
  (repetitions one folder at a time, then the plots and the report, ``results.json`` last); the
  old entries are first moved aside and are put back if any move fails, then deleted. Entries the
  new run did not write (other files, repetitions beyond the new run's count) stay as they are,
  exactly as when runs wrote into the output folder directly.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import LfdTrackError

REPETITIONS = "repetitions"
"""Sub-folder of the output holding one folder per repetition."""
LAST = "results.json"
"""Moved into place last: once it is new, so is everything else."""


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _missing_parents(folder: Path) -> list[Path]:
    """``folder`` and its ancestors that do not exist yet, outermost first."""
    missing = []
    while not os.path.lexists(folder) and folder.parent != folder:
        missing.append(folder)
        folder = folder.parent
    return missing[::-1]


def _remove_empty(folders: list[Path]) -> None:
    for folder in reversed(folders):
        try:
            folder.rmdir()
        except OSError:
            return


def _staging_folder(out: Path) -> Path:
    """A fresh hidden folder on the output's file system: beside ``out`` if possible, else (the
    output folder is a mount point, or its parent is read-only) inside it."""
    parent = out.parent
    beside = not out.is_dir() or os.stat(out).st_dev == os.stat(parent).st_dev
    try:
        if not beside:
            raise OSError("the output folder is on another file system than its parent")
        stage = Path(tempfile.mkdtemp(prefix=f".{out.name[:100]}.benchmark-", dir=parent))
    except OSError:
        if not out.is_dir():
            raise
        stage = Path(tempfile.mkdtemp(prefix=".benchmark-", dir=out))
    os.chmod(stage, 0o777 & ~_umask())  # as a plain mkdir would make it (it may become ``out``)
    return stage


def _entries(stage: Path, out: Path) -> list[Path]:
    """What to move from ``stage`` into ``out``, relative paths in the order they are moved."""
    entries: list[Path] = []
    staged_reps = stage / REPETITIONS
    if staged_reps.is_dir():
        if os.path.lexists(out / REPETITIONS):
            entries += [Path(REPETITIONS, name) for name in sorted(os.listdir(staged_reps))]
        else:
            entries.append(Path(REPETITIONS))
    rest = sorted(name for name in os.listdir(stage) if name != REPETITIONS)
    rest.sort(key=lambda name: name == LAST)
    return entries + [Path(name) for name in rest]


def publish(stage: Path, out: Path) -> None:
    """Move the finished run in ``stage`` into ``out`` (see the module docstring); on any
    error ``out`` is left as it was."""
    if not os.path.lexists(out):
        try:
            os.rename(stage, out)
            return
        except OSError:
            if not out.is_dir():  # not a folder that appeared meanwhile: a real error
                raise
    entries = _entries(stage, out)
    aside = Path(tempfile.mkdtemp(prefix=".previous-", dir=stage))
    done: list[tuple[Path, Path | None]] = []  # (entry, where its old version was moved)
    try:
        for index, rel in enumerate(entries):
            target = out / rel
            old = aside / str(index) if os.path.lexists(target) else None
            if old is not None:
                os.rename(target, old)
            done.append((rel, old))
            os.rename(stage / rel, target)
    except BaseException as exc:
        _put_back(stage, out, done)
        if os.listdir(aside):  # some old entry could not be put back: keep it, say where
            kept = Path(tempfile.mkdtemp(prefix=f".{out.name[:100]}.previous-", dir=stage.parent))
            os.rename(aside, kept / "entries")
            raise LfdTrackError(
                f"{out}: could not replace the previous output ({exc}) nor put all of it back;"
                f" the rest is in {kept / 'entries'}"
            ) from exc
        raise


def _put_back(stage: Path, out: Path, done: list[tuple[Path, Path | None]]) -> None:
    """Undo :func:`publish`'s moves, newest first, as far as the file system lets us."""
    for rel, old in reversed(done):
        try:
            if not os.path.lexists(stage / rel):  # the new entry had been moved in
                os.rename(out / rel, stage / rel)
            if old is not None:
                os.rename(old, out / rel)
        except OSError:
            continue


@contextmanager
def staged_output(out: str | Path) -> Iterator[Path]:
    """Yield a fresh staging folder for a run whose output goes to ``out``; move the run into
    ``out`` when the ``with`` block ends without error, else delete it, leaving ``out`` (and
    everything beside it) as it was.

    Raises ``LfdTrackError`` at once if ``out`` exists and is not a folder.
    """
    out = Path(os.path.abspath(out))
    if os.path.lexists(out) and not out.is_dir():
        raise LfdTrackError(f"{out}: exists and is not a folder (the benchmark writes a folder)")
    created = _missing_parents(out.parent)
    out.parent.mkdir(parents=True, exist_ok=True)
    try:
        stage = _staging_folder(out)
    except BaseException:
        _remove_empty(created)
        raise
    published = False
    try:
        yield stage
        publish(stage, out)
        published = True
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if not published:
            _remove_empty(created)
