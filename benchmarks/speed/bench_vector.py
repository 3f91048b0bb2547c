"""Many envs at once on the machine's cores: steps/s of N envs against one env on one thread.

Workloads, in interleaved rounds of ``--seconds`` each, random actions, resets included (a
vector env restarts its episodes itself):

* ``one_env`` — one ``LfDTrack-v0`` stepped in this process (the reference: 1.0);
* ``two_processes`` — two independent processes, each stepping its own env with no vector env
  between them, started together: what the cores give with no coordination at all, so the ceiling
  of any vector env on this machine (it measures how much one env's step slows when another runs
  beside it: both read their ground textures through the shared cache and memory);
* ``async_2`` — Gymnasium's ``AsyncVectorEnv`` of 2 (``make_vec(..., vectorization_mode="async",
  vector_kwargs={"copy": False})``: a process per env, frames through shared memory);
* ``threaded_N`` — ``lfd_track.envs.vector.ThreadedVectorEnv`` (``make_vec``'s default) of N
  envs on a pool of 2 threads, ``copy=False``, for N in ``--threaded``;
* ``processes_N`` — ``lfd_track.envs.process_vector.ProcessVectorEnv`` (``make_vec(...,
  workers=2)``) of N envs in 2 worker processes, frames in shared memory, ``copy=False``, for N
  in ``--processes``.

Steps/s of a vector env count every sub-env's step. Everything runs with OpenCV and BLAS on one
thread per process or worker (``single_thread.pin_one_thread``); the ratio of a workload is the
median of its per-round ratios to ``one_env`` in the same round.

Run: ``.venv/bin/python benchmarks/speed/bench_vector.py [--seconds S] [--rounds R]`` — prints a
table and writes ``benchmarks/speed/results/vector.json``.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import statistics
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from bench_env import random_steps
from single_thread import load_average, pin_one_thread, run_facts

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.utils.atomic import atomic_write_text

RESULTS = Path(__file__).resolve().parent / "results" / "vector.json"


def _process_worker(seed: int, seconds: float, go, conn) -> None:
    """One env in its own process: on each ``go`` it steps for ``seconds`` and reports."""
    pin_one_thread()
    env = gym.make("LfDTrack-v0")
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    random_steps(env, 0.3, rng)  # warm the caches
    conn.send("ready")
    while conn.recv() == "run":
        go.wait()
        t0 = time.perf_counter()
        steps = random_steps(env, seconds, rng)
        conn.send((steps, t0, time.perf_counter()))
    env.close()


class TwoProcesses:
    """Two processes with one env each, released together by one event."""

    def __init__(self, seed: int, seconds: float) -> None:
        ctx = mp.get_context("spawn")
        self.go = ctx.Event()
        self.pipes, self.procs = [], []
        for k in range(2):
            parent, child = ctx.Pipe()
            proc = ctx.Process(
                target=_process_worker, args=(seed + k, seconds, self.go, child), daemon=True
            )
            proc.start()
            self.pipes.append(parent)
            self.procs.append(proc)
        for pipe in self.pipes:
            assert pipe.recv() == "ready"

    def run(self) -> float:
        self.go.clear()
        for pipe in self.pipes:
            pipe.send("run")
        self.go.set()
        results = [pipe.recv() for pipe in self.pipes]
        steps = sum(r[0] for r in results)
        wall = max(r[2] for r in results) - min(r[1] for r in results)
        return steps / wall

    def close(self) -> None:
        for pipe in self.pipes:
            pipe.send("stop")
        for proc in self.procs:
            proc.join(timeout=10)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=3.0, help="per workload per round")
    parser.add_argument("--rounds", type=int, default=5, help="counted rounds (after a warm-up)")
    parser.add_argument("--threaded", type=int, nargs="+", default=[2, 4], help="N envs")
    parser.add_argument("--processes", type=int, nargs="+", default=[2, 4, 8], help="N envs")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    pin_one_thread()
    load_before = load_average()
    rng = np.random.default_rng(args.seed)

    single = gym.make("LfDTrack-v0")
    single.reset(seed=args.seed)
    vectors = {
        "async_2": gym.make_vec(
            "LfDTrack-v0", num_envs=2, vectorization_mode="async", vector_kwargs={"copy": False}
        )
    }
    for n in args.threaded:
        vectors[f"threaded_{n}"] = gym.make_vec("LfDTrack-v0", num_envs=n, threads=2, copy=False)
    for n in args.processes:
        vectors[f"processes_{n}"] = gym.make_vec("LfDTrack-v0", num_envs=n, workers=2, copy=False)
    for vec in vectors.values():
        vec.reset(seed=args.seed)
    pair = TwoProcesses(args.seed, args.seconds)

    def run_vec(vec) -> float:
        n, steps, t0 = vec.num_envs, 0, time.perf_counter()
        while time.perf_counter() - t0 < args.seconds:
            vec.step(rng.integers(3, size=n))
            steps += n
        return steps / (time.perf_counter() - t0)

    workloads = {
        "one_env": lambda: random_steps(single, args.seconds, rng) / args.seconds,
        "two_processes": pair.run,
        **{name: (lambda v=vec: run_vec(v)) for name, vec in vectors.items()},
    }
    names = list(workloads)
    rows = []
    try:
        for r in range(args.rounds + 1):
            order = names if r % 2 == 0 else names[::-1]
            rates = {name: workloads[name]() for name in order}
            if r == 0:
                continue  # warm-up
            row = {"steps_per_s": rates, "load_average": load_average()}
            rows.append(row)
            print(
                f"round {r}: "
                + ", ".join(f"{k} {rates[k]:.0f}" for k in names)
                + f", load {row['load_average'][0]}",
                flush=True,
            )
    finally:
        pair.close()
        single.close()
        for vec in vectors.values():
            vec.close()

    summary = {
        name: {
            "steps_per_s": statistics.median(row["steps_per_s"][name] for row in rows),
            "vs_one_env": statistics.median(
                row["steps_per_s"][name] / row["steps_per_s"]["one_env"] for row in rows
            ),
            "vs_one_env_rounds": [
                round(row["steps_per_s"][name] / row["steps_per_s"]["one_env"], 3) for row in rows
            ],
        }
        for name in names
    }
    for name in names:
        s = summary[name]
        print(f"{name:15s} {s['steps_per_s']:7.0f} steps/s  {s['vs_one_env']:.2f}x one env")
    result = {
        "benchmark": "vector",
        "seconds_per_slot": args.seconds,
        "rounds": rows,
        "summary": summary,
        **run_facts(load_before),
    }
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
