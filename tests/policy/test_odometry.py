"""Visual odometry on the floor: the motion between two frames, measured against the simulated
rover's true pose, and refused where the floor gives nothing to match."""

import math
from functools import cache

import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers the env)
from lfd_track.envs.presets import load_preset
from lfd_track.policy.map_geometry import PAPER_GEOMETRY, MapGeometry
from lfd_track.policy.odometry import FloorOdometry, PlanarMotion

SLIP = "benchmarks/experiments/robustness/presets/slip.toml"
NOMINAL = {
    0: PlanarMotion(0.10, 0.0, 0.0),
    1: PlanarMotion(0.0, 0.0, 22.9),
    2: PlanarMotion(0.0, 0.0, -22.9),
}


def _true_motion(before: tuple[float, ...], after: tuple[float, ...]) -> PlanarMotion:
    """The rover's motion from pose ``before`` to pose ``after``, in its frame at ``before``."""
    dx, dy = after[0] - before[0], after[1] - before[1]
    cos, sin = math.cos(before[2]), math.sin(before[2])
    turn = math.remainder(after[2] - before[2], 2.0 * math.pi)
    return PlanarMotion(cos * dx + sin * dy, -sin * dx + cos * dy, math.degrees(turn))


@cache
def _drive(preset: str) -> list[tuple[np.ndarray, np.ndarray, int, PlanarMotion]]:
    """Frames before and after each of six commands on the training track's first strip (two
    forward, a left, a right, two forward), with the true motion of each."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    path = preset if preset == "paper" else str(root / preset)
    env = gym.make("LfDTrack-v0", track="training", preset=path)
    frame, info = env.reset(seed=3)
    out = []
    for command in (0, 0, 1, 2, 0, 0):
        after, _, _, _, after_info = env.step(command)
        out.append((frame, after, command, _true_motion(info["pose"], after_info["pose"])))
        frame, info = after, after_info
    env.close()
    return out


@pytest.mark.parametrize("preset", ["paper", SLIP])
def test_the_motion_between_frames_matches_the_true_one(preset: str) -> None:
    # Every command's turn within 0.5 deg and its shift within 1 cm of the rover's true motion,
    # where the nominal motion is further off (slip: a forward command turns the rover too).
    odometry = FloorOdometry(PAPER_GEOMETRY)
    nominal_turn_errors = []
    for before, after, command, truth in _drive(preset):
        found = odometry.between(before, after, NOMINAL[command])
        assert found.reliable, (command, found)
        assert found.motion.turn_deg == pytest.approx(truth.turn_deg, abs=0.5)
        assert found.motion.forward_m == pytest.approx(truth.forward_m, abs=0.01)
        assert found.motion.left_m == pytest.approx(truth.left_m, abs=0.01)
        nominal_turn_errors.append(abs(NOMINAL[command].turn_deg - truth.turn_deg))
    assert max(nominal_turn_errors) > 1.0  # the nominal motion is off by more than that


def test_a_floor_without_texture_is_not_trusted() -> None:
    odometry = FloorOdometry(PAPER_GEOMETRY)
    grey = np.full((480, 640, 3), 120, dtype=np.uint8)
    noise = np.random.default_rng(0).normal(0.0, 1.5, grey.shape)
    flat = np.clip(grey + noise, 0, 255).astype(np.uint8)
    found = odometry.between(grey, flat, NOMINAL[0])
    assert not found.reliable
    assert found.texture < 4.0


def test_frames_of_another_size_are_refused_in_one_line() -> None:
    odometry = FloorOdometry(PAPER_GEOMETRY)
    with pytest.raises(ValueError, match="640 x 480"):
        odometry.view(np.zeros((240, 320, 3), dtype=np.uint8))


@pytest.mark.parametrize("preset", ["wide", "paper_fast"])
def test_other_cameras_get_a_view_of_their_own_floor(preset: str) -> None:
    # The fisheye and the half-size camera: the view follows the camera of the map's geometry.
    geometry = MapGeometry.from_preset(load_preset(preset))
    odometry = FloorOdometry(geometry)
    camera = geometry.camera()
    frame = np.zeros((camera.frame_height_px, camera.frame_width_px, 3), dtype=np.uint8)
    assert odometry.view(frame).fine.shape == odometry._seen.shape


def test_planar_motion_moves_points_into_the_frame_after_it() -> None:
    # A point 1 m ahead, after a 0.1 m step and a quarter turn left, lies 0.9 m to the right.
    moved = PlanarMotion(0.1, 0.0, 90.0).move_points(np.array([[1.0, 0.0]]))
    np.testing.assert_allclose(moved, [[0.0, -0.9]], atol=1e-12)
    matrix = PlanarMotion(0.1, 0.0, 90.0).matrix()
    np.testing.assert_allclose(matrix @ [0.0, -0.9, 1.0], [1.0, 0.0, 1.0], atol=1e-12)
