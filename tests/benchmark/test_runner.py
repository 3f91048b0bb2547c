"""The autonomous-trial loop and repetition seeding of the benchmark runner."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, repetition_seeds, run_trial
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.controller import Controller
from lfd_track.vision.road_library import RoadLibrary


def _controller(env: LfDTrackEnv, learn: bool) -> Controller:
    library = RoadLibrary()
    frame, _ = env.reset(seed=0)
    library.learn(frame)
    weights = np.random.default_rng(1).uniform(-1, 1, 215)
    return Controller(library, weights, learn=learn)


def test_frozen_library_does_not_change_during_a_trial():
    env = LfDTrackEnv(track="training", max_steps=15)
    controller = _controller(env, learn=False)
    before = controller.library.n_models
    seen = []
    info, trajectory, steps = run_trial(
        env, controller, seed=3, on_step=lambda f, v, i: seen.append(v.copy())
    )
    assert controller.library.n_models == before
    assert steps == len(seen) == len(trajectory) - 1
    assert all(v.shape == (40,) for v in seen)


def test_keep_learning_grows_the_library():
    env = LfDTrackEnv(track="training", max_steps=15)
    controller = _controller(env, learn=True)
    before = controller.library.n_models
    run_trial(env, controller, seed=3)
    assert controller.library.n_models > before


def test_repetition_seeds_are_stable_and_distinct():
    seeds = repetition_seeds(0, 10)
    assert seeds == repetition_seeds(0, 10)
    assert len(set(seeds)) == 10
    assert repetition_seeds(0, 3) == seeds[:3]  # adding repetitions never changes earlier ones


def test_bad_benchmark_config():
    with pytest.raises(ValueError, match="repetitions"):
        BenchmarkConfig(repetitions=0)
