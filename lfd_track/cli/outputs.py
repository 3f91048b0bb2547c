"""What the commands check about their outputs before any work, and how they show progress."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

from ..errors import LfdTrackError
from ..utils.outputs import refuse_unsafe_output, same_file, shown_path, unwritable_name


def check_output(out: str | Path, inputs: Sequence[tuple[str, str | Path | None]]) -> None:
    """Refuse, before any work, an output that is one of the ``(what, path)`` inputs (it would be
    replaced by the output), exists and is not a regular file (a folder, device, FIFO, socket or
    symbolic link), or is below something that is not a folder."""
    out = Path(out)
    for what, path in inputs:
        if path is not None and Path(path).is_file() and same_file(out, path):
            raise LfdTrackError(
                f"{shown_path(out)}: is the {what} this command reads; write to another file"
            )
    refuse_unsafe_output(out)
    problem = unwritable_name(out)
    if problem is not None:
        raise LfdTrackError(f"{shown_path(out)}: {problem[1]}")


def advance(bar: Any, done: float, note: str = "") -> None:
    """Move a progress bar to ``done`` (it may go back) with a short note."""
    if note:
        bar.set_postfix_str(note, refresh=False)
    bar.update(done - bar.n)
