"""Reading user files: one buffer, the head checked before the rest, memory errors named."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from lfd_track.dataset import load_demonstration
from lfd_track.errors import FileFormatError
from lfd_track.utils import files


def test_contents_are_read_whole_and_the_head_is_checked_first(tmp_path: Path) -> None:
    path = tmp_path / "data.bin"
    payload = bytes(range(256)) * 5000
    path.write_bytes(payload)
    seen = []
    data = files.read_regular_file(
        path, len(payload), "test", check_head=seen.append, head_bytes=10
    )
    assert bytes(data) == payload and seen == [payload[:10]]
    assert bytes(files.read_regular_file(path, len(payload), "test")) == payload
    # A file shorter than the head gives the head what there is.
    path.write_bytes(b"abc")
    seen.clear()
    assert bytes(files.read_regular_file(path, 10, "t", check_head=seen.append, head_bytes=8)) == (
        b"abc"
    )
    assert seen == [b"abc"]


def test_a_huge_file_of_another_kind_is_refused_from_its_first_bytes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # 256 MiB of zeros (sparse, so it costs no disk): "bad magic" must come from the first
    # bytes, not after reading (and holding) the whole file.
    path = tmp_path / "zeros.lfdemo"
    with open(path, "wb") as f:
        f.truncate(256 << 20)
    reads = []
    real_read, real_readv = os.read, os.readv

    def counting_read(fd, n):
        data = real_read(fd, n)
        reads.append(len(data))
        return data

    def counting_readv(fd, buffers):
        n = real_readv(fd, buffers)
        reads.append(n)
        return n

    monkeypatch.setattr(files.os, "read", counting_read)
    monkeypatch.setattr(files.os, "readv", counting_readv)
    with pytest.raises(FileFormatError, match="bad magic") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    assert sum(reads) < 1 << 20


def test_running_out_of_memory_is_a_file_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "big.lfdemo"
    path.write_bytes(b"x" * 1000)

    def no_memory(*args):
        raise MemoryError

    monkeypatch.setattr(files, "bytearray", no_memory, raising=False)
    with pytest.raises(FileFormatError, match="more than memory allows") as info:
        files.read_regular_file(path, 10_000, "demonstration")
    assert str(path) in str(info.value)
