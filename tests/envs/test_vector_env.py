"""The threaded vector env: make_vec's default, with SyncVectorEnv's results step for step."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode, SyncVectorEnv

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.process_vector import ProcessVectorEnv
from lfd_track.envs.vector import EnvFactory, ThreadedVectorEnv, make_vector_env

# A short budget so that episodes end (truncated) and restart inside the vector env.
KWARGS = {"track": "training", "max_steps": 4}


def _roll(vec, actions):
    """Everything a vector env returns over ``actions``, frames as copies."""
    out = [vec.reset(seed=[5, 9, 11])]
    for a in actions:
        obs, rewards, terminated, truncated, infos = vec.step(a)
        out.append((obs.copy(), rewards, terminated, truncated, infos))
    return out


def _same(a, b):
    """Equal batches: arrays exactly (frames, rewards, flags), dicts key by key."""
    if isinstance(a, dict):
        assert sorted(a) == sorted(b)
        for key in a:
            _same(a[key], b[key])
    elif isinstance(a, (tuple, list)):
        assert len(a) == len(b)
        for x, y in zip(a, b, strict=True):
            _same(x, y)
    elif isinstance(a, np.ndarray) and a.dtype == object:
        assert a.shape == b.shape
        for x, y in zip(a.ravel(), b.ravel(), strict=True):
            _same(x, y)
    elif isinstance(a, np.ndarray):
        np.testing.assert_array_equal(a, b)
    else:
        assert a == b


def _threaded(fns, mode):
    return ThreadedVectorEnv(fns, threads=2, autoreset_mode=mode)


def _processes(fns, mode):
    # 3 envs on 2 workers: envs 0-1 stepped by this process, env 2 by a child process.
    vec = ProcessVectorEnv(fns, workers=2, autoreset_mode=mode)
    assert [len(b) for b in vec._blocks] == [2, 1] and len(vec._processes) == 1
    return vec


@pytest.mark.parametrize("make", [_threaded, _processes])
@pytest.mark.parametrize("mode", [AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP])
def test_vector_envs_equal_sync_step_for_step(make, mode):
    actions = np.random.default_rng(0).integers(3, size=(11, 3))
    fns = [EnvFactory(KWARGS)] * 3
    sync = SyncVectorEnv(fns, autoreset_mode=mode)
    vec = make(fns, mode)
    try:
        expected, got = _roll(sync, actions), _roll(vec, actions)
    finally:
        sync.close()
        vec.close()
    _same(got, expected)
    # The rollout crossed episode ends, so autoreset was exercised.
    assert any(step[3].any() for step in got[1:])


def test_make_vec_defaults_to_the_threaded_env():
    vec = gym.make_vec("LfDTrack-v0", num_envs=2, threads=2, **KWARGS)
    try:
        assert isinstance(vec, ThreadedVectorEnv) and vec.threads == 2
        obs, infos = vec.reset(seed=3)
        assert obs.shape == (2, 480, 640, 3) and obs.dtype == np.uint8
        assert not np.array_equal(obs[0], obs[1])  # seeds 3 and 4: two worlds
        assert infos["max_steps"].tolist() == [4, 4]
        obs2, rewards, terminated, truncated, _ = vec.step(np.array([0, 2]))
        assert rewards.shape == (2,) and not np.shares_memory(obs, obs2)
    finally:
        vec.close()
    assert vec.closed and vec._pool._shutdown


def test_copy_false_returns_the_batch_buffer_and_reset_mask_resets_one_env():
    vec = make_vector_env(2, copy=False, **KWARGS)
    try:
        obs, _ = vec.reset(seed=1)
        first = obs[0].copy()
        obs_step, *_ = vec.step(np.array([0, 0]))
        assert obs_step is obs  # the vector env's own buffer, rewritten in place
        obs_reset, infos = vec.reset(
            seed=[1, None], options={"reset_mask": np.array([True, False])}
        )
        np.testing.assert_array_equal(obs_reset[0], first)  # seed 1 again: the same first frame
        assert infos["_step"].tolist() == [True, False]
    finally:
        vec.close()


def test_bad_arguments_are_refused_in_one_line():
    with pytest.raises(ValueError, match="threads must be a positive integer"):
        ThreadedVectorEnv([lambda: gym.make("LfDTrack-v0")], threads=0)
    with pytest.raises(ValueError, match="num_envs must be a positive integer"):
        make_vector_env(0)
    with pytest.raises(ValueError, match="renders only 'rgb_array' or None"):
        make_vector_env(2, render_mode="human")
    vec = make_vector_env(2, **KWARGS)
    try:
        vec.reset(seed=0)
        with pytest.raises(ValueError, match="If seeds are passed as a list"):
            vec.reset(seed=[1, 2, 3])
    finally:
        vec.close()


# --- worker processes, frames in shared memory ------------------------------------------


def test_make_vec_workers_gives_the_process_env_sharing_one_batch():
    vec = gym.make_vec("LfDTrack-v0", num_envs=2, workers=2, copy=False, **KWARGS)
    try:
        assert isinstance(vec, ProcessVectorEnv) and vec.workers == 2
        assert vec.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
        obs, _ = vec.reset(seed=1)
        first = obs[1].copy()  # rendered by the child process into the shared batch
        obs_step, rewards, *_ = vec.step(np.array([0, 2]))
        assert obs_step is obs and rewards.shape == (2,)
        assert not np.array_equal(obs_step[1], first)
        obs_reset, infos = vec.reset(
            seed=[None, 2], options={"reset_mask": np.array([False, True])}
        )
        np.testing.assert_array_equal(obs_reset[1], first)  # seed 2 (= 1 + 1) again
        assert infos["_step"].tolist() == [False, True]
        assert vec.get_attr("max_steps") == (4, 4)
        vec.set_attr("max_steps", [3, 5])
        assert vec.call("max_steps") == (3, 5)
        with pytest.raises(ValueError, match="off the painted floor") as caught:
            vec.reset(options={"pose": (99.0, 99.0, 0.0), "reset_mask": np.array([False, True])})
        assert "in the env worker" in "".join(caught.value.__notes__)
        vec.step(np.array([1, 1]))  # the worker answers again after its error
    finally:
        vec.close()
    vec.close()  # closing twice is harmless
    with pytest.raises(RuntimeError, match="closed"):
        vec.step(np.array([0, 0]))


def test_a_dead_worker_is_reported_not_waited_for():
    vec = ProcessVectorEnv([EnvFactory(KWARGS)] * 2, workers=2)
    try:
        vec.reset(seed=0)
        vec._processes[0].kill()
        vec._processes[0].join()
        with pytest.raises(RuntimeError, match="env worker 1 died"):
            vec.step(np.array([0, 0]))
    finally:
        vec.close()


def test_process_env_bad_arguments_are_refused_in_one_line():
    with pytest.raises(ValueError, match="workers must be a positive integer"):
        ProcessVectorEnv([EnvFactory(KWARGS)], workers=0)
    with pytest.raises(ValueError, match="spin_s must be between"):
        ProcessVectorEnv([EnvFactory(KWARGS)], spin_s=-1)
    with pytest.raises(ValueError, match="not both"):
        make_vector_env(2, threads=2, workers=2)
