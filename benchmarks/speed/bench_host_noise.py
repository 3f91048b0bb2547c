"""How much of a decision's slowest frame is the machine's: a fixed piece of work timed like one.

``bench_budget.py`` asks whether every frame's decision takes at most 5 ms of the process's CPU
time on one core. A decision's cost varies from frame to frame (the map, the registration's
iterations), but so does the machine: on a shared machine the same instructions take longer when
other processes, or other tenants of the host, compete for the core, its caches and the memory.
This benchmark separates the two. It times the very same work again and again — the road
library's region histograms of one fixed frame of the testing track (``GridHistogrammer``, the
largest part of a decision), repeated until one sample takes about ``--target-ms`` — with the
clock ``bench_budget.py`` uses (``time.process_time_ns``). Every sample is the same work, so
their spread is the machine's alone: the ratio of the slowest sample to the median is the factor
by which the machine alone can stretch a frame.

``--busy N`` starts N processes that only spin (the hostile load of the budget runs, without a
study's own variation), ``--cpu K`` pins this process to core K (``os.sched_setaffinity``: "one
core" taken literally); ``--runs`` repeats the whole timing (as the budget's rule asks three
runs), each run's spread reported.

Run: ``.venv/bin/python benchmarks/speed/bench_host_noise.py [--target-ms 2.7 | --repeats N]
[--samples 1500] [--runs 3] [--busy 2] [--cpu K] --out FILE`` — e.g. ``--repeats 3 --busy 2
--out benchmarks/speed/results/host_noise_busy2.json``.
"""

from __future__ import annotations

import argparse
import multiprocessing
import os
import time
from pathlib import Path
from typing import Any

import numpy as np
from bench_budget import percentiles
from single_thread import load_average, pin_core, pin_one_thread, run_facts, write_results

from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.vision.histograms import GridHistogrammer

BINS = 32  # the road library's bins per channel


def spin(stop: Any, cores: set[int]) -> None:
    """A busy process free to run on ``cores`` (not the measuring process's pinned one alone):
    spins until ``stop`` is set."""
    os.sched_setaffinity(0, cores)
    while not stop.is_set():
        pass


def fixed_frame(preset: str) -> np.ndarray:
    """The first frame of the testing track in ``preset`` (reset with seed 0)."""
    env = LfDTrackEnv(track="testing", preset=preset)
    frame, _ = env.reset(seed=0)
    env.close()
    return np.ascontiguousarray(frame)


def repeats_for(grid: GridHistogrammer, frame: np.ndarray, target_ms: float) -> int:
    """Repetitions of the histograms that take about ``target_ms`` of CPU time (measured once,
    so every run times the same work)."""
    t0 = time.process_time_ns()
    for _ in range(100):
        grid.histograms(frame)
    each_ms = (time.process_time_ns() - t0) / 1e6 / 100
    return max(1, round(target_ms / each_ms))


def samples_ms(
    grid: GridHistogrammer, frame: np.ndarray, repeats: int, samples: int
) -> list[float]:
    """Each sample's CPU milliseconds: ``repeats`` times the histograms of ``frame``."""
    out = []
    for _ in range(samples):
        t0 = time.process_time_ns()
        for _ in range(repeats):
            grid.histograms(frame)
        out.append((time.process_time_ns() - t0) / 1e6)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", default="paper_fast", help="the frame's world (paper_fast)")
    parser.add_argument("--target-ms", type=float, default=2.7, help="CPU ms per sample (2.7)")
    parser.add_argument("--samples", type=int, default=1500, help="samples timed (1500)")
    parser.add_argument(
        "--repeats", type=int, default=None, help="histograms per sample (default: --target-ms)"
    )
    parser.add_argument("--runs", type=int, default=3, help="whole timings made (3)")
    parser.add_argument("--busy", type=int, default=0, help="busy processes beside it (0)")
    parser.add_argument("--cpu", type=int, default=None, help="pin this process to core K")
    parser.add_argument("--out", type=Path, required=True, help="the JSON written")
    args = parser.parse_args()
    if args.samples < 20 or not 0.1 <= args.target_ms <= 100 or not 0 <= args.busy <= 8:
        parser.error("--samples >= 20, --target-ms in 0.1..100 and --busy in 0..8")
    if not 1 <= args.runs <= 20 or (args.repeats is not None and not 1 <= args.repeats <= 100):
        parser.error("--runs must be in 1..20 and --repeats in 1..100")
    cores = os.sched_getaffinity(0)  # the busy processes' cores, whatever this one is pinned to
    try:
        pin_core(args.cpu)
    except ValueError as error:
        parser.error(f"--cpu: {error}")
    pin_one_thread()
    frame = fixed_frame(args.preset)
    grid = GridHistogrammer(BINS, threads=1)
    for _ in range(20):  # first-call allocations
        grid.histograms(frame)
    # The same work in every condition compared: --repeats fixes it (a measured count follows
    # the machine's speed at that moment).
    repeats = args.repeats or repeats_for(grid, frame, args.target_ms)
    stop = multiprocessing.Event()
    busy = [multiprocessing.Process(target=spin, args=(stop, cores)) for _ in range(args.busy)]
    for process in busy:
        process.start()
    before = load_average()
    runs: list[dict[str, Any]] = []
    try:
        for _ in range(args.runs):
            spread = percentiles(samples_ms(grid, frame, repeats, args.samples))
            runs.append(
                {
                    "cpu_ms": spread,
                    "max_over_median": round(spread["max_ms"] / spread["median_ms"], 2),
                }
            )
    finally:
        stop.set()
        for process in busy:
            process.join()
    where = "unpinned" if args.cpu is None else f"pinned to core {args.cpu}"
    print(
        f"fixed work ({repeats} x the region histograms of one {frame.shape[1]} x"
        f" {frame.shape[0]} frame), {args.samples} samples per run, {where},"
        f" {args.busy} busy processes"
    )
    for i, run in enumerate(runs, 1):
        spread = run["cpu_ms"]
        print(
            f"run {i}: CPU ms median / p95 / p99 / max:"
            f" {spread['median_ms']:.2f} / {spread['p95_ms']:.2f} / {spread['p99_ms']:.2f} /"
            f" {spread['max_ms']:.2f}; max / median {run['max_over_median']}"
        )
    result = {
        "benchmark": "host_noise",
        "work": f"{repeats} x GridHistogrammer({BINS}).histograms of the first frame of the"
        f" testing track in {args.preset} per sample",
        "samples_per_run": args.samples,
        "busy_processes": args.busy,
        "cpu": args.cpu,
        "runs": runs,
        **run_facts(before),
    }
    write_results(args.out, result, before)


if __name__ == "__main__":
    main()
