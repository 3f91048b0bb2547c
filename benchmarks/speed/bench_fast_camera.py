"""Steps per second of the half-size camera (preset ``paper_fast``) against the full one and
CarRacing-v3, on one thread in one process.

Five workloads, stepped as in ``bench_env.py`` (each with its own policy, reset whenever an episode
ends), interleaved in rounds so load from other processes falls on all of them alike; the first
round is a warm-up and is not counted; ratios are medians of per-round ratios:

* ``lfdtrack``          — ``gym.make("LfDTrack-v0")``: physics + 640 x 480 render, random actions;
* ``lfdtrack_fast``     — the same with ``preset="paper_fast"`` (320 x 240 frames of the same view);
* ``carracing``         — ``gym.make("CarRacing-v3")``, actions sampled from its action space;
* ``closed_loop``       — ``lfdtrack`` driven by road values (a full 10 x 10 library) and the
  40-5-3 MLP with random weights, as in ``bench_env.py``;
* ``closed_loop_fast``  — the same on ``lfdtrack_fast``'s frames (the same library).

Targets: closed_loop_fast / closed_loop >= 3 and lfdtrack_fast / carracing >= 5. OpenCV and the
BLAS are pinned to one thread. The load average before and after is recorded: on a machine
shared with other jobs the ratios hold better than the rates.

Run: ``.venv/bin/python benchmarks/speed/bench_fast_camera.py [--seconds 2] [--rounds 5]
[--output FILE]`` — prints a table and writes ``benchmarks/speed/results/fast_camera.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
from bench_env import (
    ClosedLoop,
    RandomCarRacing,
    RandomLfDTrack,
    Sample,
    Workload,
    full_library,
    run_for,
    summarise,
    versions,
)
from single_thread import load_average, pin_one_thread, source_state

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.road_library import RoadLibrary

RESULTS = Path(__file__).resolve().parent / "results" / "fast_camera.json"
TARGET_LOOP_RATIO = 3.0
TARGET_ENV_RATIO = 5.0


class FastLfDTrack(RandomLfDTrack):
    name = "lfdtrack_fast"

    def __init__(self, seed: int) -> None:
        self.env = gym.make("LfDTrack-v0", preset="paper_fast")
        self.env.reset(seed=seed)
        self.rng = np.random.default_rng(seed)


class FastClosedLoop(ClosedLoop):
    name = "closed_loop_fast"

    def __init__(self, seed: int, library: RoadLibrary) -> None:
        self.env = gym.make("LfDTrack-v0", preset="paper_fast")
        self.library = library
        self.rng = np.random.default_rng(seed)
        self.frame, _ = self.env.reset(seed=seed)
        self._new_controller()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="wall time per slot [s]")
    parser.add_argument("--rounds", type=int, default=5, help="counted rounds (after a warm-up)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.rounds < 1:
        parser.error("--seconds must be > 0 and --rounds >= 1")

    pin_one_thread()
    load_before = load_average()
    library = full_library(args.seed + 1)
    workloads: list[Workload] = [
        RandomLfDTrack(args.seed),
        FastLfDTrack(args.seed),
        RandomCarRacing(args.seed),
        ClosedLoop(args.seed + 2, library),
        FastClosedLoop(args.seed + 2, library),
    ]
    samples: dict[str, list[Sample]] = {w.name: [] for w in workloads}
    for round_index in range(args.rounds + 1):
        for w in workloads:
            sample = run_for(w, args.seconds)
            if round_index > 0:  # round 0 warms caches, allocators and lazy imports
                samples[w.name].append(sample)
        if round_index > 0:
            rates = "  ".join(f"{n} {s[-1].rate:7.1f}" for n, s in samples.items())
            print(f"round {round_index}/{args.rounds}: {rates} steps/s", file=sys.stderr)
    for w in workloads:
        w.close()
    load_after = load_average()

    def ratio(num: str, den: str) -> float:
        pairs = zip(samples[num], samples[den], strict=True)
        return statistics.median(a.rate / b.rate for a, b in pairs)

    def ratio_range(num: str, den: str) -> list[float]:
        pairs = zip(samples[num], samples[den], strict=True)
        values = [a.rate / b.rate for a, b in pairs]
        return [round(min(values), 3), round(max(values), 3)]

    pairs = {
        "closed_loop_fast_over_closed_loop": ("closed_loop_fast", "closed_loop"),
        "lfdtrack_fast_over_lfdtrack": ("lfdtrack_fast", "lfdtrack"),
        "lfdtrack_fast_over_carracing": ("lfdtrack_fast", "carracing"),
        "closed_loop_fast_over_carracing": ("closed_loop_fast", "carracing"),
        "lfdtrack_over_carracing": ("lfdtrack", "carracing"),
        "closed_loop_over_carracing": ("closed_loop", "carracing"),
    }
    ratios = {name: ratio(*p) for name, p in pairs.items()}
    ranges = {name: ratio_range(*p) for name, p in pairs.items()}
    met = {
        "closed_loop_fast_over_closed_loop": ratios["closed_loop_fast_over_closed_loop"]
        >= TARGET_LOOP_RATIO,
        "lfdtrack_fast_over_carracing": ratios["lfdtrack_fast_over_carracing"] >= TARGET_ENV_RATIO,
    }
    summary = {name: summarise(s) for name, s in samples.items()}

    print(f"{'workload':<17} {'steps/s':>9} {'steps/s':>11} {'steps/':>8}")
    print(f"{'':<17} {'(resets)':>9} {'(step only)':>11} {'cpu s':>8}")
    for name, s in summary.items():
        print(
            f"{name:<17} {s['median_steps_per_s']:>9.1f} {s['median_step_only_steps_per_s']:>11.1f}"
            f" {s['median_steps_per_cpu_s']:>8.1f}"
        )
    for name, value in ratios.items():
        low, high = ranges[name]
        print(f"{name:<36} {value:5.2f}x  (rounds {low:.2f}-{high:.2f}x)")
    for name, ok in met.items():
        print(f"target {name}: {'met' if ok else 'NOT met'}")
    print(f"load average (1, 5, 15 min): before {load_before}, after {load_after}")

    result = {
        "benchmark": "fast_camera_steps_per_second",
        "workloads": {
            "lfdtrack": "gym.make('LfDTrack-v0'), 640x480 RGB frames, random actions",
            "lfdtrack_fast": "gym.make('LfDTrack-v0', preset='paper_fast'), 320x240, random actions",
            "carracing": "gym.make('CarRacing-v3'), 96x96 RGB frames, action_space.sample()",
            "closed_loop": "lfdtrack + road values (10 x 10 library) + 40-5-3 MLP, random weights",
            "closed_loop_fast": "lfdtrack_fast + the same library and MLP",
        },
        "method": (
            "interleaved rounds, median of per-round ratios; OpenCV and BLAS pinned to one thread"
        ),
        "targets": {
            "closed_loop_fast_over_closed_loop": TARGET_LOOP_RATIO,
            "lfdtrack_fast_over_carracing": TARGET_ENV_RATIO,
        },
        "targets_met": met,
        "ratios": ratios,
        "ratio_ranges_over_rounds": ranges,
        "seconds_per_slot": args.seconds,
        "rounds": args.rounds,
        "seed": args.seed,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "machine": versions(),
        "source": source_state(),
        "results": summary,
    }
    atomic_write_text(args.output, json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
