"""Property tests of the track file parser: random geometry, random tables, random bytes.

For any input the parser returns a valid object or refuses the file in one line naming it
(``parser_property_support``); ``-s`` prints how many inputs each property tried.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from parser_property_support import (
    NUMBERS,
    SETTINGS,
    TOML_SCALARS,
    outcome,
    print_counts,
    toml_value,
)

from lfd_track.world.track import load_track
from lfd_track.world.track_file import segment_gaps


@pytest.fixture(scope="module", autouse=True)
def _report_counts():
    yield
    print_counts()


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
    lines = [f"closed = {toml_value(closed)}", f"width_m = {toml_value(width)}"]
    lines.append("vertices = " + toml_value([[x, y] for x, y in vertices]))
    lines.append("[corners]")
    lines += [f"{json.dumps(k)} = {v}" for k, v in corners.items()]
    path = tmp_path / "t.toml"
    path.write_text("\n".join(lines) + "\n")
    outcome("track: random geometry", path, _check_track)


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
    path.write_text("".join(f"{k} = {toml_value(v)}\n" for k, v in table.items()))
    outcome("track: random tables", path, _check_track)


@SETTINGS
@given(st.binary(max_size=1500))
def test_any_bytes_as_a_track(tmp_path, data):
    path = tmp_path / "t.toml"
    path.write_bytes(data)
    outcome("track: random bytes", path, _check_track)
