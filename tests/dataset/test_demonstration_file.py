"""Demonstration file format: round trip, crash safety, and older schemas read as before."""

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
    SCHEMA_VERSION,
    Demonstration,
    DemonstrationWriter,
    load_demonstration,
    save_demonstration,
)


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
    written = write_recording(path, 7)
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
    written = write_recording(a, 5, seed=3)
    write_recording(b, 5, seed=3)
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
    _, values, hists = make_case(rng)
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
            w.append(*make_case(rng))
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


def test_torn_last_record_is_dropped_and_reported(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    written = write_recording(path, 4, close=False)
    data = path.read_bytes()
    last = case_offsets(data)[-1]
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


def test_cases_carry_source_and_round(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    rng = np.random.default_rng(4)
    with DemonstrationWriter(path, {}, bins=BINS, fsync=False) as writer:
        writer.append(*make_case(rng))  # defaults: a demonstration of round 0
        writer.append(*make_case(rng), source="correction", round=2)
        writer.append(*make_case(rng), source="demonstration", round=1)
        with pytest.raises(ValueError, match="source"):
            writer.append(*make_case(rng), source="policy")
        with pytest.raises(ValueError, match="round"):
            writer.append(*make_case(rng), round=-1)
        with pytest.raises(ValueError, match="step"):
            writer.append(*make_case(rng), step=-3)
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
        command, values, hists = make_case(rng)
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


def test_library_log_rebuilds_the_record_time_library(tmp_path: Path) -> None:
    path = tmp_path / "demo.lfdemo"
    snapshots = write_recording_with_library(path, 24)
    demo = load_demonstration(path)
    assert demo.metadata["library_log"] is True
    # The loader checked the replayed library against the footer snapshot; prove it can fail:
    # a footer that disagrees with the log is refused.
    assert demo.metadata["road_library"] == snapshots[-1]
    types = snapshots[-1]["types"]
    assert len(types) == 3 and any(len(t["examples"]) == 2 for t in types)  # evictions happened

    data = path.read_bytes()
    offsets = case_offsets(data)
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
    snapshots = write_recording_with_library(path, 12, close=False)
    demo = load_demonstration(path)
    assert demo.metadata["complete"] is False and demo.metadata["road_library"] == snapshots[-1]
    from lfd_track.vision.road_library import RoadLibrary

    assert RoadLibrary.from_dict(demo.metadata["road_library"]).n_models > 0


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


def _older_schema(data: bytes, schema: int) -> bytes:
    """The same recording in the layout of ``schema`` (2 or 3): no record indexes."""
    import json

    header, *rest = split_records(data)
    meta = json.loads(header[FRAME_LEN:])
    n_memory = meta.pop("n_memory")
    if schema == 3:
        meta["n_memory"] = n_memory
    meta["schema"] = schema
    older = [framed(header[0], json.dumps(meta).encode())]
    older += [framed(r[0], r[FRAME_LEN + INDEX_LEN :]) for r in rest]
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
            writer.append(*make_case(rng), pose=(0.1 * i, 0.0, 0.0), memory=memory)
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
