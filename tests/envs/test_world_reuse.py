"""A reset with the seed of the world already built keeps that world instead of painting the same
floor again: its frames, rewards and infos are those of a fresh env reset with that seed."""

from __future__ import annotations

import hashlib

import pytest

from lfd_track.envs.track_env import LfDTrackEnv


def episode_hash(env: LfDTrackEnv, seed: int | None, steps: int = 12) -> str:
    digest = hashlib.sha256()
    frame, info = env.reset(seed=seed)
    digest.update(frame.tobytes() + repr(info).encode())
    for i in range(steps):
        frame, reward, terminated, truncated, info = env.step(i % 3)
        digest.update(frame.tobytes() + repr((reward, terminated, truncated, info)).encode())
        if terminated or truncated:
            break
    return digest.hexdigest()


@pytest.mark.parametrize("preset", ["paper", "randomized"])
def test_the_same_seed_again_drives_the_same_world(preset):
    reused = LfDTrackEnv(track="testing", preset=preset)
    first = episode_hash(reused, 5)
    ground = reused._ground
    again = episode_hash(reused, 5)
    assert reused._ground is ground  # not painted again
    fresh = episode_hash(LfDTrackEnv(track="testing", preset=preset), 5)
    assert first == again == fresh


def test_another_seed_or_a_seedless_randomized_reset_builds_a_new_world():
    env = LfDTrackEnv(track="testing", preset="randomized")
    episode_hash(env, 5)
    ground = env._ground
    episode_hash(env, 6)
    assert env._ground is not ground
    ground = env._ground
    episode_hash(env, None)  # a randomized preset draws a new room at every reset
    assert env._ground is not ground
