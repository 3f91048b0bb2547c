"""Property tests of the demonstration parser: random bytes and mutated recordings.

For any input the parser returns a valid object or refuses the file in one line naming it
(``parser_property_support``); ``-s`` prints how many inputs each property tried.
"""

from __future__ import annotations

import struct
import zlib

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from parser_property_support import SETTINGS, outcome, print_counts

from lfd_track.dataset import DemonstrationWriter, load_demonstration
from lfd_track.vision.road_library import RoadLibrary


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print_counts()


BINS = 4


@pytest.fixture(scope="module")
def demo_bytes(tmp_path_factory) -> bytes:
    """A small valid recording with a logged library (all record kinds present)."""
    path = tmp_path_factory.mktemp("demo") / "valid.lfdemo"
    rng = np.random.default_rng(0)
    library = RoadLibrary(bins=BINS, max_types=2, max_examples=2)
    with DemonstrationWriter(path, {"track": "t"}, bins=BINS, fsync=False, library=library) as w:
        for i in range(4):
            library.learn_model(rng.random((5, BINS)).astype(np.float32))
            hists = rng.random((40, 5, BINS)).astype(np.float32)
            values = library.road_values_from_histograms(hists)
            w.append(i % 3, values, hists, source=("demonstration", "correction")[i % 2], round=i)
        w.close({"road_library": library.to_dict()})
    return path.read_bytes()


def _check_demonstration(demo) -> None:
    n = demo.n_cases
    assert demo.road_values.shape == (n, 40) and np.abs(demo.road_values).max(initial=0) <= 1 + 1e-6
    assert demo.histograms.min(initial=0) >= 0 and demo.histograms.max(initial=0) <= 1
    assert set(demo.commands.tolist()) <= {0, 1, 2} and (demo.steps >= 0).all()
    assert set(demo.sources.tolist()) <= {"demonstration", "correction"}
    assert (demo.rounds >= 0).all() and len(demo.rounds) == n


def _refix_crcs(data: bytearray) -> bytes:
    """Recompute every record's CRC, so a mutation reaches the checks behind the CRC."""
    pos = 8
    while pos + 9 <= len(data):
        kind = data[pos]
        (length,) = struct.unpack_from("<I", data, pos + 1)
        end = pos + 9 + length
        if end > len(data):
            break
        head = struct.pack("<BI", kind, length)
        struct.pack_into(
            "<I", data, pos + 5, zlib.crc32(bytes(data[pos + 9 : end]), zlib.crc32(head))
        )
        pos = end
    return bytes(data)


@SETTINGS
@given(st.binary(max_size=3000))
def test_any_bytes_as_a_demonstration(tmp_path, data):
    path = tmp_path / "any.lfdemo"
    path.write_bytes(data)
    demo = outcome("demonstration: random bytes", path, load_demonstration)
    if demo is not None:
        _check_demonstration(demo)


@SETTINGS
@given(
    st.lists(st.tuples(st.integers(0, 10**6), st.integers(0, 255)), min_size=1, max_size=8),
    st.booleans(),
    st.integers(0, 10**6),
)
def test_mutated_demonstrations(tmp_path, demo_bytes, edits, fix_crc, cut):
    data = bytearray(demo_bytes)
    for where, value in edits:
        data[8 + where % (len(data) - 8)] = value
    if fix_crc:
        data = bytearray(_refix_crcs(data))
    path = tmp_path / "mutated.lfdemo"
    path.write_bytes(bytes(data[: len(data) - cut % 400]))
    name = "demonstration: mutated" + (" (CRCs fixed)" if fix_crc else "")
    demo = outcome(name, path, load_demonstration)
    if demo is not None:
        _check_demonstration(demo)
