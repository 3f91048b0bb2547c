"""Track files that used to hang or print bare Python errors: sizes, limits, odd bytes."""

from __future__ import annotations

import os

import numpy as np
import pytest

from lfd_track.errors import FileFormatError
from lfd_track.world import track_file
from lfd_track.world.track import load_track
from lfd_track.world.track_file import MAX_TRACK_SIZE_M, MAX_VERTICES, segment_gaps


def _toml_vertices(vertices) -> str:
    return "vertices = [" + ", ".join(f"[{float(x)!r}, {float(y)!r}]" for x, y in vertices) + "]\n"


def _refused(path, problem: str) -> str:
    with pytest.raises(FileFormatError) as info:
        load_track(path)
    message = str(info.value)
    assert message.startswith(f"{path}: ") and "\n" not in message
    assert problem in message, message
    return message


def _serpentine(rows: int, step_m: float = 0.4, row_gap_m: float = 0.6) -> list:
    """A valid open track: rows of short collinear segments joined by U-turns."""
    vertices = []
    xs = np.arange(0.0, 6.0 + 1e-9, step_m)
    for r in range(rows):
        row = xs if r % 2 == 0 else xs[::-1]
        vertices += [(float(x), r * row_gap_m) for x in row]
    return vertices


def test_validation_checks_a_near_linear_number_of_pairs(tmp_path, monkeypatch):
    vertices = _serpentine(10)
    n = len(vertices) - 1
    checked = []
    real = track_file.segment_gaps

    def counting(p1, p2, q1, q2):
        checked.append(len(p1))
        return real(p1, p2, q1, q2)

    monkeypatch.setattr(track_file, "segment_gaps", counting)
    path = tmp_path / "serpentine.toml"
    path.write_text(_toml_vertices(vertices))
    track = load_track(path)
    assert len(track.vertices) == n + 1 == 160
    # The wave-1 check compared all n (n - 1) / 2 = 12,561 pairs; the grid keeps near ones only.
    assert 0 < sum(checked) < 12 * n


def test_the_broad_phase_finds_every_close_pair():
    # Random segments: the grid must report exactly the pairs an all-pairs check reports.
    rng = np.random.default_rng(3)
    for _ in range(20):
        starts = rng.uniform(0, 3, (40, 2))
        ends = starts + rng.normal(0, 0.4, (40, 2))
        i, j = np.triu_indices(40, 2)
        gaps = segment_gaps(starts[i], ends[i], starts[j], ends[j])
        close = gaps < 0.25
        try:
            track_file.check_no_self_intersection("x", starts, ends, False, 0.25)
        except FileFormatError as exc:
            k = np.nonzero(close)[0][0]
            assert f"segments {i[k]} and {j[k]} come within" in str(exc)
        else:
            assert not close.any()


def test_a_ten_thousand_vertex_track_is_refused_at_once(tmp_path):
    rng = np.random.default_rng(0)
    dense = rng.uniform(0.0, 6.0, (MAX_VERTICES, 2))
    path = tmp_path / "dense.toml"
    path.write_text(_toml_vertices(dense))
    _refused(path, "self-intersecting strips")
    path.write_text(_toml_vertices(rng.uniform(0.0, 6.0, (MAX_VERTICES + 1, 2))))
    _refused(path, "10001 vertices, more than the 10000 allowed")


def test_size_limit_is_checked_at_load(tmp_path):
    path = tmp_path / "big.toml"
    path.write_text(_toml_vertices([(0.0, 0.0), (MAX_TRACK_SIZE_M, 0.0)]))
    _refused(path, "more than the 7 m x 7 m allowed")
    path.write_text("width_m = 5.0\n" + _toml_vertices([(0.0, 0.0), (1.0, 0.0)]))
    _refused(path, "wider than 2.0 m")


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("vertices = []\n", "at least 2 vertices, got 0"),
        ("closed = true\nvertices = []\n", "at least 3 vertices, got 0"),
        ("vertices = [[0, 0], [1" + "0" * 5000 + ", 0]]\n", "not valid TOML"),
        ("vertices = [[0, 0], [1" + "0" * 40 + ", 0]]\n", "within ±1000 m"),
        ("width_m = 1" + "0" * 400 + "\nvertices = [[0, 0], [1, 0]]\n", "finite number"),
        ("vertices = " + "[" * 200_000 + "]" * 200_000 + "\n", "TOML"),
        ("name = 7\nvertices = [[0, 0], [1, 0]]\n", "'name' must be a string"),
    ],
)
def test_odd_files_name_the_file(tmp_path, text, problem):
    path = tmp_path / "odd.toml"
    path.write_text(text)
    _refused(path, problem)


def test_non_utf8_fifo_and_device_are_refused(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes('name = "Sch\xf6n"\nvertices = [[0, 0], [1, 0]]\n'.encode("latin-1"))
    _refused(path, "not UTF-8")
    fifo = tmp_path / "fifo.toml"
    os.mkfifo(fifo)
    _refused(fifo, "not a regular file")  # used to wait forever for a writer
    _refused("/dev/zero", "not a regular file")
