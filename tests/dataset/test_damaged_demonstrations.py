"""Demonstration file format: damaged, impossible or reordered files are refused in one line
naming the file, never read as something else."""

from __future__ import annotations

import os
import struct
from pathlib import Path

import numpy as np
import pytest
from lfdemo_files import (
    BINS,
    FRAME_LEN,
    INDEX_LEN,
    MAGIC_LEN,
    case_offsets,
    framed,
    make_case,
    split_records,
    write_recording,
    write_recording_with_library,
)

from lfd_track.dataset import (
    DemonstrationWriter,
    load_demonstration,
)
from lfd_track.errors import FileFormatError


def _one_line_error(path: Path, match: str) -> None:
    with pytest.raises(FileFormatError) as info:
        load_demonstration(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert match in message


def test_damaged_files_are_rejected_with_one_line(tmp_path: Path) -> None:
    good = tmp_path / "good.lfdemo"
    write_recording(good, 4)
    data = good.read_bytes()
    offsets = case_offsets(data)
    bad = tmp_path / "bad.lfdemo"

    bad.write_bytes(b"")
    _one_line_error(bad, "empty file")
    bad.write_bytes(data[:5])
    _one_line_error(bad, "truncated header")
    bad.write_bytes(data[: offsets[1] - 10])
    _one_line_error(bad, "truncated header")
    bad.write_bytes(b"PK\x03\x04 this is a zip, not a demonstration" * 4)
    _one_line_error(bad, "bad magic")
    bad.write_bytes(bytes(range(256)) * 8)
    _one_line_error(bad, "bad magic")

    # Mid-file corruption: flip one histogram byte of the second case.
    corrupt = bytearray(data)
    corrupt[offsets[2] + 2000] ^= 0xFF
    bad.write_bytes(bytes(corrupt))
    _one_line_error(bad, "CRC mismatch")

    # Corrupt header.
    corrupt = bytearray(data)
    corrupt[MAGIC_LEN + FRAME_LEN + 3] ^= 0x01
    bad.write_bytes(bytes(corrupt))
    _one_line_error(bad, "header record is corrupt")

    # Corrupt length field in the middle (a huge length is not a torn tail).
    corrupt = bytearray(data)
    corrupt[offsets[2] + 1 : offsets[2] + 5] = struct.pack("<I", 0x7FFFFFFF)
    bad.write_bytes(bytes(corrupt))
    _one_line_error(bad, "impossible length")

    bad.write_bytes(data + data[offsets[1] : offsets[2]])
    _one_line_error(bad, "after the footer")


def _rewrite_header(data: bytes, edit, raw=lambda b: b) -> bytes:
    """Replace the header JSON with ``edit(header)`` and a valid CRC (a well-formed wrong file);
    ``raw`` may then change the JSON bytes."""
    import json

    (length,) = struct.unpack_from("<I", data, MAGIC_LEN + 1)
    start = MAGIC_LEN + FRAME_LEN
    header = json.loads(data[start : start + length])
    payload = raw(json.dumps(edit(header)).encode())
    return data[:MAGIC_LEN] + framed(ord("H"), payload) + data[start + length :]


def _with_case_byte(data: bytes, offset: int, value: int) -> bytes:
    """Set one payload byte of the record at ``offset`` and fix its CRC."""
    return _with_payload(data, offset, 8, bytes([value]))  # the command, after the int64 step


def test_wrong_schema_or_values_are_rejected(tmp_path: Path) -> None:
    good = tmp_path / "good.lfdemo"
    write_recording(good, 3)
    data = good.read_bytes()
    bad = tmp_path / "bad.lfdemo"

    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "schema": 99}))
    _one_line_error(bad, "unsupported schema version 99")
    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "bins": 16}))
    _one_line_error(bad, "expected")  # case records are sized for 8 bins
    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "n_values": 41}))
    _one_line_error(bad, "41 values")

    offsets = case_offsets(data)
    bad.write_bytes(_with_case_byte(data, offsets[2], 7))
    _one_line_error(bad, "case 1: command 7")


def test_impossible_values_are_refused(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    command, values, hists = make_case(rng)
    with DemonstrationWriter(tmp_path / "w.lfdemo", {}, bins=BINS, fsync=False) as writer:
        with pytest.raises(ValueError, match=r"\[0, 1\]"):
            writer.append(command, values, hists * 3)
        with pytest.raises(ValueError, match="pose"):
            writer.append(command, values, hists, pose=(1e9, 0.0, 0.0))
        with pytest.raises(ValueError, match="pose"):
            writer.append(command, values, hists, pose=(np.nan, 0.0, 0.0))
        with pytest.raises(ValueError, match="progress"):
            writer.append(command, values, hists, progress_m=np.inf)
    # The same values written past the writer's checks are refused by the loader, naming the case.
    good = tmp_path / "good.lfdemo"
    write_recording(good, 2)
    data = good.read_bytes()
    offsets = case_offsets(data)
    bad = tmp_path / "bad.lfdemo"
    bad.write_bytes(_with_payload(data, offsets[1], 0, struct.pack("<q", -5)))
    _one_line_error(bad, "case 0: step -5 is negative")
    big = struct.pack("<f", 2.5)
    end = FRAME_LEN + struct.unpack_from("<I", data, offsets[1] + 1)[0]
    bad.write_bytes(_with_payload(data, offsets[1], end - FRAME_LEN - INDEX_LEN - 4, big))
    _one_line_error(bad, "case 0: region histograms values must lie in [0, 1]")
    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "metadata": {"x": float("nan")}}))
    _one_line_error(bad, "header: non-finite number NaN")
    huge = (lambda h: {**h, "metadata": {"x": 12345}}, lambda b: b.replace(b"12345", b"9" * 5000))
    bad.write_bytes(_rewrite_header(data, *huge))
    _one_line_error(bad, "header: Exceeds the limit")


def _with_payload(data: bytes, offset: int, at: int, new: bytes) -> bytes:
    """Overwrite payload bytes ``at`` (counted after the record's index) of the record at
    ``offset`` and fix its CRC."""
    (length,) = struct.unpack_from("<I", data, offset + 1)
    payload = bytearray(data[offset + FRAME_LEN : offset + FRAME_LEN + length])
    at += INDEX_LEN
    payload[at : at + len(new)] = new
    return (
        data[:offset] + framed(data[offset], bytes(payload)) + data[offset + FRAME_LEN + length :]
    )


def test_footer_that_disagrees_with_the_log_is_refused(tmp_path: Path) -> None:
    import json
    import zlib

    path = tmp_path / "demo.lfdemo"
    write_recording_with_library(path, 9)
    data = path.read_bytes()
    footer_at = case_offsets(data)[-1]
    index = data[footer_at + FRAME_LEN : footer_at + FRAME_LEN + INDEX_LEN]
    footer = json.loads(data[footer_at + FRAME_LEN + INDEX_LEN :])
    footer["road_library"]["types"][0]["selections"] += 1
    payload = index + json.dumps(footer).encode()
    head = struct.pack("<BI", ord("F"), len(payload))
    frame = struct.pack("<BII", ord("F"), len(payload), zlib.crc32(payload, zlib.crc32(head)))
    path.write_bytes(data[:footer_at] + frame + payload)
    _one_line_error(path, "does not rebuild the footer's library")
    # A learning record that cannot apply (an evicted type that does not exist) is named.
    learned_at = next(o for o in case_offsets(data) if data[o] == ord("L"))
    path.write_bytes(_with_payload(data, learned_at, 0, struct.pack("<hhh", 7, -1, -1)))
    _one_line_error(path, "does not apply")


def test_fifo_device_and_deep_json_are_refused_naming_the_file(tmp_path: Path) -> None:
    fifo = tmp_path / "demo.lfdemo"
    os.mkfifo(fifo)  # wave 1 waited forever for a writer
    _one_line_error(fifo, "not a regular file")
    with pytest.raises(FileFormatError, match="^/dev/zero: not a regular file"):
        load_demonstration("/dev/zero")  # wave 1: MemoryError traceback
    good = tmp_path / "good.lfdemo"
    write_recording(good, 1)
    deep = tmp_path / "deep.lfdemo"
    nested = (
        lambda h: {**h, "metadata": {"x": 0}},
        lambda b: b.replace(b"0}", b"[" * 200_000 + b"]" * 200_000 + b"}"),
    )
    deep.write_bytes(_rewrite_header(good.read_bytes(), *nested))
    _one_line_error(deep, "header JSON is nested too deeply")


def _corrupt_footer(data: bytes, how: str) -> bytes:
    footer_at = case_offsets(data)[-1]
    assert data[footer_at] == ord("F")
    damaged = bytearray(data)
    (length,) = struct.unpack_from("<I", data, footer_at + 1)
    if how == "a JSON byte flipped":
        damaged[-5] ^= 0x20
    elif how == "its CRC flipped":
        damaged[footer_at + 5] ^= 0x01
    elif how == "its length too long":
        struct.pack_into("<I", damaged, footer_at + 1, length + 7)
    elif how == "its length too short":
        struct.pack_into("<I", damaged, footer_at + 1, length - 7)
    else:  # its kind changed
        damaged[footer_at] = ord("Q")
    return bytes(damaged)


@pytest.mark.parametrize(
    "how",
    [
        "a JSON byte flipped",
        "its CRC flipped",
        "its length too long",
        "its length too short",
        "its kind changed",
    ],
)
def test_a_corrupted_footer_is_corruption_not_an_interrupted_recording(tmp_path, how):
    path = tmp_path / "demo.lfdemo"
    write_recording(path, 3)
    path.write_bytes(_corrupt_footer(path.read_bytes(), how))
    with pytest.raises(FileFormatError, match="corrupt") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def _rearranged(data: bytes, how: str) -> bytes:
    header, *rest = split_records(data)
    cases = [i for i, r in enumerate(rest) if r[0] == ord("C")]
    if how == "two cases swapped":
        a, b = cases[0], cases[1]
        rest[a], rest[b] = rest[b], rest[a]
    elif how == "a case repeated":
        rest.insert(cases[1], rest[cases[1]])
    elif how == "a case missing":
        del rest[cases[1]]
    elif how == "the last case missing":
        del rest[cases[-1]]
    elif how == "a library record missing":
        del rest[next(i for i, r in enumerate(rest) if r[0] == ord("L"))]
    else:  # a selection record repeated
        i = next(i for i, r in enumerate(rest) if r[0] == ord("S"))
        rest.insert(i, rest[i])
    return data[:MAGIC_LEN] + header + b"".join(rest)


@pytest.mark.parametrize(
    "how",
    [
        "two cases swapped",
        "a case repeated",
        "a case missing",
        "the last case missing",
        "a library record missing",
        "a selection record repeated",
    ],
)
@pytest.mark.parametrize("closed", [True, False])
def test_records_out_of_order_repeated_or_missing_are_refused(tmp_path, how, closed):
    path = tmp_path / "demo.lfdemo"
    if "library" in how or "selection" in how:
        write_recording_with_library(path, 9, close=closed)
    else:
        write_recording(path, 4, close=closed)
    path.write_bytes(_rearranged(path.read_bytes(), how))
    if how == "the last case missing" and not closed:
        # Cut at a record boundary: exactly what an interrupted recording looks like.
        assert load_demonstration(path).metadata["complete"] is False
        return
    with pytest.raises(FileFormatError, match="missing, repeated or out of order") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


@pytest.mark.parametrize("sparse", [True, False])
def test_a_header_followed_by_a_huge_zero_tail_is_refused(tmp_path, monkeypatch, sparse):
    from lfd_track.dataset import MAX_ZERO_TAIL_BYTES
    from lfd_track.utils import files

    path = tmp_path / "demo.lfdemo"
    write_recording(path, 2, close=False)
    size = path.stat().st_size + MAX_ZERO_TAIL_BYTES + (1 << 20)
    with open(path, "r+b") as f:
        if sparse:
            f.truncate(size)  # a hole: never written, reads as zeros
        else:
            f.seek(0, os.SEEK_END)
            f.write(bytes(size - f.tell()))
    reads = []
    real_readv = os.readv

    def counting_readv(fd, buffers):
        n = real_readv(fd, buffers)
        reads.append(n)
        return n

    monkeypatch.setattr(files.os, "readv", counting_readv)
    with pytest.raises(FileFormatError, match="corrupt") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)
    assert sum(reads) == 0  # refused from its head and its tail, not read whole
