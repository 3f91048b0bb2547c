"""Demonstration file format: round trip, crash safety and rejection of damaged files."""

from __future__ import annotations

import os
import signal
import stat
import struct
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from lfd_track.dataset import (
    SCHEMA_VERSION,
    Demonstration,
    DemonstrationWriter,
    load_demonstration,
    save_demonstration,
)
from lfd_track.errors import FileFormatError

BINS = 8
MAGIC_LEN = 8
FRAME_LEN = 9  # kind u8, length u32, crc u32
INDEX_LEN = 4  # schema 4: a record's index, first in its payload


def _case(rng: np.random.Generator, bins: int = BINS):
    values = rng.uniform(-1.0, 1.0, 40)
    values[0] = 1.0  # exact bounds must pass validation
    values[1] = -1.0
    hists = rng.random((40, 5, bins)).astype(np.float32)
    return int(rng.integers(0, 3)), values, hists


def _record(path: Path, n: int, *, seed: int = 0, bins: int = BINS, close: bool = True):
    """Write ``n`` random cases; return what was written, for comparison."""
    rng = np.random.default_rng(seed)
    written = []
    meta = {"track": "training", "seed": seed, "demonstrator": {"dead_band_deg": 15.0}}
    writer = DemonstrationWriter(path, meta, bins=bins, fsync=False)
    for i in range(n):
        command, values, hists = _case(rng, bins)
        known = i % 2 == 0
        pose = tuple(rng.normal(size=3)) if known else None
        progress = float(rng.uniform(0, 5)) if known else None
        phase = ("library_only", "drive", "turnaround")[i % 3]
        learned = bool(i % 4)
        writer.append(
            command, values, hists, pose=pose, progress_m=progress, phase=phase, learned=learned
        )
        written.append((command, values, hists, pose, progress, phase, learned))
    if close:
        writer.close({"road_library": {"types": [[0.25, 0.5]], "bins": bins}})
    else:
        writer.abandon()
    return written


def _assert_cases_equal(demo: Demonstration, written: list) -> None:
    assert demo.n_cases == len(written)
    for i, (command, values, hists, pose, progress, phase, learned) in enumerate(written):
        assert demo.commands[i] == command
        # Bit-identical, not approximately equal.
        assert demo.road_values[i].tobytes() == values.astype(np.float64).tobytes()
        assert demo.histograms[i].tobytes() == hists.tobytes()
        if pose is None:
            assert np.isnan(demo.poses[i]).all() and np.isnan(demo.progress_m[i])
        else:
            assert demo.poses[i].tobytes() == np.array(pose).tobytes()
            assert demo.progress_m[i] == progress
        assert demo.phases[i] == phase
        assert demo.learned[i] == learned
        assert demo.steps[i] == i


def test_round_trip_is_bit_identical(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    written = _record(path, 7)
    demo = load_demonstration(path)
    _assert_cases_equal(demo, written)
    assert demo.commands.dtype == np.int8
    assert demo.road_values.dtype == np.float64 and demo.road_values.shape == (7, 40)
    assert demo.histograms.dtype == np.float32 and demo.histograms.shape == (7, 40, 5, BINS)
    assert demo.poses.shape == (7, 3) and demo.learned.dtype == bool
    meta = demo.metadata
    assert meta["complete"] is True and meta["torn_tail_bytes"] == 0
    assert meta["track"] == "training" and meta["demonstrator"] == {"dead_band_deg": 15.0}
    assert meta["road_library"] == {"types": [[0.25, 0.5]], "bins": BINS}
    assert meta["schema_version"] == SCHEMA_VERSION and meta["bins"] == BINS
    expected = {
        name: sum(1 for w in written if w[0] == c)
        for c, name in enumerate(("forward", "left", "right"))
    }
    assert meta["counts"] == expected == demo.command_counts
    assert meta["n_cases"] == 7 and meta["created_by"].startswith("lfd-track")
    with pytest.raises(ValueError):
        demo.road_values[0, 0] = 0.5  # loaded arrays are read-only


def test_same_input_gives_same_bytes_and_save_round_trips(tmp_path: Path) -> None:
    a, b = tmp_path / "a.lfdemo", tmp_path / "b.lfdemo"
    written = _record(a, 5, seed=3)
    _record(b, 5, seed=3)
    assert a.read_bytes() == b.read_bytes()

    copy = tmp_path / "sub" / "copy.lfdemo"
    save_demonstration(copy, load_demonstration(a))
    again = load_demonstration(copy)
    _assert_cases_equal(again, written)
    assert again.metadata == load_demonstration(a).metadata


def test_empty_demonstration_round_trips(tmp_path: Path) -> None:
    path = tmp_path / "empty.lfdemo"
    with DemonstrationWriter(path, {}, bins=4, fsync=False):
        pass
    demo = load_demonstration(path)
    assert demo.n_cases == 0 and demo.histograms.shape == (0, 40, 5, 4)
    assert demo.metadata["complete"] is True


def test_writer_refuses_to_overwrite_and_rejects_bad_cases(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    rng = np.random.default_rng(1)
    _, values, hists = _case(rng)
    with DemonstrationWriter(path, {}, bins=BINS, fsync=False) as writer:
        with pytest.raises(ValueError, match="command"):
            writer.append(3, values, hists)
        with pytest.raises(ValueError, match="outside"):
            writer.append(0, values * 1.5, hists)
        with pytest.raises(ValueError, match="shape"):
            writer.append(0, values[:39], hists)
        with pytest.raises(ValueError, match="shape"):
            writer.append(0, values, hists[..., :4])
        with pytest.raises(ValueError, match="NaN"):
            writer.append(0, np.full(40, np.nan), hists)
        writer.append(0, values, hists)
    assert load_demonstration(path).n_cases == 1  # rejected cases left no trace
    with pytest.raises(FileExistsError):
        DemonstrationWriter(path, {}, bins=BINS)
    with pytest.raises(ValueError, match="JSON"):
        DemonstrationWriter(tmp_path / "other.lfdemo", {"bad": float("nan")}, bins=BINS)


def test_exception_inside_with_leaves_an_incomplete_but_readable_file(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    rng = np.random.default_rng(2)
    with pytest.raises(RuntimeError), DemonstrationWriter(path, {}, bins=BINS, fsync=False) as w:
        for _ in range(3):
            w.append(*_case(rng))
        raise RuntimeError("demonstrator crashed")
    demo = load_demonstration(path)
    assert demo.n_cases == 3 and demo.metadata["complete"] is False


_RECORDER = textwrap.dedent(
    """
    import sys
    import numpy as np
    from lfd_track.dataset import DemonstrationWriter

    rng = np.random.default_rng(5)
    with DemonstrationWriter(sys.argv[1], {"track": "training"}, bins=32) as writer:
        i = 0
        while True:
            values = rng.uniform(-1.0, 1.0, 40)
            hists = rng.random((40, 5, 32)).astype(np.float32)
            writer.append(i % 3, values, hists, pose=(i, 0.0, 0.0), progress_m=0.1 * i)
            print(i, flush=True)
            i += 1
    """
)


def test_sigkill_mid_recording_keeps_every_reported_case(tmp_path: Path) -> None:
    path = tmp_path / "killed.lfdemo"
    script = tmp_path / "recorder.py"
    script.write_text(_RECORDER)
    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "PYTHONPATH": str(root)}
    proc = subprocess.Popen(
        [sys.executable, str(script), str(path)], stdout=subprocess.PIPE, text=True, env=env
    )
    k = 12
    try:
        reported = -1
        assert proc.stdout is not None
        for line in proc.stdout:  # blocks on the child's output: no sleeps needed
            reported = int(line)
            if reported + 1 >= k:
                break
        proc.send_signal(signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait()
    assert proc.returncode == -signal.SIGKILL
    assert reported + 1 >= k

    demo = load_demonstration(path)
    assert demo.n_cases >= k
    assert demo.metadata["complete"] is False
    # Every case is intact: replay the recorder's random stream and compare bit for bit.
    rng = np.random.default_rng(5)
    for i in range(demo.n_cases):
        values = rng.uniform(-1.0, 1.0, 40)
        hists = rng.random((40, 5, 32)).astype(np.float32)
        assert demo.road_values[i].tobytes() == values.tobytes()
        assert demo.histograms[i].tobytes() == hists.tobytes()
        assert demo.commands[i] == i % 3 and demo.poses[i, 0] == i


def _one_line_error(path: Path, match: str) -> None:
    with pytest.raises(FileFormatError) as info:
        load_demonstration(path)
    message = str(info.value)
    assert "\n" not in message
    assert message.startswith(f"{path}: ")
    assert match in message


def _case_offsets(data: bytes) -> list[int]:
    """Start of every record after the magic."""
    offsets, pos = [], MAGIC_LEN
    while pos < len(data):
        offsets.append(pos)
        (length,) = struct.unpack_from("<I", data, pos + 1)
        pos += FRAME_LEN + length
    return offsets


def test_torn_last_record_is_dropped_and_reported(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    written = _record(path, 4, close=False)
    data = path.read_bytes()
    last = _case_offsets(data)[-1]
    for cut in (last + 3, last + FRAME_LEN + 100, len(data) - 1):
        path.write_bytes(data[:cut])
        demo = load_demonstration(path)
        _assert_cases_equal(demo, written[:3])
        assert demo.metadata["complete"] is False
        assert demo.metadata["torn_tail_bytes"] == cut - last
    # A whole-length last record whose bytes never landed (zero fill) is torn too.
    zeroed = bytearray(data)
    zeroed[last + FRAME_LEN :] = bytes(len(data) - last - FRAME_LEN)
    path.write_bytes(bytes(zeroed))
    assert load_demonstration(path).n_cases == 3
    path.write_bytes(data + bytes(50))
    assert load_demonstration(path).n_cases == 4


def test_damaged_files_are_rejected_with_one_line(tmp_path: Path) -> None:
    good = tmp_path / "good.lfdemo"
    _record(good, 4)
    data = good.read_bytes()
    offsets = _case_offsets(data)
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
    import zlib

    (length,) = struct.unpack_from("<I", data, MAGIC_LEN + 1)
    start = MAGIC_LEN + FRAME_LEN
    header = json.loads(data[start : start + length])
    payload = raw(json.dumps(edit(header)).encode())
    head = struct.pack("<BI", ord("H"), len(payload))
    frame = struct.pack("<BII", ord("H"), len(payload), zlib.crc32(payload, zlib.crc32(head)))
    return data[:MAGIC_LEN] + frame + payload + data[start + length :]


def _with_case_byte(data: bytes, offset: int, value: int) -> bytes:
    """Set one payload byte of the record at ``offset`` and fix its CRC."""
    import zlib

    (length,) = struct.unpack_from("<I", data, offset + 1)
    payload = bytearray(data[offset + FRAME_LEN : offset + FRAME_LEN + length])
    payload[4 + 8] = value  # the command byte, after the record index and the int64 step
    head = struct.pack("<BI", data[offset], length)
    crc = zlib.crc32(bytes(payload), zlib.crc32(head))
    frame = struct.pack("<BII", data[offset], length, crc)
    return data[:offset] + frame + bytes(payload) + data[offset + FRAME_LEN + length :]


def test_wrong_schema_or_values_are_rejected(tmp_path: Path) -> None:
    good = tmp_path / "good.lfdemo"
    _record(good, 3)
    data = good.read_bytes()
    bad = tmp_path / "bad.lfdemo"

    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "schema": 99}))
    _one_line_error(bad, "unsupported schema version 99")
    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "bins": 16}))
    _one_line_error(bad, "expected")  # case records are sized for 8 bins
    bad.write_bytes(_rewrite_header(data, lambda h: {**h, "n_values": 41}))
    _one_line_error(bad, "41 values")

    offsets = _case_offsets(data)
    bad.write_bytes(_with_case_byte(data, offsets[2], 7))
    _one_line_error(bad, "case 1: command 7")


# --------------------------------------------------------------------------- schema 2 additions


def test_cases_carry_source_and_round(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    rng = np.random.default_rng(4)
    with DemonstrationWriter(path, {}, bins=BINS, fsync=False) as writer:
        writer.append(*_case(rng))  # defaults: a demonstration of round 0
        writer.append(*_case(rng), source="correction", round=2)
        writer.append(*_case(rng), source="demonstration", round=1)
        with pytest.raises(ValueError, match="source"):
            writer.append(*_case(rng), source="policy")
        with pytest.raises(ValueError, match="round"):
            writer.append(*_case(rng), round=-1)
        with pytest.raises(ValueError, match="step"):
            writer.append(*_case(rng), step=-3)
    demo = load_demonstration(path)
    assert demo.sources.tolist() == ["demonstration", "correction", "demonstration"]
    assert demo.rounds.tolist() == [0, 2, 1] and demo.rounds.dtype == np.int64
    assert demo.metadata["schema_version"] == SCHEMA_VERSION == 4
    copy = tmp_path / "copy.lfdemo"
    save_demonstration(copy, demo)
    again = load_demonstration(copy)
    assert again.sources.tolist() == demo.sources.tolist()
    assert again.rounds.tolist() == demo.rounds.tolist()


def _schema_1_file(path: Path, n: int, rng: np.random.Generator) -> list:
    """A wave-1 (schema 1) file, encoded here independently of the writer."""
    import json
    import zlib

    def frame(kind: str, payload: bytes) -> bytes:
        head = struct.pack("<BI", ord(kind), len(payload))
        return struct.pack("<BII", ord(kind), len(payload), zlib.crc32(payload, zlib.crc32(head)))

    header = {
        "format": "lfd-track demonstration",
        "schema": 1,
        "bins": BINS,
        "n_values": 40,
        "n_channels": 5,
        "metadata": {"track": "training"},
    }
    out = [b"\x89LFDEMO\n"]
    payload = json.dumps(header).encode()
    out += [frame("H", payload), payload]
    written = []
    for i in range(n):
        command, values, hists = _case(rng)
        fixed = struct.pack("<qBBH4d", i, command, 1, 5, 0.5, 0.25, 0.1, 1.5)
        payload = fixed + b"drive" + values.astype("<f8").tobytes() + hists.tobytes()
        out += [frame("C", payload), payload]
        written.append((command, values, hists))
    payload = json.dumps({"n_cases": n, "road_library": None}).encode()
    out += [frame("F", payload), payload]
    path.write_bytes(b"".join(out))
    return written


def test_schema_1_files_still_load_as_round_0_demonstrations(tmp_path: Path) -> None:
    path = tmp_path / "wave1.lfdemo"
    written = _schema_1_file(path, 3, np.random.default_rng(9))
    demo = load_demonstration(path)
    assert demo.n_cases == 3 and demo.metadata["schema_version"] == 1
    assert demo.sources.tolist() == ["demonstration"] * 3 and demo.rounds.tolist() == [0, 0, 0]
    for i, (command, values, hists) in enumerate(written):
        assert demo.commands[i] == command
        assert demo.road_values[i].tobytes() == values.tobytes()
        assert demo.histograms[i].tobytes() == hists.tobytes()
    assert demo.poses[0].tolist() == [0.5, 0.25, 0.1] and demo.phases[0] == "drive"
    assert demo.metadata["library_log"] is False


def test_impossible_values_are_refused(tmp_path: Path) -> None:
    rng = np.random.default_rng(3)
    command, values, hists = _case(rng)
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
    _record(good, 2)
    data = good.read_bytes()
    offsets = _case_offsets(data)
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
    import zlib

    (length,) = struct.unpack_from("<I", data, offset + 1)
    payload = bytearray(data[offset + FRAME_LEN : offset + FRAME_LEN + length])
    at += INDEX_LEN
    payload[at : at + len(new)] = new
    head = struct.pack("<BI", data[offset], length)
    frame = struct.pack("<BII", data[offset], length, zlib.crc32(bytes(payload), zlib.crc32(head)))
    return data[:offset] + frame + bytes(payload) + data[offset + FRAME_LEN + length :]


def _record_with_library(path: Path, n_frames: int, *, close: bool = True):
    """Learn and look at synthetic frames as the demonstrator does; snapshot after every case."""
    from lfd_track.vision.road_library import RoadLibrary

    rng = np.random.default_rng(11)
    # Cheap frames: a few base colours with noise, so that types and examples both form.
    bases = rng.integers(0, 256, (5, 3))
    frames = [
        np.clip(bases[i % 5] + rng.normal(0, 12, (480, 640, 3)), 0, 255).astype(np.uint8)
        for i in range(n_frames)
    ]
    # A small library so that types and examples are evicted during the recording.
    library = RoadLibrary(bins=BINS, max_types=3, max_examples=2)
    snapshots = []
    writer = DemonstrationWriter(path, {}, bins=BINS, fsync=False, library=library)
    for i, frame in enumerate(frames):
        if i % 3 != 2:
            library.learn(frame)
        hists = library.region_histograms(frame)
        values = library.road_values_from_histograms(hists)
        library.road_values_from_histograms(hists, update_statistics=False)  # looking only
        if i >= 2:  # the first frames only build the library, as in the protocol
            writer.append(i % 3, values, hists, learned=i % 3 != 2)
            snapshots.append(library.to_dict())
    if close:
        writer.close({"road_library": library.to_dict()})
    else:
        writer.abandon()
    library.learn(frames[0])  # after closing: not logged
    return snapshots


def test_library_log_rebuilds_the_record_time_library(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    snapshots = _record_with_library(path, 24)
    demo = load_demonstration(path)
    assert demo.metadata["library_log"] is True
    # The loader checked the replayed library against the footer snapshot; prove it can fail:
    # a footer that disagrees with the log is refused.
    assert demo.metadata["road_library"] == snapshots[-1]
    types = snapshots[-1]["types"]
    assert len(types) == 3 and any(len(t["examples"]) == 2 for t in types)  # evictions happened

    data = path.read_bytes()
    offsets = _case_offsets(data)
    kinds = [data[o] for o in offsets]
    assert kinds.count(ord("L")) > 3 * 2 and kinds.count(ord("S")) == 24
    # Cut the file right after each case: the partial file's library is the one at that case.
    ends = [nxt for o, nxt in zip(offsets, offsets[1:], strict=False) if data[o] == ord("C")]
    partial = tmp_path / "partial.lfdemo"
    for k, end in enumerate(ends):
        partial.write_bytes(data[:end])
        cut = load_demonstration(partial)
        assert cut.n_cases == k + 1 and cut.metadata["complete"] is False
        assert cut.metadata["road_library"] == snapshots[k], f"case {k}"


def test_abandoned_recording_keeps_its_library(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    snapshots = _record_with_library(path, 12, close=False)
    demo = load_demonstration(path)
    assert demo.metadata["complete"] is False and demo.metadata["road_library"] == snapshots[-1]
    from lfd_track.vision.road_library import RoadLibrary

    assert RoadLibrary.from_dict(demo.metadata["road_library"]).n_models > 0


def test_footer_that_disagrees_with_the_log_is_refused(tmp_path: Path) -> None:
    import json
    import zlib

    path = tmp_path / "demo.lfdemo"
    _record_with_library(path, 9)
    data = path.read_bytes()
    footer_at = _case_offsets(data)[-1]
    index = data[footer_at + FRAME_LEN : footer_at + FRAME_LEN + INDEX_LEN]
    footer = json.loads(data[footer_at + FRAME_LEN + INDEX_LEN :])
    footer["road_library"]["types"][0]["selections"] += 1
    payload = index + json.dumps(footer).encode()
    head = struct.pack("<BI", ord("F"), len(payload))
    frame = struct.pack("<BII", ord("F"), len(payload), zlib.crc32(payload, zlib.crc32(head)))
    path.write_bytes(data[:footer_at] + frame + payload)
    _one_line_error(path, "does not rebuild the footer's library")
    # A learning record that cannot apply (an evicted type that does not exist) is named.
    learned_at = next(o for o in _case_offsets(data) if data[o] == ord("L"))
    path.write_bytes(_with_payload(data, learned_at, 0, struct.pack("<hhh", 7, -1, -1)))
    _one_line_error(path, "does not apply")


def test_fifo_device_and_deep_json_are_refused_naming_the_file(tmp_path: Path) -> None:
    fifo = tmp_path / "demo.lfdemo"
    os.mkfifo(fifo)  # wave 1 waited forever for a writer
    _one_line_error(fifo, "not a regular file")
    with pytest.raises(FileFormatError, match="^/dev/zero: not a regular file"):
        load_demonstration("/dev/zero")  # wave 1: MemoryError traceback
    good = tmp_path / "good.lfdemo"
    _record(good, 1)
    deep = tmp_path / "deep.lfdemo"
    nested = (
        lambda h: {**h, "metadata": {"x": 0}},
        lambda b: b.replace(b"0}", b"[" * 200_000 + b"]" * 200_000 + b"}"),
    )
    deep.write_bytes(_rewrite_header(good.read_bytes(), *nested))
    _one_line_error(deep, "header JSON is nested too deeply")


@pytest.mark.parametrize("overwrite", [False, True])
def test_a_header_that_cannot_be_written_leaves_no_file(tmp_path, monkeypatch, overwrite):
    """A full disk (or an interrupt) while the header is written: nothing was recorded, so no
    file is left behind for the next recording to be refused over."""
    path = tmp_path / "demo.lfdemo"

    def full_disk(self, data, sync=True):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(DemonstrationWriter, "_write", full_disk)
    with pytest.raises(OSError, match="No space left"):
        DemonstrationWriter(path, {}, bins=4, fsync=False, overwrite=overwrite)
    assert not path.exists()


# --------------------------------------------------------------------------- integrity (schema 4)
def _records(data: bytes) -> list[bytes]:
    """The whole records after the magic, the header first."""
    offsets = _case_offsets(data) + [len(data)]
    return [data[a:b] for a, b in zip(offsets, offsets[1:], strict=False)]


def _reframe(record: bytes, payload: bytes) -> bytes:
    """``record``'s kind with ``payload`` and a valid CRC."""
    import zlib

    head = struct.pack("<BI", record[0], len(payload))
    return struct.pack("<BII", record[0], len(payload), zlib.crc32(payload, zlib.crc32(head))) + (
        payload
    )


def _corrupt_footer(data: bytes, how: str) -> bytes:
    footer_at = _case_offsets(data)[-1]
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
    _record(path, 3)
    path.write_bytes(_corrupt_footer(path.read_bytes(), how))
    with pytest.raises(FileFormatError, match="corrupt") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def _rearranged(data: bytes, how: str) -> bytes:
    header, *rest = _records(data)
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
        _record_with_library(path, 9, close=closed)
    else:
        _record(path, 4, close=closed)
    path.write_bytes(_rearranged(path.read_bytes(), how))
    if how == "the last case missing" and not closed:
        # Cut at a record boundary: exactly what an interrupted recording looks like.
        assert load_demonstration(path).metadata["complete"] is False
        return
    with pytest.raises(FileFormatError, match="missing, repeated or out of order") as info:
        load_demonstration(path)
    assert str(path) in str(info.value) and "\n" not in str(info.value)


def _older_schema(data: bytes, schema: int) -> bytes:
    """The same recording in the layout of ``schema`` (2 or 3): no record indexes."""
    import json

    header, *rest = _records(data)
    meta = json.loads(header[FRAME_LEN:])
    n_memory = meta.pop("n_memory")
    if schema == 3:
        meta["n_memory"] = n_memory
    meta["schema"] = schema
    older = [_reframe(header, json.dumps(meta).encode())]
    older += [_reframe(r, r[FRAME_LEN + INDEX_LEN :]) for r in rest]
    return data[:MAGIC_LEN] + b"".join(older)


@pytest.mark.parametrize("schema", [2, 3])
@pytest.mark.parametrize("closed", [True, False])
def test_schema_2_and_3_files_load_as_before(tmp_path, schema, closed):
    path = tmp_path / "new.lfdemo"
    n_memory = 1 if schema == 3 else 0
    with DemonstrationWriter(
        path, {"kind": "test"}, bins=BINS, fsync=False, n_memory=n_memory
    ) as writer:
        rng = np.random.default_rng(5)
        for i in range(4):
            memory = [0.5] if n_memory else None
            writer.append(*_case(rng), pose=(0.1 * i, 0.0, 0.0), memory=memory)
        if not closed:
            writer.abandon()
    new = load_demonstration(path)
    old_path = tmp_path / "old.lfdemo"
    old_path.write_bytes(_older_schema(path.read_bytes(), schema))
    old = load_demonstration(old_path)
    assert old.metadata["schema_version"] == schema and new.metadata["schema_version"] == 4
    assert {**old.metadata, "schema_version": 4} == new.metadata
    for name in ("commands", "road_values", "histograms", "poses", "steps", "memory"):
        assert getattr(old, name).tobytes() == getattr(new, name).tobytes(), name


@pytest.mark.parametrize("sparse", [True, False])
def test_a_header_followed_by_a_huge_zero_tail_is_refused(tmp_path, monkeypatch, sparse):
    from lfd_track.dataset import MAX_ZERO_TAIL_BYTES
    from lfd_track.utils import files

    path = tmp_path / "demo.lfdemo"
    _record(path, 2, close=False)
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


@pytest.mark.parametrize("kind", ["fifo", "link"])
def test_a_recording_never_replaces_a_fifo_or_a_symbolic_link(tmp_path, kind):
    from lfd_track.errors import LfdTrackError

    path = tmp_path / "demo.lfdemo"
    target = tmp_path / "elsewhere.lfdemo"
    target.write_bytes(b"kept")
    reader = None
    if kind == "fifo":
        os.mkfifo(path)
        reader = os.open(path, os.O_RDONLY | os.O_NONBLOCK)  # so opening it never blocks
    else:
        path.symlink_to(target)
    try:
        with pytest.raises(LfdTrackError, match="a FIFO|symbolic link"):
            DemonstrationWriter(path, {}, bins=BINS, fsync=False, overwrite=True)
        if reader is not None:
            assert os.read(reader, 1) == b""  # nothing was written into it
    finally:
        if reader is not None:
            os.close(reader)
    mode = os.lstat(path).st_mode
    assert stat.S_ISFIFO(mode) if kind == "fifo" else stat.S_ISLNK(mode)
    assert target.read_bytes() == b"kept"
