"""Writing ``.lfdemo`` test recordings and finding their records: what the demonstration file
tests of this folder share."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path

import numpy as np

from lfd_track.dataset import DemonstrationWriter

BINS = 8
MAGIC_LEN = 8
FRAME_LEN = 9  # kind u8, length u32, crc u32
INDEX_LEN = 4  # schema 4: a record's index, first in its payload


def make_case(rng: np.random.Generator, bins: int = BINS):
    """A random case: (command, 40 road values with both exact bounds, (40, 5, bins) histograms)."""
    values = rng.uniform(-1.0, 1.0, 40)
    values[0] = 1.0  # exact bounds must pass validation
    values[1] = -1.0
    hists = rng.random((40, 5, bins)).astype(np.float32)
    return int(rng.integers(0, 3)), values, hists


def write_recording(path: Path, n: int, *, seed: int = 0, bins: int = BINS, close: bool = True):
    """Write ``n`` random cases; return what was written, for comparison."""
    rng = np.random.default_rng(seed)
    written = []
    meta = {"track": "training", "seed": seed, "demonstrator": {"dead_band_deg": 15.0}}
    writer = DemonstrationWriter(path, meta, bins=bins, fsync=False)
    for i in range(n):
        command, values, hists = make_case(rng, bins)
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


def case_offsets(data: bytes) -> list[int]:
    """Start of every record after the magic."""
    offsets, pos = [], MAGIC_LEN
    while pos < len(data):
        offsets.append(pos)
        (length,) = struct.unpack_from("<I", data, pos + 1)
        pos += FRAME_LEN + length
    return offsets


def framed(kind: int, payload: bytes) -> bytes:
    """A record of ``kind`` holding ``payload``, with its length and a valid CRC (of the kind and
    length, then the payload), as the writer frames it."""
    head = struct.pack("<BI", kind, len(payload))
    return struct.pack("<BII", kind, len(payload), zlib.crc32(payload, zlib.crc32(head))) + payload


def write_recording_with_library(path: Path, n_frames: int, *, close: bool = True):
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


def split_records(data: bytes) -> list[bytes]:
    """The whole records after the magic, the header first."""
    offsets = case_offsets(data) + [len(data)]
    return [data[a:b] for a, b in zip(offsets, offsets[1:], strict=False)]
