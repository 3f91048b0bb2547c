"""What a command may write to, and the names of the files it writes beside its output.

An output only ever replaces a regular file: a path that exists and is a device, a FIFO, a
socket or a symbolic link (even one to a regular file) is refused before any work, in one line
(:func:`refuse_unsafe_output`), and checked again at the moment a finished file is moved into
place. Names that are not valid UTF-8 (a stray byte in a POSIX name) are shown with \\x escapes
(:func:`shown_path`), also in the labels drawn on pictures; a name that would be recorded inside
an output (a track or preset name in a recording's metadata or a benchmark's results) must be
UTF-8 and is otherwise refused before any work (:func:`refuse_undecodable`).

A recording that is to replace an existing file is written under an in-progress name beside it
and moved over it only when complete; an interrupted one is kept under a partial name that never
overwrites an earlier partial recording.
"""

from __future__ import annotations

import errno
import itertools
import os
import stat
from collections.abc import Iterator
from pathlib import Path

from ..errors import LfdTrackError


def shown_path(path: str | Path) -> str:
    """A path (or any text) as text that can always be printed, encoded and drawn: bytes that
    are not UTF-8 as \\x escapes, any other unpaired surrogate as a \\u escape."""
    try:
        return os.fsencode(path).decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that no undecodable byte stands for
        return os.fspath(path).encode("utf-8", "backslashreplace").decode("utf-8")


def same_file(a: str | Path, b: str | Path) -> bool:
    """Whether ``a`` and ``b`` name the same file (through links, ``..``, symbolic links)."""
    try:
        return os.path.samefile(a, b)
    except OSError:  # one of them does not exist
        return os.path.realpath(a) == os.path.realpath(b)


def unwritable_name(path: str | Path, what: str = "file") -> tuple[int, str] | None:
    """Why no file can be created at ``path``, as ``(errno, problem)``: it is a folder ("is a
    folder, expected a ``what`` name"), or a folder it needs is something else ("PARENT is not a
    folder"); None when nothing stands in the way."""
    path = Path(path)
    if path.is_dir():
        return errno.EISDIR, f"is a folder, expected a {what} name"
    for parent in path.parents:
        if parent.exists():
            if not parent.is_dir():
                return errno.ENOTDIR, f"{shown_path(parent)} is not a folder"
            break
    return None


def refuse_undecodable(name: str | Path, what: str) -> None:
    """Raise ``LfdTrackError`` (one line) if ``name`` is not valid UTF-8: it is to be recorded in
    an output (JSON, Markdown) that holds text only, and ``what`` says what it names."""
    try:
        os.fspath(name).encode("utf-8")
    except UnicodeEncodeError:
        raise LfdTrackError(
            f"{shown_path(name)}: the {what} name is not valid UTF-8 and would be recorded in the"
            " output; rename it (or give it through a link with a UTF-8 name)"
        ) from None


def _kind(mode: int) -> str:
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return "a device"
    if stat.S_ISFIFO(mode):
        return "a FIFO"
    if stat.S_ISSOCK(mode):
        return "a socket"
    return "of an unknown kind"


def refuse_unsafe_output(path: str | Path, *, folder: bool | None = False) -> None:
    """Raise ``LfdTrackError`` (one line naming ``path``) if ``path`` exists and is not what an
    output may replace: a regular file, with ``folder`` a folder, with ``folder=None`` either
    of them. A symbolic link is always
    refused, wherever it points: an output is never written through a link. A path that does not
    exist (or cannot be looked at) passes; writing it reports its own error."""
    try:
        info = os.lstat(path)
    except (OSError, ValueError):
        return
    shown = shown_path(path)
    if stat.S_ISLNK(info.st_mode):
        raise LfdTrackError(
            f"{shown}: is a symbolic link; outputs are never written through one"
            " (give the name of the file itself)"
        )
    if folder is None and (stat.S_ISDIR(info.st_mode) or stat.S_ISREG(info.st_mode)):
        return
    if folder:
        if not stat.S_ISDIR(info.st_mode):
            raise LfdTrackError(f"{shown}: exists and is not a folder (the output is a folder)")
        return
    if stat.S_ISDIR(info.st_mode):
        raise LfdTrackError(f"{shown}: is a folder, expected a file name")
    if not stat.S_ISREG(info.st_mode):
        raise LfdTrackError(
            f"{shown}: exists and is {_kind(info.st_mode)}, not a regular file; an output only"
            " ever replaces a regular file"
        )


def _free_names(out: Path, tag: str) -> Iterator[Path]:
    """``out.TAG.lfdemo``, ``out.TAG-2.lfdemo``, ... beside ``out`` (visible names)."""
    suffix = out.suffix or ".lfdemo"
    yield out.with_name(f"{out.stem}.{tag}{suffix}")
    for n in itertools.count(2):
        yield out.with_name(f"{out.stem}.{tag}-{n}{suffix}")


def in_progress_name(out: Path) -> Path:
    """Where a recording that is to replace ``out`` is written until it is complete: beside
    ``out``, visible (a killed process leaves it to be found), unique to this process and never
    the name of an existing file (create it exclusively)."""
    return next(p for p in _free_names(out, f"in-progress-{os.getpid()}") if not taken(p))


def keep_partial(recording: Path, out: Path) -> Path:
    """Move the interrupted ``recording`` meant for ``out`` to a free partial name, never over an
    existing file (a partial recording kept earlier): ``out.partial.lfdemo``, else
    ``out.partial-2.lfdemo``, ...; returns where it is now."""
    for name in _free_names(out, "partial"):
        try:
            os.link(recording, name)  # fails if the name is taken, even by a racing process
        except FileExistsError:
            continue
        except OSError:  # no hard links on this file system
            if taken(name):
                continue
            os.replace(recording, name)
            return name
        recording.unlink()
        return name
    raise AssertionError("unreachable")  # pragma: no cover - the names never run out


def taken(path: Path) -> bool:
    """Whether ``path`` names something (a file, folder or dangling link)."""
    return path.exists() or path.is_symlink()
