"""``track="random"``: a new procedural loop at every reset, drawn from the env's RNG, without
touching the streams that make a fixed track's world."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.track_env import LfDTrackEnv


def _loop_of(seed: int, track: str = "random") -> tuple[str, np.ndarray]:
    env = LfDTrackEnv(track=track)
    obs, info = env.reset(seed=seed)
    return info["track"], obs


def test_a_new_loop_per_seed_and_the_same_loop_for_the_same_seed() -> None:
    names = {seed: _loop_of(seed)[0] for seed in (0, 1, 2)}
    assert len(set(names.values())) == 3
    assert all(name.startswith("random:train:") for name in names.values())
    name, obs = _loop_of(1)
    assert name == names[1]
    assert obs.tobytes() == _loop_of(1)[1].tobytes()


def test_every_reset_draws_a_loop_and_the_env_follows_it() -> None:
    env = gym.make("LfDTrack-v0", track="random:validation")
    assert env.spec is not None and env.spec.max_episode_steps is None  # the loop's own budget
    _, info = env.reset(seed=4)
    first = info["track"]
    assert first.startswith("random:validation:")
    assert env.unwrapped.track.name == first
    assert info["max_steps"] == env.unwrapped.max_steps
    for _ in range(3):
        _, reward, terminated, truncated, info = env.step(0)
        assert info["track"] == first and not terminated and not truncated
    assert info["progress_m"] > 0.2 and reward > 0
    drawn = {env.reset()[1]["track"] for _ in range(3)}  # seed=None: a new loop each time
    assert len(drawn | {first}) == 4
    assert env.unwrapped.episode.track is env.unwrapped.track
    env.close()


def test_the_random_draw_leaves_the_world_streams_alone() -> None:
    """A random env's world, physics and sensor streams are those of the same loop named."""
    random_env = LfDTrackEnv(track="random:test")
    obs, info = random_env.reset(seed=7)
    fixed_env = LfDTrackEnv(track=info["track"])
    fixed_obs, fixed_info = fixed_env.reset(seed=7)
    assert obs.tobytes() == fixed_obs.tobytes()
    assert fixed_info == info
    for action in (0, 1, 0, 2, 0):
        step_random = random_env.step(action)
        step_fixed = fixed_env.step(action)
        assert step_random[0].tobytes() == step_fixed[0].tobytes()
        assert step_random[1:] == step_fixed[1:]


def test_a_fixed_track_is_untouched_by_random_envs() -> None:
    def run() -> list[bytes]:
        env = LfDTrackEnv(track="testing")
        frames = [env.reset(seed=0)[0].tobytes()]
        frames += [env.step(a)[0].tobytes() for a in (0, 1, 0)]
        frames.append(env.reset()[0].tobytes())
        return frames

    before = run()
    _loop_of(3)
    assert run() == before
    _, info = LfDTrackEnv(track="testing").reset(seed=0)
    assert info["track"] == "testing"
    assert set(info) == {
        "pose",
        "progress_m",
        "lap_fraction",
        "corners_reached",
        "corners_negotiated",
        "on_felt",
        "failure",
        "failed_corner",
        "success",
        "safe_box_on_felt",
        "step",
        "max_steps",
        "track",
    }


def test_one_named_loop_is_a_fixed_track() -> None:
    env = gym.make("LfDTrack-v0", track="random:test:17", reverse=True, start_corner="2")
    names = {env.reset(seed=seed)[1]["track"] for seed in (0, 1)}
    assert names == {"random:test:17"}
    assert env.unwrapped.track.reversed
    assert env.spec is not None and env.spec.max_episode_steps == env.unwrapped.max_steps
    env.close()


def test_max_steps_holds_for_every_loop() -> None:
    env = LfDTrackEnv(track="random", max_steps=5)
    for seed in (0, 1):
        assert env.reset(seed=seed)[1]["max_steps"] == 5


@pytest.mark.parametrize(
    ("kwargs", "match"),
    [
        ({"track": "random", "start_corner": "2"}, "start_corner"),
        ({"track": "random:exam"}, "not a loop name"),
        ({"track": "random:test:x"}, "whole number"),
    ],
)
def test_bad_random_tracks_are_refused(kwargs: dict, match: str) -> None:
    with pytest.raises(ValueError, match=match):
        LfDTrackEnv(**kwargs)
