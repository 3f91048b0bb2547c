"""Names of the files a command writes beside its output: in-progress and kept partial recordings.

A recording that is to replace an existing file is written under an in-progress name beside it
and moved over it only when complete; an interrupted one is kept under a partial name that never
overwrites an earlier partial recording.
"""

from __future__ import annotations

import itertools
import os
from collections.abc import Iterator
from pathlib import Path


def shown_path(path: str | Path) -> str:
    """A path as text that can always be printed (undecodable bytes as \\x escapes)."""
    return os.fsencode(path).decode("utf-8", "backslashreplace")


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
