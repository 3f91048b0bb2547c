"""The unseen tracks: valid loops that mix left and right turns of 45–135° in one direction."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.render.texture import MAX_TEXTURE_BYTES, AppearanceConfig
from lfd_track.world.driver import CentrelineDriver, DriverConfig
from lfd_track.world.rover import Rover, RoverConfig
from lfd_track.world.track import (
    MORE_UNSEEN_TRACKS,
    UNSEEN_TRACKS,
    VALIDATION_TRACKS,
    ProgressTracker,
    load_track,
)

#: Turning angles per corner in file (counter-clockwise) order, left positive [deg].
EXPECTED_TURNS = {
    "notch": {"B": 90.0, "C": 90.0, "D": 63.43, "E": -126.87, "F": 63.43, "G": 90.0, "A": 90.0},
    "bolt": {"B": 90.0, "C": 135.0, "D": -45.0, "E": -45.0, "F": 135.0, "A": 90.0},
    "step": {"B": 90.0, "C": 90.0, "D": -90.0, "E": 90.0, "F": 45.0, "G": 45.0, "A": 90.0},
    "arrow": {"B": 50.19, "C": 79.61, "D": 50.19, "E": 129.81, "F": -79.61, "A": 129.81},
    "zed": {
        "B": 90.0,
        "C": -90.0,
        "D": 90.0,
        "E": 90.0,
        "F": 90.0,
        "G": -66.8,
        "H": 66.8,
        "A": 90.0,
    },
    # The validation loops that mix left and right turns (kite turns one way only).
    "cove": {"B": 90.0, "C": 135.0, "D": -90.0, "E": 45.0, "F": 90.0, "A": 90.0},
    "ledge": {
        "B": 45.0,
        "C": -45.0,
        "D": 90.0,
        "E": 90.0,
        "F": 90.0,
        "G": -90.0,
        "H": 90.0,
        "A": 90.0,
    },
}


def test_there_are_at_least_three_unseen_tracks():
    assert len(UNSEEN_TRACKS) >= 3
    mixed_validation = set(VALIDATION_TRACKS) - {"kite"}
    assert {*UNSEEN_TRACKS, *MORE_UNSEEN_TRACKS, *mixed_validation} == set(EXPECTED_TURNS)
    assert not {"testing", "training"} & {*UNSEEN_TRACKS, *MORE_UNSEEN_TRACKS}
    # A loop is either for choosing or for scoring, never both.
    assert not set(VALIDATION_TRACKS) & {*UNSEEN_TRACKS, *MORE_UNSEEN_TRACKS}


@pytest.mark.parametrize("name", sorted(EXPECTED_TURNS))
def test_unseen_track_turn_angles(name):
    track = load_track(name)
    assert track.closed
    turns = {c.label: c.turn_deg for c in track.corners}
    assert turns == pytest.approx(EXPECTED_TURNS[name], abs=0.01)
    # Every vertex is a named corner, so no turn goes uncounted.
    assert len(track.corners) == len(track.vertices)
    assert sum(turns.values()) == pytest.approx(360.0)  # counter-clockwise in file order
    assert all(45.0 - 1e-6 <= abs(t) <= 135.0 + 1e-6 for t in turns.values())


@pytest.mark.parametrize("name", sorted(EXPECTED_TURNS))
@pytest.mark.parametrize("reverse", [False, True])
def test_each_direction_has_left_and_right_turns(name, reverse):
    turns = [c.turn_deg for c in load_track(name, reverse=reverse).corners]
    assert any(t > 0 for t in turns) and any(t < 0 for t in turns)
    if reverse:
        forward = {c.label: c.turn_deg for c in load_track(name).corners}
        for corner in load_track(name, reverse=True).corners:
            assert corner.turn_deg == pytest.approx(-forward[corner.label])


@pytest.mark.parametrize("name", sorted(EXPECTED_TURNS))
def test_unseen_track_fits_the_texture_limit_and_leaves_room_between_corners(name):
    track = load_track(name)
    appearance = AppearanceConfig()
    xmin, ymin, xmax, ymax = track.bounds(appearance.margin_m)
    texels = (math.ceil((xmax - xmin) / appearance.metres_per_px) + 1) * (
        math.ceil((ymax - ymin) / appearance.metres_per_px) + 1
    )
    assert texels * 4 <= MAX_TEXTURE_BYTES
    # Corners at least 1 m apart: "negotiated" (0.30 m after) comes before the next "reached".
    assert track.segment_lengths.min() >= 1.0
    np.testing.assert_allclose(track.vertices[0], load_track(name, reverse=True).vertices[0])


@pytest.mark.parametrize("name", sorted(EXPECTED_TURNS))
@pytest.mark.parametrize("reverse", [False, True])
def test_the_privileged_driver_laps_each_unseen_track(name, reverse):
    """Drivable: the paper-calibrated rover under the centreline driver completes a lap on felt."""
    track = load_track(name, reverse=reverse)
    rng = np.random.default_rng(3)
    rover = Rover(RoverConfig())
    start, heading = track.point_at(0.0)
    rover.reset((start[0], start[1], heading), rng)
    tracker = ProgressTracker(track)
    driver = CentrelineDriver(track, DriverConfig())
    best = tracker.update(rover.pose[:2])
    for _ in range(600):
        rover.step(driver.act(rover.pose, tracker.progress_m), rng)
        progress = tracker.update(rover.pose[:2])
        best = max(best, progress)
        assert best - progress < 0.30  # never "reversed"
        assert track.on_felt(rover.tread_points()).any()  # never "off_track"
        if best >= track.length_m:
            break
    assert best >= track.length_m
