"""Many ``LfDTrack-v0`` worlds stepped at once by several processes, frames in shared memory.

``ThreadedVectorEnv`` keeps every world in one process; the Python glue of a step (episode
rules, the physics wrappers) holds Python's lock, so two threads never quite use two cores. Here
the worlds are split into contiguous blocks, one per process: the calling process steps the
first block itself and a child process each of the others, one world after the other. Each
frame is copied once, by the process that rendered it, into one batch of shared memory that
``step`` returns, so nothing bigger than an action, a reward and an info dict crosses a pipe.
Several worlds per process average out a slow step (a reset) in any one of them.

``gym.make_vec("LfDTrack-v0", num_envs=N, workers=W)`` makes one (``make_vector_env``). The
semantics are ``SyncVectorEnv``'s, autoreset modes and ``reset_mask`` included, and so are the
results, env by env and step by step: each world lives in one worker and draws only from its own
random generators. Each child process runs OpenCV on one thread (the processes are the
parallelism); the calling process keeps its own setting, so call ``cv2.setNumThreads(1)``
there too.

Workers start by ``"forkserver"`` (``"spawn"`` where there is none) unless ``context`` names
another ``multiprocessing`` start method: a plain fork of a process that has used OpenCV's
threads can hang the child. The ``env_fns`` must therefore be picklable (the ones
``make_vector_env`` builds are), and a script that makes the vector env at its top level needs
the usual ``if __name__ == "__main__":`` guard.
"""

from __future__ import annotations

import multiprocessing as mp
import os
import time
import traceback
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space, iterate

from .batching import batch, expand_seeds, gather_step, step_env, step_return


def _default_context() -> str:
    """``"forkserver"`` where the platform has it, else ``"spawn"``: never a plain fork.

    A forked child inherits OpenCV's thread pool without its threads, and the first OpenCV call
    that touches the pool (``cv2.setNumThreads`` included) then waits for them forever.
    """
    return "forkserver" if "forkserver" in mp.get_all_start_methods() else "spawn"


def _blocks(num_envs: int, workers: int) -> list[range]:
    """Contiguous, near-equal blocks of env indices, one per worker."""
    bounds = np.linspace(0, num_envs, workers + 1).round().astype(int)
    return [range(int(a), int(b)) for a, b in zip(bounds[:-1], bounds[1:], strict=True)]


def check_reset_mask(mask: Any, num_envs: int) -> np.ndarray:
    """``options["reset_mask"]`` as ``SyncVectorEnv`` accepts it, or its error."""
    if not isinstance(mask, np.ndarray):
        raise TypeError(f"`options['reset_mask']` must be a numpy array, got {type(mask)}")
    if mask.shape != (num_envs,):
        raise ValueError(
            f"`options['reset_mask']` must have shape `({num_envs},)`, got {mask.shape}"
        )
    if mask.dtype != np.bool_:
        raise TypeError(f"`options['reset_mask']` must have `dtype=np.bool_`, got {mask.dtype}")
    if not mask.any():
        raise ValueError(
            "`options['reset_mask']` must contain a boolean array with at least one True value,"
            f" got reset_mask={mask}"
        )
    return mask


class _Block:
    """A contiguous block of sub-envs, ``first, first + 1, …``, rendering into ``frames``."""

    def __init__(
        self,
        envs: Sequence[gym.Env],
        first: int,
        frames: np.ndarray,
        mode: AutoresetMode,
    ) -> None:
        self.envs = list(envs)
        self.first, self.mode = first, mode
        self.frames = frames[first : first + len(self.envs)]
        shape = self.envs[0].observation_space.shape
        if any(env.observation_space != self.envs[0].observation_space for env in self.envs):
            raise RuntimeError("the sub-envs' observation spaces differ")
        if self.frames.shape[1:] != shape:
            raise RuntimeError(f"env {first}'s frames are {shape}, the batch's {frames.shape[1:]}")
        self.pending = [False] * len(self.envs)  # episode ended: reset on the next step

    def step(self, actions: Sequence[Any]) -> list[list[Any]]:
        out = []
        for k, env in enumerate(self.envs):
            obs, *rest = step_env(env, self.pending[k], actions[k], self.mode)
            self.frames[k] = obs
            self.pending[k] = bool(rest[1] or rest[2])
            out.append(rest)
        return out

    def reset(
        self, seeds: Sequence[int | None], options: dict[str, Any] | None, mask: Any
    ) -> list[dict[str, Any] | None]:
        infos: list[dict[str, Any] | None] = []
        for k, env in enumerate(self.envs):
            if mask is None or mask[k]:
                self.frames[k], info = env.reset(seed=seeds[k], options=options)
                self.pending[k] = False
                infos.append(info)
            else:
                infos.append(None)
        return infos

    def call(self, name: str, args: tuple, kwargs: dict[str, Any]) -> list[Any]:
        results = []
        for env in self.envs:
            attr = env.get_wrapper_attr(name)
            results.append(attr(*args, **kwargs) if callable(attr) else attr)
        return results

    def set_attr(self, name: str, values: Sequence[Any]) -> None:
        for env, value in zip(self.envs, values, strict=True):
            env.set_wrapper_attr(name, value)

    def close(self) -> None:
        for env in self.envs:
            env.close()


class _Waiter:
    """Wait for a message on a connection: poll first, for at most ``spin_s``, then block.

    In lockstep each side waits for the other every step; on a virtual machine a core that
    sleeps costs a good part of a millisecond to wake. While answers come within the budget,
    polling keeps the core awake. When they do not (the other side is slow, or the machine is
    busy and it is not running), the poll only burns time another process could use, so each
    wait that outlasts the budget halves it and each that ends within it doubles it back, up to
    ``spin_s``.
    """

    def __init__(self, spin_s: float) -> None:
        self.limit = float(spin_s)
        self.budget = self.limit

    def wait(self, conn: Any) -> None:
        if self.limit <= 0.0:
            return
        deadline = time.perf_counter() + self.budget
        while not conn.poll(0):
            if time.perf_counter() >= deadline:
                self.budget = max(self.budget / 2, self.limit / 64)
                return
        self.budget = min(self.budget * 2, self.limit)


def _report(conn: Any, exc: BaseException) -> None:
    """Send ``exc`` and its traceback to the parent (as a ``RuntimeError`` if it cannot be
    pickled)."""
    trace = traceback.format_exc()
    try:
        conn.send(("error", (exc, trace)))
    except Exception:  # noqa: BLE001 - an exception that does not pickle
        conn.send(("error", (RuntimeError(f"{type(exc).__name__}: {exc}"), trace)))


def _worker(
    env_fns: Sequence[Callable[[], gym.Env]],
    first: int,
    buffer: Any,
    batch_shape: tuple[int, ...],
    dtype: str,
    mode: AutoresetMode,
    spin_s: float,
    conn: Any,
) -> None:
    """Own one block of envs; answer the parent's commands until ``close``."""
    import cv2

    cv2.setNumThreads(1)
    waiter = _Waiter(spin_s)
    try:
        frames = np.frombuffer(buffer, dtype=dtype).reshape(batch_shape)
        block = _Block([fn() for fn in env_fns], first, frames, mode)
        conn.send(("ok", None))
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises it
        _report(conn, exc)
        return
    while True:
        try:
            waiter.wait(conn)
            command, data = conn.recv()
        except (EOFError, KeyboardInterrupt):
            break
        if command == "close":
            break
        try:
            conn.send(("ok", getattr(block, command)(*data)))
        except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises it
            _report(conn, exc)
    block.close()
    conn.close()


class ProcessVectorEnv(VectorEnv):
    """A vector env whose sub-envs are stepped by ``workers`` processes, frames in shared memory.

    The envs are split into ``workers`` contiguous blocks; the calling process steps the first
    block itself while ``workers - 1`` child processes step the others, so that no process sleeps
    while the others work. ``workers`` defaults to ``min(len(env_fns), os.cpu_count())``;
    ``context`` is a ``multiprocessing`` start method (default ``"forkserver"``, else
    ``"spawn"``); ``spin_s`` is the longest a waiting side polls before it blocks (``_Waiter``).
    ``copy`` and ``autoreset_mode`` are ``SyncVectorEnv``'s; with ``copy=False`` ``step`` and
    ``reset`` return the shared batch itself, rewritten in place by the next call. The sub-envs
    need a ``Box`` observation space.
    """

    def __init__(
        self,
        env_fns: Sequence[Callable[[], gym.Env]],
        workers: int | None = None,
        copy: bool = True,
        autoreset_mode: str | AutoresetMode = AutoresetMode.NEXT_STEP,
        context: str | None = None,
        spin_s: float = 0.002,
    ) -> None:
        super().__init__()
        if not env_fns:
            raise ValueError("ProcessVectorEnv needs at least one env")
        if workers is None:
            workers = min(len(env_fns), os.cpu_count() or 1)
        if isinstance(workers, bool) or not isinstance(workers, (int, np.integer)) or workers < 1:
            raise ValueError(f"workers must be a positive integer or None, got {workers!r}")
        if not 0.0 <= float(spin_s) <= 1.0:
            raise ValueError(f"spin_s must be between 0 and 1 s, got {spin_s!r}")
        self.num_envs = len(env_fns)
        self.workers = min(int(workers), self.num_envs)
        self.copy = copy
        self.autoreset_mode = AutoresetMode(autoreset_mode)
        self.spin_s = float(spin_s)
        self._blocks = _blocks(self.num_envs, self.workers)
        self._conns: list[Any] = []
        self._processes: list[Any] = []
        self._local: _Block | None = None
        self._waiters = [_Waiter(self.spin_s) for _ in self._blocks[1:]]

        # The first env (constructing one builds no world; that happens at its first reset)
        # tells the spaces, so the batch is sized before any worker starts.
        ctx = mp.get_context(context or _default_context())
        first_block = [fn() for fn in env_fns[: len(self._blocks[0])]]
        space = first_block[0].observation_space
        if not isinstance(space, gym.spaces.Box):
            for env in first_block:
                env.close()
            raise TypeError("ProcessVectorEnv needs a Box observation space (one batched array)")
        batch_shape = (self.num_envs, *space.shape)
        dtype = np.dtype(space.dtype)
        self._buffer = ctx.RawArray("B", int(np.prod(batch_shape)) * dtype.itemsize)
        self._observations = np.frombuffer(self._buffer, dtype=dtype).reshape(batch_shape)
        if len(self._blocks) > 1 and ctx.get_start_method() == "forkserver":
            # Workers then fork from a server that has imported the package but never run it.
            ctx.set_forkserver_preload(["lfd_track.envs.process_vector"])
        try:
            for block in self._blocks[1:]:
                parent, child = ctx.Pipe()
                fns = [env_fns[i] for i in block]
                args = (fns, block.start, self._buffer, batch_shape, dtype.str)
                # typeshed types get_context(name) as BaseContext, which lacks the Process that
                # every concrete context (fork, spawn, forkserver) has.
                process = ctx.Process(  # type: ignore[attr-defined]
                    target=_worker,
                    args=(*args, self.autoreset_mode, self.spin_s, child),
                    daemon=True,
                    name=f"lfd-env-{block.start}",
                )
                process.start()
                child.close()
                self._conns.append(parent)
                self._processes.append(process)
            self._local = _Block(first_block, 0, self._observations, self.autoreset_mode)
            self._gather()
        except BaseException:
            if self._local is None:
                for env in first_block:
                    env.close()
            self.close_extras(terminate=True)
            raise
        first = first_block[0]
        self.single_observation_space = space
        self.observation_space = batch_space(space, self.num_envs)
        self.single_action_space = first.action_space
        self.action_space = batch_space(first.action_space, self.num_envs)
        self.metadata = dict(first.metadata)
        self.metadata["autoreset_mode"] = self.autoreset_mode
        self.render_mode = first.render_mode
        self._rewards = np.zeros(self.num_envs, dtype=np.float64)
        self._terminations = np.zeros(self.num_envs, dtype=np.bool_)
        self._truncations = np.zeros(self.num_envs, dtype=np.bool_)

    # ------------------------------------------------------------------------------------
    def _gather(self) -> list[Any]:
        """Each worker's answer to the last command, in worker order; a worker's error raised."""
        answers, error = [], None
        for w, conn in enumerate(self._conns, start=1):
            try:
                self._waiters[w - 1].wait(conn)
                status, payload = conn.recv()
            except (EOFError, ConnectionError, OSError):
                status, payload = "error", (RuntimeError(f"env worker {w} died"), "")
            if status == "error" and error is None:
                error = payload
            answers.append(payload)
        if error is not None:
            exc, trace = error
            if trace:
                exc.add_note(f"in the env worker:\n{trace}")
            raise exc
        return answers

    def _run(self, command: str, per_block: Sequence[tuple]) -> list[Any]:
        """``command`` on every block, the workers' while this process does its own."""
        if self.closed or self._local is None:
            raise RuntimeError("the vector env is closed")
        for w, (conn, data) in enumerate(zip(self._conns, per_block[1:], strict=True), start=1):
            try:
                conn.send((command, data))
            except (BrokenPipeError, ConnectionError, OSError) as exc:
                raise RuntimeError(f"env worker {w} died") from exc
        try:
            mine = getattr(self._local, command)(*per_block[0])
        except BaseException:
            self._gather()  # keep the workers in step with this process
            raise
        return [mine, *self._gather()]

    def step(
        self, actions: Any
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Step every sub-env (each process its block); the batch as ``SyncVectorEnv`` returns."""
        per_env = list(iterate(self.action_space, actions))
        if len(per_env) != self.num_envs:
            raise ValueError(f"expected {self.num_envs} actions, got {len(per_env)}")
        answers = self._run("step", [([per_env[i] for i in b],) for b in self._blocks])
        infos = gather_step(
            self,
            (
                pair
                for block, results in zip(self._blocks, answers, strict=True)
                for pair in zip(block, results, strict=True)
            ),
        )
        return step_return(self, infos)

    def reset(
        self,
        *,
        seed: int | list[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Reset the sub-envs (all, or those in ``options["reset_mask"]``) as ``SyncVectorEnv``."""
        seeds = expand_seeds(seed, self.num_envs)
        mask = None
        if options is not None and "reset_mask" in options:
            options = dict(options)
            mask = check_reset_mask(options.pop("reset_mask"), self.num_envs)
        answers = self._run(
            "reset",
            [
                ([seeds[i] for i in b], options, None if mask is None else mask[b.start : b.stop])
                for b in self._blocks
            ],
        )
        infos: dict[str, Any] = {}
        for block, block_infos in zip(self._blocks, answers, strict=True):
            for i, info in zip(block, block_infos, strict=True):
                if info is not None:
                    infos = self._add_info(infos, info, i)
        reset = np.ones(self.num_envs, dtype=np.bool_) if mask is None else mask
        self._terminations[reset] = False
        self._truncations[reset] = False
        return batch(self), infos

    def call(self, name: str, *args: Any, **kwargs: Any) -> tuple[Any, ...]:
        """Call method ``name`` (or read attribute ``name``) of every sub-env, in env order."""
        answers = self._run("call", [(name, args, kwargs)] * len(self._blocks))
        return tuple(value for block in answers for value in block)

    def get_attr(self, name: str) -> tuple[Any, ...]:
        """Attribute ``name`` of every sub-env, in env order."""
        return self.call(name)

    def set_attr(self, name: str, values: list[Any] | tuple[Any, ...] | Any) -> None:
        """Set attribute ``name`` of every sub-env: one value for all, or one per env."""
        if not isinstance(values, (list, tuple)):
            values = [values] * self.num_envs
        if len(values) != self.num_envs:
            raise ValueError(
                f"values has {len(values)} items: one value or one per env ({self.num_envs})"
            )
        self._run("set_attr", [(name, [values[i] for i in b]) for b in self._blocks])

    def render(self) -> tuple[Any, ...] | None:
        """Every sub-env's ``render()``, in env order."""
        return self.call("render")

    def close_extras(self, terminate: bool = False, **kwargs: Any) -> None:
        """Close the envs and stop the workers (``terminate=True``: stop them without asking)."""
        for conn in self._conns:
            if not terminate:
                try:
                    conn.send(("close", None))
                except (BrokenPipeError, OSError):
                    pass
        for process in self._processes:
            process.join(timeout=0.1 if terminate else 30)
            if process.is_alive():
                process.terminate()
                process.join()
        for conn in self._conns:
            conn.close()
        self._conns, self._processes = [], []
        if self._local is not None:
            self._local.close()
            self._local = None
