"""Property tests of the four file parsers (demonstration, controller, track, preset).

For any input, a parser either returns a valid object or raises ``FileFormatError`` whose message
is one line starting with the file's name; never another exception, never a hang. Run with
``-s`` to see how many inputs each property tried and how many were refused cleanly.
"""

from __future__ import annotations

import json
import math
import os
import struct
import zlib
from collections import Counter
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lfd_track.dataset import DemonstrationWriter, load_demonstration
from lfd_track.envs.presets import BOUNDS, SECTIONS, load_preset
from lfd_track.errors import FileFormatError
from lfd_track.policy.controller import MAX_ABS_WEIGHT, Controller, checksum
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.track import load_track
from lfd_track.world.track_file import segment_gaps

# LFD_PROPERTY_EXAMPLES=2000 runs a deeper, randomly seeded search (the counts quoted in the
# issue's closing note); by default the same 150 inputs per property on every run.
_DEEP = int(os.environ.get("LFD_PROPERTY_EXAMPLES", "0"))
SETTINGS = settings(
    max_examples=_DEEP or 150,
    deadline=None,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
    derandomize=not _DEEP,  # the same inputs on every run: a failure always reproduces
)
COUNTS: dict[str, Counter] = {}


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    for name, counts in sorted(COUNTS.items()):
        print(
            f"\n{name}: {counts['tried']} inputs, {counts['accepted']} accepted,"
            f" {counts['refused']} refused cleanly"
        )


def _outcome(name: str, path: Path, load):
    """Load ``path``; count the outcome; a refusal must be one line naming the file."""
    counts = COUNTS.setdefault(name, Counter())
    counts["tried"] += 1
    try:
        result = load(path)
    except FileFormatError as exc:
        message = str(exc)
        assert message.startswith(f"{path}: "), message
        assert "\n" not in message and len(message) < 2000
        counts["refused"] += 1
        return None
    counts["accepted"] += 1
    return result


# --------------------------------------------------------------------------- demonstrations
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
    demo = _outcome("demonstration: random bytes", path, load_demonstration)
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
    demo = _outcome(name, path, load_demonstration)
    if demo is not None:
        _check_demonstration(demo)


# --------------------------------------------------------------------------- controllers
def _controller_dict() -> dict:
    rng = np.random.default_rng(1)
    library = RoadLibrary(bins=4)
    library.learn_model(rng.random((5, 4)).astype(np.float32))
    controller = Controller(library, rng.uniform(-2, 2, 215), learner="bc", seed=3)
    return json.loads(json.dumps(controller.to_dict()))


JSON_VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**30), 10**30)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8),
    lambda children: (
        st.lists(children, max_size=4) | st.dictionaries(st.text(max_size=6), children, max_size=4)
    ),
    max_leaves=12,
)


def _load_controller(path: Path) -> Controller:
    controller = Controller.load(path)
    w = controller.weights
    assert np.isfinite(w).all() and np.abs(w).max() <= MAX_ABS_WEIGHT
    assert controller.library.n_models > 0
    return controller


@SETTINGS
@given(st.sampled_from(sorted(_controller_dict())), JSON_VALUES)
def test_controller_with_one_value_replaced(tmp_path, key, value):
    data = _controller_dict()
    data[key] = value
    data["checksum"] = checksum(data)  # a well-formed file with a wrong value behind the checksum
    path = tmp_path / "c.json"
    path.write_text(json.dumps(data))
    _outcome("controller: one value replaced, checksum fixed", path, _load_controller)


@SETTINGS
@given(st.integers(0, 10**7), st.characters(codec="utf-8"))
def test_controller_with_one_character_changed(tmp_path, where, char):
    text = json.dumps(_controller_dict(), separators=(",", ":"))
    i = where % len(text)
    path = tmp_path / "c.json"
    path.write_text(text[:i] + char + text[i + 1 :])
    loaded = _outcome("controller: one character changed", path, _load_controller)
    if loaded is not None:  # accepted only if nothing changed in meaning
        assert loaded.to_dict() == _controller_dict()


@SETTINGS
@given(st.binary(max_size=2000))
def test_any_bytes_as_a_controller(tmp_path, data):
    path = tmp_path / "c.json"
    path.write_bytes(data)
    _outcome("controller: random bytes", path, _load_controller)


# --------------------------------------------------------------------------- tracks
NUMBERS = (
    st.floats(allow_nan=True, allow_infinity=True)
    | st.floats(-10, 10)
    | st.integers(-(10**20), 10**20)
)
TOML_SCALARS = st.booleans() | st.text(max_size=10) | NUMBERS


def _toml(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return (
            "nan"
            if math.isnan(value)
            else ("inf" if value > 0 else "-inf")
            if math.isinf(value)
            else repr(value)
        )
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    raise TypeError(value)


def _check_track(path: Path):
    track = load_track(path)
    assert np.isfinite(track.vertices).all() and track.length_m > 0
    # Accepted means no strip comes within a width of a non-adjacent one: check all pairs.
    a, b = track.segment_starts, track.segment_ends
    n = len(a)
    i, j = np.triu_indices(n, 2)
    keep = ~(track.closed & (i == 0) & (j == n - 1))
    gaps = segment_gaps(a[i[keep]], b[i[keep]], a[j[keep]], b[j[keep]])
    assert (gaps >= track.width_m).all()
    return track


@st.composite
def _polygons(draw) -> list[tuple[float, float]]:
    """Mostly valid shapes: vertices on a circle at sorted angles (a convex loop or arc)."""
    n = draw(st.integers(3, 9))
    radius = draw(st.floats(0.4, 3.4))
    steps = draw(st.lists(st.floats(0.3, 2 * math.pi / n), min_size=n, max_size=n))
    angles = np.cumsum(steps).tolist()
    return [(3.5 + radius * math.cos(a), 3.5 + radius * math.sin(a)) for a in angles]


@SETTINGS
@given(
    st.lists(st.tuples(st.floats(-1, 6), st.floats(-1, 6)), max_size=12) | _polygons(),
    st.booleans(),
    st.sampled_from([0.25, 0.3]) | st.floats(0.23, 0.4) | NUMBERS,
    st.dictionaries(
        st.text("0123456789abc", min_size=1, max_size=3), st.integers(-2, 14), max_size=4
    ),
)
def test_random_track_geometry(tmp_path, vertices, closed, width, corners):
    lines = [f"closed = {_toml(closed)}", f"width_m = {_toml(width)}"]
    lines.append("vertices = " + _toml([[x, y] for x, y in vertices]))
    lines.append("[corners]")
    lines += [f"{json.dumps(k)} = {v}" for k, v in corners.items()]
    path = tmp_path / "t.toml"
    path.write_text("\n".join(lines) + "\n")
    _outcome("track: random geometry", path, _check_track)


@SETTINGS
@given(
    st.dictionaries(
        st.sampled_from(["name", "closed", "width_m", "vertices", "corners", "x"]),
        TOML_SCALARS | st.lists(TOML_SCALARS, max_size=4),
        max_size=6,
    )
)
def test_random_track_tables(tmp_path, table):
    path = tmp_path / "t.toml"
    path.write_text("".join(f"{k} = {_toml(v)}\n" for k, v in table.items()))
    _outcome("track: random tables", path, _check_track)


@SETTINGS
@given(st.binary(max_size=1500))
def test_any_bytes_as_a_track(tmp_path, data):
    path = tmp_path / "t.toml"
    path.write_bytes(data)
    _outcome("track: random bytes", path, _check_track)


# --------------------------------------------------------------------------- presets
FIELDS = sorted(BOUNDS)


def _check_preset(path: Path):
    preset = load_preset(path)
    drawn = preset.sample(np.random.default_rng(0))
    for name, (low, high) in BOUNDS.items():
        section, key = name.split(".")
        value = getattr(getattr(drawn, section), key)
        assert all(low <= v <= high for v in (value if isinstance(value, tuple) else (value,)))
    return preset


def _field_value(name: str):
    low, high = BOUNDS[name]
    section, key = name.split(".")
    default = getattr(SECTIONS[section](), key)
    near = (
        st.floats(low - (high - low), high + (high - low))
        if isinstance(default, float)
        else st.integers(int(low) - 5, int(high) + 5)
    )
    value = near | NUMBERS | st.booleans() | st.text(max_size=3)
    if isinstance(default, tuple):
        return st.lists(st.integers(-10, 300), min_size=2, max_size=4) | value
    return value


@SETTINGS
@given(st.data())
def test_random_preset_values(tmp_path, data):
    names = data.draw(st.lists(st.sampled_from(FIELDS), max_size=4, unique=True))
    tables: dict[str, list[str]] = {}
    for name in names:
        section, key = name.split(".")
        tables.setdefault(section, []).append(f"{key} = {_toml(data.draw(_field_value(name)))}")
    ranged = data.draw(st.lists(st.sampled_from(FIELDS), max_size=3, unique=True))
    lines = [f"[{s}]\n" + "\n".join(body) for s, body in tables.items()]
    if ranged:
        rows = []
        for name in ranged:
            lo, hi = data.draw(_field_value(name)), data.draw(_field_value(name))
            rows.append(f"{json.dumps(name)} = [{_toml(lo)}, {_toml(hi)}]")
        lines.append("[randomization]\n" + "\n".join(rows))
    path = tmp_path / "p.toml"
    path.write_text("\n".join(lines) + "\n")
    _outcome("preset: random values and ranges", path, _check_preset)


@SETTINGS
@given(st.binary(max_size=1500))
def test_any_bytes_as_a_preset(tmp_path, data):
    path = tmp_path / "p.toml"
    path.write_bytes(data)
    _outcome("preset: random bytes", path, _check_preset)
