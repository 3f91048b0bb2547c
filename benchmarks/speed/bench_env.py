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
of them alike; the first round is a warm-up and is not counted. Ratios are the median of the
per-round ratios. Two rates are kept per workload: *with resets* (steps / all time, the throughput
a training loop sees) and *steps only* (reset time excluded). Everything runs on one thread:
OpenCV and the BLAS are pinned (``single_thread.pin_one_thread``), as CarRacing's Box2D and
pygame are single-threaded anyway. Targets: lfdtrack / carracing >= 3 and closed_loop /
carracing >= 1.5.

Also measured: a per-step time budget taken inside the env's own steps (physics; the camera's
stages — texture warp, exposure meter, tone curve, vignetting and white balance, sensor noise —
timed call by call inside each render; the rest of the render; the env's bookkeeping), plus
road values and the MLP, and the throughput of ``gymnasium.make_vec("LfDTrack-v0", num_envs=2,
vectorization_mode="async")`` against one env in this process, interleaved the same way.

Run: ``.venv/bin/python benchmarks/speed/bench_env.py [--seconds N] [--rounds R]`` — prints a table and
writes ``benchmarks/speed/results/env.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import cv2
import gymnasium as gym
import numpy as np
from single_thread import load_average, machine, pin_one_thread, source_state

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.presets import load_preset
from lfd_track.policy.mlp import mlp_forward, n_weights, select_action
from lfd_track.render.camera import CameraRenderer
from lfd_track.render.texture import build_ground
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.rover import Rover
from lfd_track.world.track import load_track

RESULTS = Path(__file__).resolve().parent / "results" / "env.json"
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


def component_times(
    library: RoadLibrary, seed: int, repeats: int, env_steps: int = 600
) -> dict[str, dict[str, float]]:
    """Median milliseconds per call of the pieces of a closed-loop step.

    The pieces (physics, render, road values, MLP, CarRacing's step) are timed through public
    APIs, interleaved; so are stand-alone copies of the camera stages: the texture warp (the
    renderer's own homography fed to the same ``cv2.warpPerspective`` call) and the same OpenCV
    calls on arrays of the frame's size for exposure and tone curve (``cvtColor`` + ``LUT``),
    vignetting and white balance (``multiply``) and sensor noise (saturating ``add`` +
    ``subtract`` of a noise frame). Interleaved, each starts with caches the others evicted.
    The ``budget`` is measured inside ``env_steps`` consecutive steps of an instrumented env
    (random actions, resets untimed): physics, each camera stage call by call inside each render,
    the rest of the render (homography, margin check, Python) and the env's bookkeeping (episode
    rules, info dict) as what remains of each step; with road values and the MLP it adds up to a
    closed-loop step.
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
    in_env = instrument(env)
    racing = gym.make("CarRacing-v3")
    racing.reset(seed=seed)
    racing.action_space.seed(seed)
    height, width = preset.camera.height_px, preset.camera.width_px
    warp_flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
    raw = np.empty((height, width, 4), dtype=np.uint8)
    tone = np.clip(np.arange(256) * 1.1, 0, 255).astype(np.uint8)
    gain_map = rng.integers(150, 230, (height, width, 3), dtype=np.uint8)
    noise = rng.integers(0, 8, (2, height + 16, width + 16, 3), dtype=np.uint8)

    def warp(i: int) -> None:
        inverse = np.linalg.inv(renderer.model.homography(poses[i % 8], ground))
        cv2.warpPerspective(
            ground.rgba,
            inverse,
            (width, height),
            dst=raw,
            flags=warp_flags,
            borderMode=cv2.BORDER_REFLECT,
        )

    def exposure_and_tone(i: int) -> None:
        rgb = cv2.cvtColor(raw, cv2.COLOR_RGBA2RGB)
        cv2.LUT(rgb.reshape(height, -1), tone)

    def vignetting_and_white_balance(i: int) -> None:
        cv2.multiply(frames[i % 8], gain_map, scale=1.0 / 200.0)

    def sensor_noise(i: int) -> None:
        frame = frames[i % 8].copy()
        d = i % 16
        cv2.add(frame, noise[0, d : d + height, d : d + width], dst=frame)
        cv2.subtract(frame, noise[1, d : d + height, d : d + width], dst=frame)

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

    bookkeeping: list[float] = []
    timed_env_step = step_only(env, lambda i: int(rng.integers(3)))

    def env_step(i: int) -> float:
        """Times one env step and keeps what it spent outside physics and render."""
        n_physics, n_render = len(in_env["physics"]), len(in_env["render"])
        elapsed = timed_env_step(i)
        inner = sum(in_env["physics"][n_physics : n_physics + 1]) + sum(
            in_env["render"][n_render : n_render + 1]
        )
        bookkeeping.append(elapsed - inner)
        return elapsed

    pieces: dict[str, Callable[[int], float]] = {
        "physics (Rover.step, 0.4 s)": clocked(lambda i: rover.step(i % 3, rng)),
        "texture warp": clocked(warp),
        "exposure and tone curve": clocked(exposure_and_tone),
        "vignetting and white balance": clocked(vignetting_and_white_balance),
        "sensor noise": clocked(sensor_noise),
        "camera render 640x480": clocked(lambda i: renderer.render(ground, poses[i % 8], rng)),
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
    # The env's steps run back to back, as in a training loop (interleaved with the pieces above
    # every step would start with caches the other pieces had just evicted), with the camera's
    # OpenCV calls timed one by one only here.
    for timings in in_env.values():
        timings.clear()
    bookkeeping.clear()
    time_camera_stages(True)
    try:
        times["LfDTrack-v0 step"] = [env_step(i) for i in range(env_steps)]
    finally:
        time_camera_stages(False)
    env.close()
    racing.close()
    ms = {name: 1e3 * statistics.median(t) for name, t in times.items()}
    # Redrawing the noise and white-balance pools (only when a world is rebuilt) churns ~15 MB;
    # timed after the loop so it does not leave the other pieces with cold caches.
    spare = CameraRenderer(preset.camera, preset.sensor)
    ms["renderer reset (new pools)"] = 1e3 * statistics.median(
        clocked(lambda i: spare.reset(rng))(i) for i in range(3)
    )
    ms["physics inside LfDTrack-v0 step"] = 1e3 * statistics.median(in_env["physics"])
    ms["camera render inside LfDTrack-v0 step"] = 1e3 * statistics.median(in_env["render"])
    # Inside the env's steps (renders at reset included), each camera stage's time per render
    # and what the render spent beyond them (homography, margin check, Python), render by render.
    # Stages this preset never runs (motion blur, JPEG) are left out.
    stage_keys = [k for k in in_env if k.startswith("stage: ") and any(in_env[k])]
    rest = [
        render - sum(in_env[k][i] for k in stage_keys) for i, render in enumerate(in_env["render"])
    ]
    budget = {
        "physics": ms["physics inside LfDTrack-v0 step"],
        **{k.removeprefix("stage: "): 1e3 * statistics.median(in_env[k]) for k in stage_keys},
        "rest of the render (homography, margin check, Python)": 1e3 * statistics.median(rest),
        "env bookkeeping (episode rules, info)": 1e3 * statistics.median(bookkeeping),
        "road values": ms["road values (100 models)"],
        "MLP + action": ms["MLP + action"],
    }
    return {"pieces_ms": ms, "closed_loop_step_budget_ms": budget}


#: Camera stage of each OpenCV call the renderer makes (``lfd_track/render/camera.py``).
CAMERA_STAGES = {
    "warpPerspective": "texture warp",
    "remap": "texture warp",  # a distorted lens: its floor map moved by cv2.transform, then remap
    "transform": "texture warp",
    "filter2D": "motion blur",  # only with the sensor's motion_blur on (not in the paper preset)
    "imencode": "JPEG round trip",  # only with jpeg_quality > 0
    "imdecode": "JPEG round trip",
    "resize": "exposure meter",
    "mean": "exposure meter",
    "cvtColor": "tone curve",
    "LUT": "tone curve",
    "multiply": "vignetting and white balance",
    "add": "sensor noise",
    "subtract": "sensor noise",
}


class _TimedCv2:
    """Stands in for ``cv2`` inside the camera module: every call in :data:`CAMERA_STAGES` adds
    its time to its stage's running total [s]; everything else passes through untouched."""

    def __init__(self, totals: dict[str, float]) -> None:
        self._totals = totals

    def __getattr__(self, name: str):
        real = getattr(cv2, name)
        stage = CAMERA_STAGES.get(name)
        if stage is None:
            return real
        totals = self._totals

        def call(*args, **kwargs):
            t0 = time.perf_counter()
            out = real(*args, **kwargs)
            totals[stage] += time.perf_counter() - t0
            return out

        return call


_STAGE_TOTALS: dict[str, float] = dict.fromkeys(sorted(set(CAMERA_STAGES.values())), 0.0)
"""Seconds per camera stage in the render now running (while :func:`time_camera_stages` is on)."""


def time_camera_stages(on: bool) -> None:
    """Time the camera module's OpenCV calls stage by stage (``on``), or give it back the real
    ``cv2`` (benchmark-only instrumentation)."""
    from lfd_track.render import camera as camera_module

    camera_module.cv2 = _TimedCv2(_STAGE_TOTALS) if on else cv2


def instrument(env: gym.Env) -> dict[str, list[float]]:
    """Record the time of the physics and render calls inside ``env.step`` (and reset), and of
    each camera stage inside every render (:data:`CAMERA_STAGES`; key ``stage: <name>``; zero
    unless :func:`time_camera_stages` is on).

    Wraps the env's rover and renderer objects (private attributes: benchmark-only
    instrumentation). Returns the lists the timings are appended to [s], one entry per call.
    """
    stages = sorted(_STAGE_TOTALS)
    inner: dict[str, list[float]] = {"physics": [], "render": []}
    inner.update({f"stage: {name}": [] for name in stages})
    totals = _STAGE_TOTALS
    base = env.unwrapped
    renderer, rover = base._renderer, base._rover
    render, rover_step = renderer.render, rover.step

    def timed(fn: Callable, key: str) -> Callable:
        def call(*args, **kwargs):
            t0 = time.perf_counter()
            out = fn(*args, **kwargs)
            inner[key].append(time.perf_counter() - t0)
            return out

        return call

    def render_by_stage(*args, **kwargs):
        for name in stages:
            totals[name] = 0.0
        out = timed(render, "render")(*args, **kwargs)
        for name in stages:
            inner[f"stage: {name}"].append(totals[name])
        return out

    renderer.render = render_by_stage
    rover.step = timed(rover_step, "physics")
    return inner


def random_steps(env: gym.Env, seconds: float, rng: np.random.Generator) -> int:
    """Steps of one env in ``seconds`` of random actions (resets when an episode ends, not
    counted)."""
    steps, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        _, _, terminated, truncated, _ = env.step(int(rng.integers(3)))
        steps += 1
        if terminated or truncated:
            env.reset()
    return steps


def vector_scaling(seconds: float, rounds: int, seed: int, **env_kwargs: Any) -> dict:
    """Steps/s of ``make_vec(num_envs=2, async)`` against one env, interleaved, random actions.

    Steps of the vector env count both sub-envs. Its workers are forked from this process, so
    they inherit the one-thread settings. ``env_kwargs`` go to both ``gym.make`` calls (e.g.
    ``preset=``).
    """
    single = gym.make("LfDTrack-v0", **env_kwargs)
    single.reset(seed=seed)
    vec = gym.make_vec("LfDTrack-v0", num_envs=2, vectorization_mode="async", **env_kwargs)
    vec.reset(seed=seed)
    rng = np.random.default_rng(seed)

    def run_single() -> float:
        t0 = time.perf_counter()
        steps = random_steps(single, seconds, rng)
        return steps / (time.perf_counter() - t0)

    def run_vec() -> float:
        # Episodes restart inside the vector env (gymnasium's autoreset); every call counts.
        steps, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < seconds:
            vec.step(rng.integers(3, size=2))
            steps += 2
        return steps / (time.perf_counter() - t0)

    rows = []
    for r in range(rounds + 1):
        if r % 2 == 0:
            one = run_single()
            two = run_vec()
        else:
            two = run_vec()
            one = run_single()
        if r > 0:  # round 0 warms up
            rows.append(
                {
                    "one_env_steps_per_s": one,
                    "two_async_envs_steps_per_s": two,
                    "load_average": load_average(),
                }
            )
    single.close()
    vec.close()
    return {
        "seconds_per_slot": seconds,
        "rounds": rows,
        "one_env_steps_per_s": statistics.median(r["one_env_steps_per_s"] for r in rows),
        "two_async_envs_steps_per_s": statistics.median(
            r["two_async_envs_steps_per_s"] for r in rows
        ),
        "scaling": statistics.median(
            r["two_async_envs_steps_per_s"] / r["one_env_steps_per_s"] for r in rows
        ),
    }


def summarise(samples: list[Sample]) -> dict:
    return {
        "median_steps_per_s": statistics.median(s.rate for s in samples),
        "median_step_only_steps_per_s": statistics.median(s.step_only_rate for s in samples),
        "median_steps_per_cpu_s": statistics.median(s.steps / s.cpu_s for s in samples),
        "steps": sum(s.steps for s in samples),
        "resets": sum(s.resets for s in samples),
        "rounds": [asdict(s) for s in samples],
    }


def versions() -> dict[str, object]:
    import Box2D
    import pygame

    return {
        **machine(),  # gymnasium's and pymunk's versions among them
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
    parser.add_argument(
        "--vector-rounds", type=int, default=3, help="rounds of the make_vec scaling (0: skip)"
    )
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    if args.seconds <= 0 or args.rounds < 1 or args.component_repeats < 1 or args.vector_rounds < 0:
        parser.error(
            "--seconds must be > 0, --rounds and --component-repeats >= 1, --vector-rounds >= 0"
        )

    pin_one_thread()
    load_before = load_average()
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
    components = component_times(library, args.seed + 3, args.component_repeats)
    vector = (
        vector_scaling(args.seconds, args.vector_rounds, args.seed + 4)
        if args.vector_rounds
        else None
    )
    load_after = load_average()

    summary = {name: summarise(s) for name, s in samples.items()}

    def per_round(num: str, den: str, rate: Callable[[Sample], float]) -> float:
        pairs = zip(samples[num], samples[den], strict=True)
        return statistics.median(rate(a) / rate(b) for a, b in pairs)

    def with_resets(x: Sample) -> float:
        return x.rate

    def step_only(x: Sample) -> float:
        return x.step_only_rate

    ratios = {
        "lfdtrack_over_carracing": per_round("lfdtrack", "carracing", with_resets),
        "closed_loop_over_carracing": per_round("closed_loop", "carracing", with_resets),
        "lfdtrack_over_carracing_step_only": per_round("lfdtrack", "carracing", step_only),
        "closed_loop_over_carracing_step_only": per_round("closed_loop", "carracing", step_only),
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
    print("closed-loop step budget, median ms:")
    for name, ms in components["closed_loop_step_budget_ms"].items():
        print(f"  {name:<48} {ms:8.2f}")
    print("pieces, median ms per call:")
    for name, ms in components["pieces_ms"].items():
        print(f"  {name:<48} {ms:8.2f}")
    if vector is not None:
        print(
            f"make_vec(num_envs=2, async): {vector['two_async_envs_steps_per_s']:.1f} steps/s vs"
            f" one env {vector['one_env_steps_per_s']:.1f} -> {vector['scaling']:.2f}x"
        )
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
        "method": (
            "interleaved rounds, median of per-round ratios; OpenCV and BLAS pinned to one thread"
        ),
        "targets": {
            "lfdtrack_over_carracing": TARGET_ENV_RATIO,
            "closed_loop_over_carracing": TARGET_LOOP_RATIO,
        },
        "targets_met": met,
        "ratios": ratios,
        "seconds_per_slot": args.seconds,
        "rounds": args.rounds,
        "seed": args.seed,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "machine": versions(),
        "source": source_state(),
        "results": summary,
        "components_median_ms": components["pieces_ms"],
        "closed_loop_step_budget_ms": components["closed_loop_step_budget_ms"],
        "vector_env": vector,
    }
    atomic_write_text(args.output, json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.output}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
