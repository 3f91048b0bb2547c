"""Env arguments are checked the Gymnasium way: at once, with a clear error, nothing half-done."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

from lfd_track.envs.track_env import LfDTrackEnv


@pytest.mark.parametrize("max_steps", [0, -5, 2.5, True, "10", np.float64(3.0)])
def test_max_steps_must_be_a_positive_integer(max_steps):
    with pytest.raises(ValueError, match="max_steps must be a positive integer"):
        LfDTrackEnv(max_steps=max_steps)


def test_integer_types_are_accepted_for_max_steps():
    assert LfDTrackEnv(max_steps=np.int64(7)).max_steps == 7


@pytest.mark.parametrize("reverse", ["yes", 1, None, "False"])
def test_reverse_must_be_a_bool(reverse):
    with pytest.raises(TypeError, match="reverse must be True or False"):
        LfDTrackEnv(reverse=reverse)


def test_start_corner_as_int_or_string():
    by_int = LfDTrackEnv(start_corner=1).track
    by_str = LfDTrackEnv(start_corner="1").track
    assert by_int.vertices.tobytes() == by_str.vertices.tobytes()
    assert [c.label for c in by_int.corners] == [c.label for c in by_str.corners]
    with pytest.raises(TypeError, match="start_corner"):
        LfDTrackEnv(start_corner=True)
    with pytest.raises(ValueError, match="no such corner"):
        LfDTrackEnv(start_corner=9)


@pytest.mark.parametrize(
    ("options", "error", "match"),
    [
        ("pose", TypeError, "options must be a dict"),
        ({"speed": 2.0}, ValueError, "unknown reset option 'speed'"),
        ({"pose": [math.nan, 0.0, 0.0]}, ValueError, "three finite numbers"),
        ({"pose": [0.0, 0.0]}, ValueError, "three finite numbers"),
        ({"pose": "here"}, ValueError, "pose"),
        ({"pose": [0.0, 0.0, 1e300]}, ValueError, "heading"),
        ({"pose": [1e9, 0.0, 0.0]}, ValueError, "off the painted floor"),
    ],
)
def test_bad_reset_options_are_refused(options, error, match):
    # NaN or far-away poses used to hang the camera renderer.
    env = LfDTrackEnv(track="training")
    with pytest.raises(error, match=match):
        env.reset(seed=0, options=options)


def test_a_start_pose_on_the_floor_is_used():
    env = LfDTrackEnv(track="training")
    _, info = env.reset(seed=0, options={"pose": (1.5, 0.0, 0.0)})
    assert info["pose"][:2] == pytest.approx((1.5, 0.0), abs=1e-6)


def test_step_after_the_episode_ended_raises():
    env = gym.make("LfDTrack-v0", track="training", max_steps=1).unwrapped
    env.reset(seed=0)
    _, _, terminated, truncated, _ = env.step(0)
    assert truncated and not terminated
    with pytest.raises(RuntimeError, match="episode has ended"):
        env.step(0)
    env.reset(seed=1)
    env.step(0)  # a new episode steps again

    going_on = LfDTrackEnv(track="training", max_steps=1, continue_after_end=True)
    going_on.reset(seed=0)
    going_on.step(0)
    going_on.step(0)  # a demonstration protocol drives on past the end
    with pytest.raises(TypeError, match="continue_after_end"):
        LfDTrackEnv(continue_after_end="yes")
