"""Atomic file writes: a reader sees the old file or the complete new one, never a partial one.

Only a regular file is ever replaced: a target that is a device, a FIFO, a socket or a symbolic
link is refused (:func:`lfd_track.utils.outputs.refuse_unsafe_output`), before writing and again at the
rename (:func:`replace_file`).
"""

from __future__ import annotations

import errno
import os
import tempfile
from pathlib import Path

from .outputs import refuse_unsafe_output


def current_umask() -> int:
    """The process's umask (read by setting it and setting it back)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def temporary_prefix(path: Path) -> str:
    """A hidden name's start for a temporary file beside ``path``: the start of its name, short
    enough that with tempfile's 8 characters and ".tmp" it fits in 255 bytes."""
    return f".{path.name[:50]}."


def temporary_beside(out: Path) -> Path:
    """A new empty hidden file beside ``out`` (its folder made if missing): an output is written
    there first and moved over ``out`` (:func:`replace_file`) once the command's other output is
    written too."""
    out.parent.mkdir(parents=True, exist_ok=True)
    fd, name = tempfile.mkstemp(prefix=temporary_prefix(out), suffix=".tmp", dir=out.parent)
    os.close(fd)
    return Path(name)


def replace_file(src: str | Path, dst: str | Path) -> None:
    """Move the finished file ``src`` over ``dst`` (``os.replace``), unless ``dst`` exists and is
    not a regular file (``LfdTrackError``; ``src`` is left for the caller to remove)."""
    refuse_unsafe_output(dst)
    os.replace(src, dst)


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder, then rename.

    Raises ``IsADirectoryError`` for a folder, ``LfdTrackError`` for a path that exists and is
    not a regular file (a device, FIFO, socket or symbolic link); nothing is written then.
    """
    path = Path(path)
    if path.is_dir() and not path.is_symlink():
        raise IsADirectoryError(errno.EISDIR, "is a folder, expected a file name", str(path))
    refuse_unsafe_output(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=temporary_prefix(path), suffix=".tmp", dir=path.parent)
    try:
        # mkstemp makes the file private (0600); give it the permissions a plain open() would.
        os.fchmod(fd, 0o666 & ~current_umask())
        with os.fdopen(fd, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        replace_file(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except FileNotFoundError:
            pass
        raise


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write UTF-8 ``text`` to ``path`` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))
