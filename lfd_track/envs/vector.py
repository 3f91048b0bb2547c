"""Many ``LfDTrack-v0`` worlds stepped at once in one process, on a pool of threads.

Almost all of a step's time is spent inside OpenCV (the texture warp, the camera's image
pipeline) and pymunk, both of which release Python's global interpreter lock, so the worlds of one
process can render side by side on several cores. Unlike Gymnasium's ``AsyncVectorEnv`` nothing
is pickled or copied between processes: each frame is written once, by the thread that rendered
it, into the batch that ``step`` returns.

``gym.make_vec("LfDTrack-v0", num_envs=N)`` makes one (the spec's ``vector_entry_point``, which
``make_vec`` uses when no ``vectorization_mode`` is given; ``threads=`` sets the pool's size,
default ``min(N, os.cpu_count())``); ``workers=W`` splits the worlds over W processes instead
(``lfd_track.envs.process_vector``). Gymnasium's own ``"sync"`` and ``"async"`` modes still
work. The semantics are ``SyncVectorEnv``'s, autoreset modes
included, and the results are the same as its results, env by env and step by step: each world
is stepped by one thread at a time and draws only from its own random generators.

OpenCV may also split one call over its own threads; for the pool to use the cores, set
``cv2.setNumThreads(1)`` (``benchmarks/speed/bench_vector.py`` does).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Sequence
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, SyncVectorEnv
from gymnasium.vector.utils import iterate

from .batching import Result, batch, expand_seeds, gather_step, step_env, step_return


class ThreadedVectorEnv(SyncVectorEnv):
    """``SyncVectorEnv`` whose ``step`` and ``reset`` run the sub-envs on a thread pool.

    ``threads`` is the pool's size (default ``min(len(env_fns), os.cpu_count())``); 1 steps the
    worlds one after the other, exactly like ``SyncVectorEnv``. The other arguments are
    ``SyncVectorEnv``'s.
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        threads: int | None = None,
        copy: bool = True,
        observation_mode: str = "same",
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
    ) -> None:
        if threads is None:
            threads = min(len(env_fns), os.cpu_count() or 1)
        if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)) or threads < 1:
            raise ValueError(f"threads must be a positive integer or None, got {threads!r}")
        super().__init__(
            env_fns, copy=copy, observation_mode=observation_mode, autoreset_mode=autoreset_mode
        )
        if not isinstance(self._observations, np.ndarray):
            raise TypeError("ThreadedVectorEnv needs a Box observation space (one batched array)")
        self.threads = int(threads)
        self._pool = ThreadPoolExecutor(max_workers=self.threads, thread_name_prefix="lfd-env")

    # ------------------------------------------------------------------------------------
    def _step_one(self, i: int, action: Any) -> Result:
        """Step (or autoreset) sub-env ``i``; its frame goes straight into the batch."""
        result = step_env(self.envs[i], bool(self._autoreset_envs[i]), action, self.autoreset_mode)
        self._observations[i] = result[0]
        return result

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-env (in parallel); the batch as ``SyncVectorEnv.step`` returns it."""
        per_env = list(iterate(self.action_space, actions))
        if len(per_env) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions, got {len(per_env)}")
        results = list(self._pool.map(self._step_one, range(self.num_envs), per_env))
        for i, result in enumerate(results):
            # gymnasium builds SyncVectorEnv._env_obs as [None, ...], so mypy infers list[None].
            self._env_obs[i] = result[0]  # type: ignore[call-overload]
        infos = gather_step(self, enumerate(result[1:] for result in results))
        self._autoreset_envs = np.logical_or(self._terminations, self._truncations)
        return step_return(self, infos)

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs (in parallel); seeds and ``reset_mask`` as ``SyncVectorEnv``."""
        if options is not None and "reset_mask" in options:
            # A partial reset is rare (between episodes): the serial implementation does it.
            return super().reset(seed=seed, options=options)
        seeds = expand_seeds(seed, self.num_envs)

        def reset_one(i: int) -> dict[str, Any]:
            obs, info = self.envs[i].reset(seed=seeds[i], options=options)
            self._env_obs[i] = obs
            self._observations[i] = obs
            return info

        results = list(self._pool.map(reset_one, range(self.num_envs)))
        infos: dict[str, Any] = {}
        for i, info in enumerate(results):
            infos = self._add_info(infos, info, i)
        self._terminations = np.zeros((self.num_envs,), dtype=np.bool_)
        self._truncations = np.zeros((self.num_envs,), dtype=np.bool_)
        self._autoreset_envs = np.zeros((self.num_envs,), dtype=np.bool_)
        return batch(self), infos

    def close_extras(self, **kwargs: Any) -> None:
        """Stop the thread pool, then close the sub-envs."""
        pool = getattr(self, "_pool", None)
        if pool is not None:
            pool.shutdown(wait=True)
        super().close_extras(**kwargs)


class EnvFactory:
    """A picklable ``gym.make("LfDTrack-v0", **kwargs)`` with ``wrappers`` applied in order."""

    def __init__(
        self, kwargs: dict[str, Any], wrappers: Sequence[Callable[[gym.Env], gym.Wrapper]] = ()
    ) -> None:
        self.kwargs, self.wrappers = dict(kwargs), tuple(wrappers)

    def __call__(self) -> gym.Env:
        env = gym.make("LfDTrack-v0", **self.kwargs)
        for wrap in self.wrappers:
            env = wrap(env)
        return env


def make_vector_env(
    num_envs: int,
    *,
    threads: int | None = None,
    workers: int | None = None,
    copy: bool = True,
    autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
    wrappers: Sequence[Callable[[gym.Env], gym.Wrapper]] | None = None,
    render_mode: str | None = None,
    **env_kwargs: Any,
) -> gym.vector.VectorEnv:
    """``LfDTrack-v0``'s vector entry point: ``num_envs`` envs made with ``env_kwargs``.

    Called by ``gym.make_vec("LfDTrack-v0", num_envs=N, **kwargs)``. By default the envs live in
    this process, stepped by a pool of ``threads`` (``ThreadedVectorEnv``); ``workers=W`` puts
    them in W worker processes instead, frames in shared memory
    (``lfd_track.envs.process_vector.ProcessVectorEnv``). ``copy`` and ``autoreset_mode`` are the
    vector env's, everything else goes to every ``gym.make("LfDTrack-v0", ...)``. ``wrappers``
    (when called directly; ``make_vec`` refuses wrappers for a vector entry point) wrap each
    sub-env.
    """
    if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
        raise ValueError(f"num_envs must be a positive integer, got {num_envs!r}")
    if render_mode not in (None, "rgb_array"):
        raise ValueError(
            f"a vector of LfDTrack envs renders only 'rgb_array' or None, got {render_mode!r}"
        )
    if threads is not None and workers is not None:
        raise ValueError("give threads (one process) or workers (worker processes), not both")
    env_kwargs.pop("max_episode_steps", None)  # the env sets its own budget (its spec says it)
    make_one = EnvFactory({"render_mode": render_mode, **env_kwargs}, wrappers or ())
    fns = [make_one] * int(num_envs)
    if workers is not None:
        from .process_vector import ProcessVectorEnv

        return ProcessVectorEnv(fns, workers=workers, copy=copy, autoreset_mode=autoreset_mode)
    return ThreadedVectorEnv(fns, threads=threads, copy=copy, autoreset_mode=autoreset_mode)
