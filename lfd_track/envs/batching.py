"""What the vector envs of ``lfd_track.envs`` share: one sub-env's step in a given autoreset
mode, ``SyncVectorEnv``'s seed expansion, the batch's rewards, flags and infos from per-env
results, and the batch a step or reset returns (``vector.ThreadedVectorEnv`` and ``process_vector.ProcessVectorEnv``)."""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from copy import deepcopy
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode

Result = tuple[np.ndarray, float, bool, bool, dict[str, Any], dict[str, Any] | None]


def step_env(env: gym.Env, pending_reset: bool, action: Any, mode: AutoresetMode) -> Result:
    """One sub-env's share of ``SyncVectorEnv.step`` in autoreset ``mode``.

    ``pending_reset`` says the env's episode ended on the previous step. Returns the frame,
    reward, flags, info and, in the SAME_STEP mode when an episode ends, the ``final_obs`` /
    ``final_info`` pair that the batch's infos carry.
    """
    final = None
    if mode == AutoresetMode.NEXT_STEP and pending_reset:
        obs, info = env.reset()
        reward, terminated, truncated = 0.0, False, False
    else:
        if mode == AutoresetMode.DISABLED:
            assert not pending_reset, "autoreset is disabled: reset the env before stepping it"
        obs, step_reward, terminated, truncated, info = env.step(action)
        reward = float(step_reward)
        if mode == AutoresetMode.SAME_STEP and (terminated or truncated):
            final = {"final_obs": obs, "final_info": info}
            obs, info = env.reset()
    return obs, reward, terminated, truncated, info, final


def expand_seeds(seed: int | Sequence[int | None] | None, num_envs: int) -> list[int | None]:
    """``SyncVectorEnv.reset``'s seeds: None for all, ``seed + i``, or a list of ``num_envs``."""
    if seed is None:
        seeds: list[int | None] = [None] * num_envs
    elif isinstance(seed, bool):
        raise TypeError(f"seed must be an integer or a list of seeds, got {seed!r}")
    elif isinstance(seed, (int, np.integer)):
        seeds = [int(seed) + i for i in range(num_envs)]
    else:
        seeds = list(seed)
    if len(seeds) != num_envs:
        raise ValueError(
            "If seeds are passed as a list the length must match"
            f" num_envs={num_envs} but got length={len(seeds)}."
        )
    return seeds


def gather_step(vec: Any, results: Iterable[tuple[int, tuple]]) -> dict[str, Any]:
    """Write sub-env ``i``'s (reward, terminated, truncated, info, final) into ``vec``'s reward
    and flag arrays for each ``(i, result)``; return the batch's infos as ``SyncVectorEnv`` builds
    them (a SAME_STEP ``final`` pair before the env's own info)."""
    infos: dict[str, Any] = {}
    for i, (reward, terminated, truncated, info, final) in results:
        vec._rewards[i] = reward
        vec._terminations[i] = terminated
        vec._truncations[i] = truncated
        if final is not None:
            infos = vec._add_info(infos, final, i)
        infos = vec._add_info(infos, info, i)
    return infos


def batch(vec: Any) -> np.ndarray:
    """``vec``'s frames as ``step`` and ``reset`` return them: a copy unless ``vec.copy`` is off."""
    return deepcopy(vec._observations) if vec.copy else vec._observations


def step_return(
    vec: Any, infos: dict[str, Any]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """What ``SyncVectorEnv.step`` returns, from ``vec``'s batch, rewards and flags."""
    return (
        batch(vec),
        np.copy(vec._rewards),
        np.copy(vec._terminations),
        np.copy(vec._truncations),
        infos,
    )
