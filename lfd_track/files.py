"""Reading the files a user gives: regular files only, with a size cap, errors naming the file.

A FIFO or a device (``/dev/zero``) would block or never end, so they are refused before any byte
is read: the path is opened non-blocking (opening a FIFO with no writer would otherwise wait
forever) and checked with ``fstat`` on the opened descriptor (no race between check and read).
"""

from __future__ import annotations

import errno
import os
import stat
from pathlib import Path

from .errors import FileFormatError


def read_regular_file(path: str | Path, max_bytes: int, what: str) -> bytes:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    ``what`` names the kind of file in messages ("controller", "track", ...).

    Raises:
        FileFormatError: one line naming the file: missing, unreadable, not a regular file, or
            larger than ``max_bytes``.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0)
    try:
        fd = os.open(path, flags)
    except FileNotFoundError:
        raise FileFormatError(path, f"{what} file not found") from None
    except OSError as exc:
        if exc.errno == errno.ENXIO:  # a FIFO or socket with nobody at the other end
            raise FileFormatError(path, f"not a regular file (expected a {what} file)") from None
        raise FileFormatError(path, f"cannot read {what} file ({exc.strerror or exc})") from None
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise FileFormatError(path, f"is a folder, expected a {what} file")
        if not stat.S_ISREG(info.st_mode):
            raise FileFormatError(path, f"not a regular file (expected a {what} file)")
        if info.st_size > max_bytes:
            raise FileFormatError(
                path, f"{what} file is {info.st_size} bytes, more than the {max_bytes} allowed"
            )
        os.set_blocking(fd, True)
        chunks: list[bytes] = []
        total = 0
        while True:  # read to the end, but never past the cap (the file may grow meanwhile)
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - total))
            if not chunk:
                break
            chunks.append(chunk)
            total += len(chunk)
            if total > max_bytes:
                raise FileFormatError(path, f"{what} file grew past the {max_bytes} bytes allowed")
        return b"".join(chunks)
    except OSError as exc:
        raise FileFormatError(path, f"cannot read {what} file ({exc.strerror or exc})") from None
    finally:
        os.close(fd)


def read_regular_text(path: str | Path, max_bytes: int, what: str) -> str:
    """Like :func:`read_regular_file`, decoded as UTF-8 (a bad byte is a one-line error)."""
    data = read_regular_file(path, max_bytes, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            path, f"{what} file is not UTF-8 text (bad byte at offset {exc.start})"
        ) from None
