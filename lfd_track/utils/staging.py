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

The moves hold a lock on the output folder, so two runs into one folder never interleave them,
and Ctrl-C or SIGTERM waits for them (milliseconds) to be done or undone. A run holds a lock on
its staging folder too: one left by a killed run (nobody holds it, ten minutes old) is deleted by
the next run into the same output folder, unless it holds old entries moved aside (a run killed
while replacing), which are never deleted.
"""

from __future__ import annotations

import os
import re
import shutil
import signal
import stat
import tempfile
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from ..errors import LfdTrackError
from .atomic import current_umask
from .outputs import refuse_unsafe_output

try:
    import fcntl
except ImportError:  # pragma: no cover - not on POSIX: no locks, no clean-up of left folders
    fcntl = None  # type: ignore[assignment]

REPETITIONS = "repetitions"
"""Sub-folder of the output holding one folder per repetition."""
LAST = "results.json"
"""Moved into place last: once it is new, so is everything else."""
FILES = (
    "trajectories.png",
    "trajectories.csv",
    "fitness.png",
    "fitness.csv",
    "report.md",
    LAST,
)
"""The files a run writes at the top of the output folder (checked before the run starts)."""
STALE_S = 600.0
"""A staging folder nobody holds is left over from a killed run once it is this old (a running
run locks its folder at once; the wait only covers the moment between making and locking it)."""


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


def _lock(folder: Path, *, wait: bool = False, busy: str | None = None) -> int | None:
    """An open descriptor of ``folder`` holding an exclusive lock on it; None if another
    process holds one (and not ``wait``; with ``busy``, ``LfdTrackError`` "``folder``:
    ``busy``" instead) or the file system has no locks."""
    if fcntl is None:  # pragma: no cover - not on POSIX
        return None
    try:
        fd = os.open(folder, os.O_RDONLY | getattr(os, "O_DIRECTORY", 0))
    except OSError:
        return None
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
    except BaseException as exc:  # held elsewhere, no locks here, or Ctrl-C while waiting
        os.close(fd)
        if isinstance(exc, BlockingIOError) and busy is not None:
            raise LfdTrackError(f"{folder}: {busy}") from None
        if isinstance(exc, OSError):
            return None
        raise
    return fd


def _unlock(fd: int | None) -> None:
    if fd is not None:
        os.close(fd)


@contextmanager
def locked_folder(folder: Path, busy: str) -> Iterator[None]:
    """Hold the lock a run takes on its output ``folder`` (an existing folder) for the block;
    ``LfdTrackError`` "``folder``: ``busy``" at once if another process holds it. Where the
    file system has no locks the block runs without one."""
    fd = _lock(folder, busy=busy)
    try:
        yield
    finally:
        _unlock(fd)


def _remove_left_stages(out: Path) -> None:
    """Delete the staging folders killed runs into ``out`` left (see the module docstring)."""
    if fcntl is None:  # pragma: no cover - without locks a running run's folder looks the same
        return
    places = [(out.parent, re.escape(_stage_prefix(out)))]
    try:
        inside = out.is_dir() and (
            os.stat(out).st_dev != os.stat(out.parent).st_dev or not os.access(out.parent, os.W_OK)
        )
    except OSError:
        inside = False
    if inside:  # where runs stage when they cannot beside it (see _staging_folder)
        places.append((out, re.escape(_INSIDE_PREFIX)))
    for folder, prefix in places:
        try:
            names = os.listdir(folder)
        except OSError:
            continue
        for name in names:
            stage = folder / name
            if not re.fullmatch(prefix + r"[a-z0-9_]{8}", name) or not _left_over(stage):
                continue
            fd = _lock(stage)
            if fd is None:  # a run still going (or no locks here)
                continue
            try:
                if not any(os.listdir(p) for p in stage.glob(".previous-*") if p.is_dir()):
                    shutil.rmtree(stage, ignore_errors=True)
            except OSError:
                pass
            finally:
                _unlock(fd)


def _left_over(stage: Path) -> bool:
    """Whether ``stage`` is a folder (not a link) last changed :data:`STALE_S` ago or more."""
    try:
        info = os.lstat(stage)
    except OSError:
        return False
    return stat.S_ISDIR(info.st_mode) and time.time() - info.st_mtime > STALE_S


def _ignore(signum: int, frame: object) -> None:
    """A signal handler that does nothing (unlike SIG_IGN, also for a signal already pending)."""


@contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM are ignored inside the block (the main thread only can change them):
    moves into the output are done or undone whole, and the command then ends at once."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    held = (signal.SIGINT, signal.SIGTERM)
    previous = [signal.signal(s, _ignore) for s in held]
    try:
        yield
    finally:
        for s, handler in zip(held, previous, strict=True):
            signal.signal(s, signal.SIG_DFL if handler is None else handler)


_INSIDE_PREFIX = ".benchmark-"
"""Name start of a staging folder made inside the output folder (see :func:`_staging_folder`)."""


def _stage_prefix(out: Path) -> str:
    """Name start of a staging folder beside ``out``: made, and found again when left over."""
    return f".{out.name[:100]}.benchmark-"


def _staging_folder(out: Path) -> Path:
    """A fresh hidden folder on the output's file system: beside ``out`` if possible, else (the
    output folder is a mount point, or its parent is read-only) inside it."""
    parent = out.parent
    beside = not out.is_dir() or os.stat(out).st_dev == os.stat(parent).st_dev
    try:
        if not beside:
            raise OSError("the output folder is on another file system than its parent")
        stage = Path(tempfile.mkdtemp(prefix=_stage_prefix(out), dir=parent))
    except OSError:
        if not out.is_dir():
            raise
        stage = Path(tempfile.mkdtemp(prefix=_INSIDE_PREFIX, dir=out))
    os.chmod(
        stage, 0o777 & ~current_umask()
    )  # as a plain mkdir would make it (it may become ``out``)
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
    lock = _lock(out, wait=True)  # another run's moves into ``out`` end first
    try:
        with _signals_held():
            _move_in(stage, out)
    finally:
        _unlock(lock)


def _refuse_unsafe_entries(stage: Path, out: Path, entries: list[Path]) -> None:
    """Refuse (before any move) an entry of ``out`` to be replaced that is a symbolic link, a
    device, a FIFO or a socket."""
    for rel in entries:
        refuse_unsafe_output(out / rel, folder=None)


def _move_in(stage: Path, out: Path) -> None:
    entries = _entries(stage, out)
    _refuse_unsafe_entries(stage, out, entries)
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

    Raises ``LfdTrackError`` at once if ``out`` exists and is not a folder (a symbolic link to
    one is refused too: outputs are never written through a link), or if a file the run writes
    (:data:`FILES`) is there and is not a regular file.
    """
    out = Path(os.path.abspath(out))
    if os.path.lexists(out) and not out.is_dir():
        raise LfdTrackError(f"{out}: exists and is not a folder (the benchmark writes a folder)")
    refuse_unsafe_output(out, folder=True)
    for name in (*FILES, REPETITIONS):
        refuse_unsafe_output(out / name, folder=None)
    created = _missing_parents(out.parent)
    out.parent.mkdir(parents=True, exist_ok=True)
    _remove_left_stages(out)
    try:
        stage = _staging_folder(out)
    except BaseException:
        _remove_empty(created)
        raise
    held = None
    published = False
    try:
        held = _lock(stage)  # tells later runs this folder is in use
        yield stage
        publish(stage, out)
        published = True
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        _unlock(held)
        if not published:
            _remove_empty(created)
