"""Stable-Baselines3's own env checker accepts the env and the road-value env.

Stable-Baselines3 needs torch, which the test extra does not install: without it these tests are
reported as skipped.
"""

from __future__ import annotations

import warnings

import gymnasium as gym
import pytest
from lfd_test_support import TEST_DATA

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.envs.wrappers import RoadValueObservation
from lfd_track.policy.controller import Controller

env_checker = pytest.importorskip("stable_baselines3.common.env_checker")

CONTROLLER = TEST_DATA / "schema1_controller.json"


def _check(env: gym.Env) -> list[str]:
    """Run SB3's check_env (warnings on); returns the warnings it gave."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        env_checker.check_env(env, warn=True, skip_render_check=False)
    return [str(w.message) for w in caught]


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_check_env_accepts_the_camera_env(render_mode):
    env = LfDTrackEnv(track="training", render_mode=render_mode)
    assert _check(env) == []


def test_check_env_accepts_the_road_value_env():
    library = Controller.load(CONTROLLER).library
    env = RoadValueObservation(LfDTrackEnv(track="training"), library)
    assert _check(env) == []
