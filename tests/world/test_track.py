"""Track files: the paper's geometry, validation of bad files, felt and progress geometry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.errors import FileFormatError
from lfd_track.world.track import ProgressTracker, load_track


def test_testing_track_matches_paper_geometry():
    track = load_track("testing")
    assert track.closed
    assert track.length_m == pytest.approx(8.546, abs=0.01)
    assert [c.label for c in track.corners] == ["1", "2", "3", "4"]
    assert [round(abs(c.turn_deg)) for c in track.corners] == [90, 90, 45, 135]
    assert sum(c.turn_deg for c in track.corners) == pytest.approx(360.0)


def test_testing_track_directions_meet_corners_in_table_3_order():
    ccw = load_track("testing")
    cw = load_track("testing", reverse=True)
    assert [c.label for c in ccw.corners] == ["1", "2", "3", "4"]
    assert [c.label for c in cw.corners] == ["3", "2", "1", "4"]
    # Both directions start on corner 4.
    np.testing.assert_allclose(ccw.vertices[0], [0.0, 0.0])
    np.testing.assert_allclose(cw.vertices[0], [0.0, 0.0])


def test_start_corner_rotates_the_loop():
    track = load_track("testing", start_corner="2")
    np.testing.assert_allclose(track.vertices[0], [3.0, 1.8])
    assert [c.label for c in track.corners] == ["3", "4", "1", "2"]


def test_training_track_directions():
    d1 = load_track("training")
    d2 = load_track("training", reverse=True)
    assert not d1.closed
    assert d1.length_m == pytest.approx(0.9 + 1.83 + 0.9, abs=0.001)
    assert [c.label for c in d1.corners] == ["1", "2"]
    assert [c.label for c in d2.corners] == ["2", "1"]
    assert all(abs(abs(c.turn_deg) - 45.0) < 0.01 for c in d1.corners)


def test_felt_union_and_open_ends():
    track = load_track("training")
    # On the straight, inside the half-width; off beyond it.
    assert track.on_felt(np.array([1.5, 0.14]))
    assert not track.on_felt(np.array([1.5, 0.16]))
    # Open ends are flat: nothing past the end vertex along the arm.
    end = track.vertices[0]
    outward = (track.vertices[0] - track.vertices[1]) / np.linalg.norm(
        track.vertices[0] - track.vertices[1]
    )
    assert track.on_felt(end - outward * 0.01)
    assert not track.on_felt(end + outward * 0.01)
    # Loop corners are covered by the overlapping strip extensions.
    loop = load_track("testing")
    assert loop.on_felt(np.array([3.14, -0.14]))


def test_progress_is_continuous_across_the_135_degree_corner():
    track = load_track("testing")
    tracker = ProgressTracker(track, start_progress_m=track.length_m - 0.5)
    # Walk the centreline from 0.5 m before corner 4 to 0.5 m after it in 2 cm steps.
    last = tracker.progress_m
    for s in np.arange(track.length_m - 0.5, track.length_m + 0.5, 0.02):
        point, _ = track.point_at(s)
        progress = tracker.update(point)
        assert progress == pytest.approx(s, abs=1e-6)
        assert progress >= last - 1e-9
        last = progress


def test_progress_never_snaps_across_the_sharp_corner():
    track = load_track("testing")
    # A point on the diagonal near corner 4 is also close to the first straight; progress started
    # on the diagonal must stay on it.
    s = track.length_m - 0.35
    point, heading = track.point_at(s)
    tracker = ProgressTracker(track, start_progress_m=s)
    progress = tracker.update(point + np.array([0.0, -0.05]))
    assert s - 0.05 < progress < track.length_m  # still before corner 4, not on the first straight


def test_progress_is_continuous_off_the_centreline_inside_sharp_corners():
    track = load_track("testing")
    # Cut the inside of corner 4 (the 135° corner) along a straight chord.
    start, _ = track.point_at(track.length_m - 0.6)
    end, _ = track.point_at(track.length_m + 0.6)
    tracker = ProgressTracker(track, start_progress_m=track.length_m - 0.6)
    last = None
    for f in np.linspace(0.0, 1.0, 121):
        progress = tracker.update(start + f * (end - start))
        assert last is None or 0.0 <= progress - last < 0.05
        last = progress
    assert last == pytest.approx(track.length_m + 0.6)


def _write(tmp_path, text):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    return path


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("closed = false\nvertices = [[0.0, 0.0]]\n", "at least 2 vertices"),
        ("closed = false\nwidth_m = 0.0\nvertices = [[0.0, 0.0], [1.0, 0.0]]\n", "must be > 0"),
        (
            "closed = false\nwidth_m = 0.2\nvertices = [[0.0, 0.0], [1.0, 0.0]]\n",
            "narrower than the rover",
        ),
        (
            'closed = false\nvertices = [[0.0, 0.0], [1.0, 0.0]]\ncolour = "red"\n',
            "unknown key 'colour'",
        ),
        ("closed = false\nvertices = [[0.0, 0.0], [nan, 0.0]]\n", "NaN"),
        ("closed = false\nwidth_m = nan\nvertices = [[0.0, 0.0], [1.0, 0.0]]\n", "finite"),
        (
            "closed = true\nvertices = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [1.0, -1.0], [0.0, 2.0]]\n",
            "self-intersecting",
        ),
        ("closed = false\nvertices = [[0.0, 0.0], [1.0, 0.0], [0.0, 0.0]]\n", "self-intersecting"),
        ('closed = false\nvertices = [[0.0, 0.0], [1.0, 0.0]]\n[corners]\n"1" = 7\n', "corner '1'"),
        ("this is = not toml [", "not valid TOML"),
        ("closed = false\nvertices = [[0.0, 0.0], [1e300, 0.0]]\n", "within ±1000 m"),
    ],
)
def test_bad_track_files_are_rejected_with_one_line(tmp_path, text, problem):
    path = _write(tmp_path, text)
    with pytest.raises(FileFormatError) as excinfo:
        load_track(path)
    message = str(excinfo.value)
    assert "\n" not in message
    assert str(path) in message
    assert problem in message


def test_unknown_track_name():
    with pytest.raises(
        FileNotFoundError,
        match="unknown track 'nowhere' \\(shipped: arrow, bolt, cove, kite, ledge, notch, sbend, step,"
        " testing, training, zed",
    ):
        load_track("nowhere")


def test_sbend_track_is_a_valid_general_loop():
    track = load_track("sbend")
    turns = [c.turn_deg for c in track.corners]
    assert any(t > 0 for t in turns) and any(t < 0 for t in turns)
    v = track.vertices
    d = np.roll(v, -1, axis=0) - v
    total = sum(
        math.atan2(d[i - 1][0] * d[i][1] - d[i - 1][1] * d[i][0], float(np.dot(d[i - 1], d[i])))
        for i in range(len(v))
    )
    assert total == pytest.approx(2 * math.pi)  # a simple counter-clockwise loop


def test_bad_start_corner_blames_the_argument_not_the_file():
    from lfd_track.world.track import StartCornerError

    with pytest.raises(StartCornerError, match="start_corner='1': track 'training' is not a loop"):
        load_track("training", start_corner="1")
    with pytest.raises(StartCornerError, match="has no such corner"):
        load_track("testing", start_corner="9")


def test_project_gives_each_points_foot_on_every_segment_alone_or_many_at_once():
    track = load_track("training")
    points = np.array([[0.3, 0.2], [1.0, -0.4], [-0.5, 0.9]])
    many = track.project(points)
    assert many.shape == (3, len(track.segment_s), 2)
    for point, row in zip(points, many, strict=True):
        np.testing.assert_array_equal(track.project(point), row)
    # a point on the centreline lies at distance 0 from its segment, at its arc length
    on, _ = track.point_at(0.7)
    arc, dist = min(track.project(on), key=lambda r: r[1])
    assert dist == pytest.approx(0.0, abs=1e-12) and arc == pytest.approx(0.7, abs=1e-9)
