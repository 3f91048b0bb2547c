"""The watching human's intervention rule, one trigger at a time (InterventionConfig defaults:
heading error over 35°, an outer tread 3 cm over the felt edge, progress 0.10 m below its
maximum, 8 policy commands with less than 0.05 m of progress)."""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest

from lfd_track.teaching.scripted import HumanConfig, InterventionConfig, Watcher
from lfd_track.world.driver import CentrelineDriver
from lfd_track.world.rover import RoverConfig
from lfd_track.world.track import ProgressTracker, load_track

S = 0.6  # metres along the training track's first straight


@pytest.fixture
def scene():
    track = load_track("training")
    driver = CentrelineDriver(track, HumanConfig().driver)
    centre, heading = track.point_at(S)
    watcher = Watcher(InterventionConfig(), RoverConfig().body_width_m / 2.0)
    return track, driver, np.asarray(centre, dtype=np.float64), float(heading), watcher


def _reason(scene, *, turn_deg=0.0, offset_m=0.0, max_progress_m=S):
    track, driver, centre, heading, watcher = scene
    normal = np.array([-math.sin(heading), math.cos(heading)])
    xy = centre + offset_m * normal
    pose = np.array([xy[0], xy[1], heading + math.radians(turn_deg)])
    tracker = ProgressTracker(track)
    tracker.update(pose[:2])
    assert tracker.progress_m == pytest.approx(
        S, abs=0.03
    )  # bisector zones: offset moves it a little
    return watcher.reason(track, driver, tracker, max_progress_m, pose)


def test_a_robot_on_the_centreline_pointing_ahead_is_left_alone(scene):
    assert _reason(scene) is None


@pytest.mark.parametrize(
    ("turn_deg", "expected"), [(20, None), (-30, None), (45, "heading"), (-50, "heading")]
)
def test_heading_error_beyond_35_degrees_fires(scene, turn_deg, expected):
    assert _reason(scene, turn_deg=turn_deg) == expected


def test_a_tread_3_cm_over_the_felt_edge_fires(scene):
    track = scene[0]
    half_rover = RoverConfig().body_width_m / 2.0
    limit = (
        track.width_m / 2.0 + 0.03 - half_rover
    )  # centre offset where the tread reaches 3 cm over
    assert _reason(scene, offset_m=limit - 0.01) is None
    assert _reason(scene, offset_m=limit + 0.01) == "edge"
    assert _reason(scene, offset_m=-(limit + 0.01)) == "edge"


def test_falling_back_more_than_10_cm_fires(scene):
    assert _reason(scene, max_progress_m=S + 0.05) is None
    assert _reason(scene, max_progress_m=S + 0.15) == "progress"


def test_eight_commands_without_5_cm_of_progress_is_a_stall(scene):
    watcher = scene[4]
    crawl = deque([0.004 * i for i in range(9)])  # 9 samples = 8 commands, 3.2 cm gained
    assert watcher.stalled(crawl)
    assert not watcher.stalled(deque([0.01 * i for i in range(9)]))  # 8 cm: moving on
    assert not watcher.stalled(deque([0.0] * 8))  # only 7 commands watched so far
