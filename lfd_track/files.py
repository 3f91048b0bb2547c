"""Reading the files a user gives: regular files only, with a size cap, errors naming the file.

A FIFO or a device (``/dev/zero``) would block or never end, so they are refused before any byte
is read: the path is opened non-blocking (opening a FIFO with no writer would otherwise wait
forever) and checked with ``fstat`` on the opened descriptor (no race between check and read).
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Callable
from pathlib import Path

from .errors import FileFormatError


def read_regular_file(
    path: str | Path,
    max_bytes: int,
    what: str,
    *,
    check_head: Callable[[bytes], None] | None = None,
    head_bytes: int = 0,
    max_hole_tail: int | None = None,
) -> bytearray:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    ``what`` names the kind of file in messages ("controller", "track", ...). With
    ``check_head``, the first ``head_bytes`` bytes (fewer if the file is shorter) are read and
    passed to it before the rest: it raises to refuse the file, so a large file of the wrong
    kind is refused without reading it whole. The file is read into one buffer of its size (no
    second copy), and running out of memory is reported as a file error too. With
    ``max_hole_tail``, a file whose last ``max_hole_tail`` bytes were never written (a hole: they
    read as zeros, e.g. a file extended by ``truncate``) is refused before it is read.

    Raises:
        FileFormatError: one line naming the file: missing, unreadable, not a regular file,
            larger than ``max_bytes`` or than memory allows, or refused by ``check_head``.
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
        try:
            buffer = bytearray(info.st_size)
        except MemoryError:
            raise FileFormatError(
                path, f"{what} file is {info.st_size} bytes, more than memory allows"
            ) from None
        view = memoryview(buffer)
        total = 0
        if check_head is not None:
            total = _read_into(fd, view[: min(head_bytes, info.st_size)])
            check_head(bytes(view[:total]))
        if max_hole_tail is not None and _ends_in_hole(fd, info.st_size, max_hole_tail):
            raise FileFormatError(
                path,
                f"{what} file ends in more than {max_hole_tail} bytes that were never written"
                " (corrupt file)",
            )
        total += _read_into(fd, view[total:])
        view.release()
        del buffer[total:]  # the file may have shrunk meanwhile: keep what is there
        # Or grown meanwhile: read on, but never past the cap.
        while True:
            chunk = os.read(fd, min(1 << 20, max_bytes + 1 - len(buffer)))
            if not chunk:
                break
            buffer += chunk
            if len(buffer) > max_bytes:
                raise FileFormatError(path, f"{what} file grew past the {max_bytes} bytes allowed")
        return buffer
    except OSError as exc:
        raise FileFormatError(path, f"cannot read {what} file ({exc.strerror or exc})") from None
    except MemoryError:
        raise FileFormatError(path, f"{what} file is too large to read into memory") from None
    finally:
        os.close(fd)


def _ends_in_hole(fd: int, size: int, length: int) -> bool:
    """Whether the last ``length`` bytes of the open file ``fd`` (of ``size`` bytes) hold no data
    (one ``SEEK_DATA``; False where the file system cannot tell). The offset is put back."""
    seek_data = getattr(os, "SEEK_DATA", None)
    if seek_data is None or size <= length:
        return False
    here = os.lseek(fd, 0, os.SEEK_CUR)
    try:
        os.lseek(fd, size - length, seek_data)
    except OSError as exc:
        return exc.errno == errno.ENXIO  # no data from there to the end
    finally:
        os.lseek(fd, here, os.SEEK_SET)
    return False


def _read_into(fd: int, view: memoryview) -> int:
    """Fill ``view`` from ``fd`` until it is full or the file ends; the bytes read."""
    total = 0
    while total < len(view):
        n = os.readv(fd, [view[total:]])
        if n == 0:
            break
        total += n
    return total


def read_regular_text(path: str | Path, max_bytes: int, what: str) -> str:
    """Like :func:`read_regular_file`, decoded as UTF-8 (a bad byte is a one-line error)."""
    data = read_regular_file(path, max_bytes, what)
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            path, f"{what} file is not UTF-8 text (bad byte at offset {exc.start})"
        ) from None
