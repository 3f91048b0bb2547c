"""Env steps per second: ``LfDTrack-v0`` against Gymnasium's ``CarRacing-v3``, in one process.

Three workloads, each stepped with its own policy and reset whenever an episode ends:

* ``lfdtrack``   — ``gym.make("LfDTrack-v0")`` (pymunk physics + 640 x 480 camera render),
  uniformly random actions;
* ``carracing``  — ``gym.make("CarRacing-v3")`` (Box2D physics + 96 x 96 frames), actions sampled
  from its action space;
* ``closed_loop`` — ``LfDTrack-v0`` whose action comes from the paper's pipeline: road values of
  the frame against a full road library (10 types x 10 examples = 100 models) fed to the 40-5-3
  MLP (215 random weights, redrawn each episode so the run is not one fixed behaviour).

The workloads are interleaved in rounds (lfdtrack, carracing, closed_loop, lfdtrack, ...), each
running for ``--seconds`` of wall-clock time per round, so load from other processes falls on all
of them alike; the first round is a warm-up and is not counted. Rates are median over rounds.
Two rates are kept per workload: *with resets* (steps / all time, the throughput a training loop
sees) and *steps only* (reset time excluded). Targets (DESIGN §9): lfdtrack / carracing >= 3 and
closed_loop / carracing >= 1.5.

Run: ``.venv/bin/python benchmarks/bench_env.py [--seconds N] [--rounds R]`` — prints a table and
writes ``benchmarks/results/env.json``.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.atomic import atomic_write_text
from lfd_track.control.mlp import mlp_forward, n_weights, select_action
from lfd_track.presets import load_preset
from lfd_track.render.camera import CameraRenderer
from lfd_track.render.texture import build_ground
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.rover import Rover
from lfd_track.world.track import load_track

REPO = Path(__file__).resolve().parents[1]
RESULTS = REPO / "benchmarks" / "results" / "env.json"
TARGET_ENV_RATIO = 3.0
TARGET_LOOP_RATIO = 1.5
N_TYPES = 10
N_EXAMPLES = 10


@dataclass(frozen=True)
class Sample:
    """One timed slot of one workload."""

    steps: int
    resets: int
    wall_s: float
    """Wall-clock time of the slot, resets included [s]."""
    reset_wall_s: float
    """Wall-clock time spent in ``reset`` [s]."""
    cpu_s: float
    """CPU time of this process (all its threads) during the slot [s]."""

    @property
    def rate(self) -> float:
        """Steps per second, resets included."""
        return self.steps / self.wall_s

    @property
    def step_only_rate(self) -> float:
        """Steps per second, reset time excluded."""
        return self.steps / max(self.wall_s - self.reset_wall_s, 1e-12)


class Workload:
    """An env plus a policy; ``step`` returns True when the episode ended."""

    name = ""

    def step(self) -> bool:
        raise NotImplementedError

    def reset(self) -> None:
        raise NotImplementedError

    def close(self) -> None:
        raise NotImplementedError


class RandomLfDTrack(Workload):
    name = "lfdtrack"

    def __init__(self, seed: int) -> None:
        self.env = gym.make("LfDTrack-v0")
        self.env.reset(seed=seed)
        self.rng = np.random.default_rng(seed)

    def step(self) -> bool:
        _, _, terminated, truncated, _ = self.env.step(int(self.rng.integers(3)))
        return terminated or truncated

    def reset(self) -> None:
        self.env.reset()

    def close(self) -> None:
        self.env.close()


class RandomCarRacing(Workload):
    name = "carracing"

    def __init__(self, seed: int) -> None:
        try:
            self.env = gym.make("CarRacing-v3")
        except gym.error.DependencyNotInstalled as exc:
            raise SystemExit(
                f"CarRacing-v3 needs Box2D ({exc}); install it with:"
                " pip install 'gymnasium[box2d]'  (or: pip install '.[bench]')"
            ) from None
        self.env.reset(seed=seed)
        self.env.action_space.seed(seed)

    def step(self) -> bool:
        _, _, terminated, truncated, _ = self.env.step(self.env.action_space.sample())
        return terminated or truncated

    def reset(self) -> None:
        self.env.reset()

    def close(self) -> None:
        self.env.close()


class ClosedLoop(Workload):
    """Frame → road values (full library) → MLP → command → env, as the autonomous rover runs."""

    name = "closed_loop"

    def __init__(self, seed: int, library: RoadLibrary) -> None:
        self.env = gym.make("LfDTrack-v0")
        self.library = library
        self.rng = np.random.default_rng(seed)
        self.frame, _ = self.env.reset(seed=seed)
        self._new_controller()

    def _new_controller(self) -> None:
        self.weights = self.rng.uniform(-1.0, 1.0, n_weights())
        self.previous: int | None = None

    def step(self) -> bool:
        values = self.library.road_values(self.frame)
        self.previous = select_action(mlp_forward(self.weights, values), self.previous)
        self.frame, _, terminated, truncated, _ = self.env.step(self.previous)
        return terminated or truncated

    def reset(self) -> None:
        self.frame, _ = self.env.reset()
        self._new_controller()

    def close(self) -> None:
        self.env.close()


def full_library(seed: int, n_frames: int = 12) -> RoadLibrary:
    """A full library (10 types x 10 examples) of region histograms from varied env frames.

    Frames are taken at random poses around the testing track (felt, carpet, edges, shadows).
    The cost of road values depends only on the number of models (one 40 x 100 similarity
    matrix), so the models are laid out directly rather than grown with Algorithm 1, which on
    varied regions keeps evicting young types and rarely ends exactly full.
    """
    rng = np.random.default_rng(seed)
    env = gym.make("LfDTrack-v0")
    env.reset(seed=seed)
    library = RoadLibrary()
    hists = []
    for _ in range(n_frames):
        pose = (rng.uniform(-0.3, 3.3), rng.uniform(-0.3, 2.1), rng.uniform(-np.pi, np.pi))
        frame, _ = env.reset(options={"pose": pose})
        hists.append(library.region_histograms(frame))
    env.close()
    pool = np.concatenate(hists)  # (40 * n_frames, 5, bins)
    chosen = pool[rng.choice(len(pool), N_TYPES * N_EXAMPLES, replace=False)]
    data = library.to_dict()
    data["types"] = [
        {
            "selections": 0,
            "comparisons": 0,
            "examples": [
                {"selections": 0, "comparisons": 0, "model": m.tolist()}
                for m in chosen[t * N_EXAMPLES : (t + 1) * N_EXAMPLES]
            ],
        }
        for t in range(N_TYPES)
    ]
    full = RoadLibrary.from_dict(data)
    assert full.n_models == N_TYPES * N_EXAMPLES and full.n_types == N_TYPES
    return full


def run_for(workload: Workload, seconds: float) -> Sample:
    """Step ``workload`` until ``seconds`` of wall-clock time have passed."""
    steps = resets = 0
    reset_s = 0.0
    clock: Callable[[], float] = time.perf_counter
    t0, c0 = clock(), time.process_time()
    while True:
        done = workload.step()
        steps += 1
        if done:
            r0 = clock()
            workload.reset()
            reset_s += clock() - r0
            resets += 1
        if clock() - t0 >= seconds:
            break
    return Sample(steps, resets, clock() - t0, reset_s, time.process_time() - c0)


def component_times(library: RoadLibrary, seed: int, repeats: int) -> dict[str, float]:
    """Median milliseconds per call of the pieces of a step, interleaved, via public APIs.

    Shows where an env step goes (and what a reset costs, which a random policy pays every
    few steps because it leaves the felt quickly).
    """
    rng = np.random.default_rng(seed)
    preset = load_preset("paper")
    ground = build_ground(load_track("testing"), preset.appearance, preset.lighting, rng)
    renderer = CameraRenderer(preset.camera, preset.sensor)
    renderer.reset(rng)
    rover = Rover(preset.rover)
    rover.reset((0.5, 0.0, 0.0), rng)
    poses = [
        np.array([0.3 + 0.25 * i, rng.uniform(-0.1, 0.1), rng.uniform(-0.5, 0.5)]) for i in range(8)
    ]
    frames = [renderer.render(ground, pose, rng) for pose in poses]
    values = library.road_values(frames[0], update_statistics=False)
    weights = rng.uniform(-1.0, 1.0, n_weights())
    env = gym.make("LfDTrack-v0")
    env.reset(seed=seed)
    racing = gym.make("CarRacing-v3")
    racing.reset(seed=seed)
    racing.action_space.seed(seed)

    def clocked(fn: Callable[[int], object]) -> Callable[[int], float]:
        def call(i: int) -> float:
            t0 = time.perf_counter()
            fn(i)
            return time.perf_counter() - t0

        return call

    def step_only(target: gym.Env, action: Callable[[int], object]) -> Callable[[int], float]:
        """Times one step; an episode end is reset outside the timed part."""

        def call(i: int) -> float:
            t0 = time.perf_counter()
            _, _, terminated, truncated, _ = target.step(action(i))
            elapsed = time.perf_counter() - t0
            if terminated or truncated:
                target.reset()
            return elapsed

        return call

    pieces: dict[str, Callable[[int], float]] = {
        "physics (Rover.step, 0.4 s)": clocked(lambda i: rover.step(i % 3, rng)),
        "camera render 640x480": clocked(lambda i: renderer.render(ground, poses[i % 8], rng)),
        "renderer reset": clocked(lambda i: renderer.reset(rng)),
        "LfDTrack-v0 step": step_only(env, lambda i: int(rng.integers(3))),
        "LfDTrack-v0 reset (no seed)": clocked(lambda i: env.reset()),
        "region histograms": clocked(lambda i: library.region_histograms(frames[i % 8])),
        "road values (100 models)": clocked(lambda i: library.road_values(frames[i % 8])),
        "MLP + action": clocked(lambda i: select_action(mlp_forward(weights, values))),
        "CarRacing-v3 step": step_only(racing, lambda i: racing.action_space.sample()),
    }
    times: dict[str, list[float]] = {name: [] for name in pieces}
    for i in range(repeats):
        for name, piece in pieces.items():
            times[name].append(piece(i))
    env.close()
    racing.close()
    return {name: 1e3 * statistics.median(t) for name, t in times.items()}


def summarise(samples: list[Sample]) -> dict:
    return {
        "median_steps_per_s": statistics.median(s.rate for s in samples),
        "median_step_only_steps_per_s": statistics.median(s.step_only_rate for s in samples),
        "median_steps_per_cpu_s": statistics.median(s.steps / s.cpu_s for s in samples),
        "steps": sum(s.steps for s in samples),
        "resets": sum(s.resets for s in samples),
        "rounds": [asdict(s) for s in samples],
    }


def source_state() -> dict[str, object]:
    """Commit of the checkout and its uncommitted package files (they are what was measured)."""

    def git(*args: str) -> str:
        try:
            proc = subprocess.run(
                ["git", *args], cwd=REPO, capture_output=True, text=True, timeout=10, check=True
            )
        except (OSError, subprocess.SubprocessError):
            return ""
        return proc.stdout

    # Porcelain lines are "XY path"; the status columns may start with a space.
    dirty = git("status", "--porcelain", "--", "lfd_track", "envs", "tracks")
    return {
        "commit": git("rev-parse", "HEAD").strip() or None,
        "uncommitted": [line[3:] for line in dirty.splitlines()],
    }


def versions() -> dict[str, str]:
    import Box2D
    import pygame
    import pymunk

    return {
        "python": platform.python_version(),
        "processor": platform.machine(),
        "cpus": str(os.cpu_count()),
        "gymnasium": gym.__version__,
        "numpy": np.__version__,
        "opencv": cv2.__version__,
        "opencv_threads": str(cv2.getNumThreads()),
        "pymunk": pymunk.version,
        "box2d": getattr(Box2D, "__version__", "?"),
        "pygame": pygame.version.ver,
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n", 1)[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="wall time per slot [s]")
    parser.add_argument("--rounds", type=int, default=7, help="counted rounds (after a warm-up)")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--component-repeats", type=int, default=30, help="calls per piece in the breakdown"
    )
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.rounds < 1 or args.component_repeats < 1:
        parser.error("--seconds must be > 0, --rounds and --component-repeats >= 1")

    load_before = os.getloadavg()
    library = full_library(args.seed + 1)
    workloads: list[Workload] = [
        RandomLfDTrack(args.seed),
        RandomCarRacing(args.seed),
        ClosedLoop(args.seed + 2, library),
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
    components_ms = component_times(library, args.seed + 3, args.component_repeats)
    load_after = os.getloadavg()

    summary = {name: summarise(s) for name, s in samples.items()}

    def ratio(num: str, den: str, key: str) -> float:
        return summary[num][key] / summary[den][key]

    def per_round_ratio(num: str, den: str) -> float:
        pairs = zip(samples[num], samples[den], strict=True)
        return statistics.median(a.rate / b.rate for a, b in pairs)

    ratios = {
        "lfdtrack_over_carracing": ratio("lfdtrack", "carracing", "median_steps_per_s"),
        "closed_loop_over_carracing": ratio("closed_loop", "carracing", "median_steps_per_s"),
        "lfdtrack_over_carracing_step_only": ratio(
            "lfdtrack", "carracing", "median_step_only_steps_per_s"
        ),
        "closed_loop_over_carracing_step_only": ratio(
            "closed_loop", "carracing", "median_step_only_steps_per_s"
        ),
        "lfdtrack_over_carracing_per_round_median": per_round_ratio("lfdtrack", "carracing"),
        "closed_loop_over_carracing_per_round_median": per_round_ratio("closed_loop", "carracing"),
    }
    met = {
        "lfdtrack_over_carracing": ratios["lfdtrack_over_carracing"] >= TARGET_ENV_RATIO,
        "closed_loop_over_carracing": ratios["closed_loop_over_carracing"] >= TARGET_LOOP_RATIO,
    }

    print(
        f"{'workload':<12} {'steps/s':>9} {'steps/s':>11} {'steps/':>8} {'steps':>7} {'resets':>7}"
    )
    print(f"{'':<12} {'(resets)':>9} {'(step only)':>11} {'cpu s':>8}")
    for name, s in summary.items():
        print(
            f"{name:<12} {s['median_steps_per_s']:>9.1f} {s['median_step_only_steps_per_s']:>11.1f}"
            f" {s['median_steps_per_cpu_s']:>8.1f} {s['steps']:>7d} {s['resets']:>7d}"
        )
    print(
        f"lfdtrack / carracing    = {ratios['lfdtrack_over_carracing']:.2f}x"
        f" (step only {ratios['lfdtrack_over_carracing_step_only']:.2f}x;"
        f" target >= {TARGET_ENV_RATIO}x: {'met' if met['lfdtrack_over_carracing'] else 'NOT met'})"
    )
    print(
        f"closed_loop / carracing = {ratios['closed_loop_over_carracing']:.2f}x"
        f" (step only {ratios['closed_loop_over_carracing_step_only']:.2f}x;"
        f" target >= {TARGET_LOOP_RATIO}x:"
        f" {'met' if met['closed_loop_over_carracing'] else 'NOT met'})"
    )
    print("breakdown, median ms per call:")
    for name, ms in components_ms.items():
        print(f"  {name:<30} {ms:8.2f}")
    print(f"load average (1, 5, 15 min): before {load_before}, after {load_after}")

    result = {
        "benchmark": "env_steps_per_second",
        "workloads": {
            "lfdtrack": "gym.make('LfDTrack-v0'), 640x480 RGB frames, random actions",
            "carracing": "gym.make('CarRacing-v3'), 96x96 RGB frames, action_space.sample()",
            "closed_loop": (
                "LfDTrack-v0 + road values (full library, 10 types x 10 examples)"
                " + 40-5-3 MLP with random weights choosing the action"
            ),
        },
        "targets": {
            "lfdtrack_over_carracing": TARGET_ENV_RATIO,
            "closed_loop_over_carracing": TARGET_LOOP_RATIO,
        },
        "targets_met": met,
        "ratios": ratios,
        "seconds_per_slot": args.seconds,
        "rounds": args.rounds,
        "seed": args.seed,
        "load_average_before": list(load_before),
        "load_average_after": list(load_after),
        "machine": versions(),
        "source": source_state(),
        "results": summary,
        "components_median_ms": components_ms,
    }
    atomic_write_text(args.output, json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
