"""Reading the files a user gives: regular files only, with a size cap, errors naming the file.

A FIFO or a device (``/dev/zero``) would block or never end, so they are refused before any byte
is read: the path is opened non-blocking (opening a FIFO with no writer would otherwise wait
forever) and checked with ``fstat`` on the opened descriptor (no race between check and read).
"""

from __future__ import annotations

import errno
import json
import os
import stat
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

from ..errors import FileFormatError


def read_regular_file(
    path: str | Path,
    max_bytes: int,
    what: str,
    *,
    check_head: Callable[[bytes], None] | None = None,
    head_bytes: int = 0,
    max_zero_tail: int | None = None,
) -> bytearray:
    """The bytes of the regular file ``path``, at most ``max_bytes`` of them.

    ``what`` names the kind of file in messages ("controller", "track", ...). With
    ``check_head``, the first ``head_bytes`` bytes (fewer if the file is shorter) are read and
    passed to it before the rest: it raises to refuse the file, so a large file of the wrong
    kind is refused without reading it whole. The file is read into one buffer of its size (no
    second copy), and running out of memory is reported as a file error too. With
    ``max_zero_tail``, a file that ends in more than ``max_zero_tail`` zero bytes (written, or a
    hole a ``truncate`` left) is refused from its last ``max_zero_tail + 1`` bytes, before the
    rest is read.

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
        # The head and the tail are checked before the buffer is made (making it touches every
        # page of it): a large file of the wrong kind, or one that ends in zeros, costs little.
        if check_head is not None:
            check_head(_read_head(fd, min(head_bytes, info.st_size)))
        if max_zero_tail is not None and _ends_in_zeros(fd, info.st_size, max_zero_tail):
            raise FileFormatError(
                path, f"{what} file ends in more than {max_zero_tail} zero bytes (corrupt file)"
            )
        try:
            buffer = bytearray(info.st_size)
        except MemoryError:
            raise FileFormatError(
                path, f"{what} file is {info.st_size} bytes, more than memory allows"
            ) from None
        view = memoryview(buffer)
        total = _read_into(fd, view)
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


def _read_head(fd: int, n: int) -> bytes:
    """The first ``n`` bytes of ``fd`` (fewer if it is shorter), without moving its offset."""
    head = b""
    while len(head) < n:
        chunk = os.pread(fd, n - len(head), len(head))
        if not chunk:
            break
        head += chunk
    return head


def _ends_in_zeros(fd: int, size: int, length: int) -> bool:
    """Whether the file ``fd`` (of ``size`` bytes) ends in more than ``length`` zero bytes, read
    with ``pread`` (the offset does not move) from its last ``length + 1`` bytes only."""
    if size <= length:
        return False
    pos = size - length - 1
    while pos < size:
        chunk = os.pread(fd, min(1 << 20, size - pos), pos)
        if not chunk:  # it shrank meanwhile: the read proper tells
            return False
        if chunk.count(0) != len(chunk):
            return False
        pos += len(chunk)
    return True


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


class NonFiniteNumber(ValueError):
    """A JSON text spells NaN or Infinity (``str()`` is the spelling): no file of ours holds one."""


def reject_constant(name: str) -> NoReturn:
    """``parse_constant`` for ``json.loads``: Python's json accepts NaN, Infinity and -Infinity,
    which no file lfd-track reads may hold; raises :class:`NonFiniteNumber`."""
    raise NonFiniteNumber(name)


def parse_json_file_text(path: str | Path, text: str, what: str) -> Any:
    """``text`` (the file ``path``, a ``what`` file) parsed as strict JSON: NaN and Infinity,
    malformed text, nesting too deep for the parser and numbers it cannot hold each raise
    ``FileFormatError(path, problem)`` in one line."""
    try:
        return json.loads(text, parse_constant=reject_constant)
    except NonFiniteNumber as exc:
        raise FileFormatError(path, f"non-finite number {exc} is not allowed") from None
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            path, f"not valid JSON (truncated or corrupted?): {exc.msg} at line {exc.lineno}"
        ) from None
    except RecursionError:
        raise FileFormatError(path, f"JSON nested too deeply to be a {what} file") from None
    except ValueError as exc:  # e.g. an integer with thousands of digits
        raise FileFormatError(path, f"not a valid {what} file: {exc}") from None
