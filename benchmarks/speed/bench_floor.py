"""The floor of one closed-loop step, and our step as a multiple of it, on one thread.

A closed-loop step turns the rover's pose into a command: render the camera frame, compute the 40
road values (Algorithm 2), run the 40-5-3 MLP, and move the rover. The *floor* is the work no
implementation producing the same observation and the same road values can skip, each piece
timed alone on frames and poses of the paper's world:

* **sampling the frame** — every one of the 640 × 480 pixels shows the ground under it, so each
  must be looked up in the ground texture at least once: one perspective warp with bilinear
  lookup (``cv2.warpPerspective``, ``INTER_LINEAR``) over the whole frame, each band of rows from
  the pre-filtered mip level its pixel footprint needs (the cheapest correct filter: bilinear
  from the full-resolution texture aliases where a pixel covers many texels, and any coarser
  level blurs). Timed both as a 3-channel warp and as the 4-channel warp (OpenCV's vectorised
  path) plus the RGBA → RGB copy; the floor takes the faster;
* **RGB → HSV** — the H and S histograms need every pixel's hue and saturation (one
  ``cv2.cvtColor``);
* **200 region histograms** — 40 regions × 5 channels (R, G, B, H, S), every pixel counted once
  per channel (``cv2.calcHist``, as ``lfd_track.vision.histograms.GridHistogrammer``);
* **road-value correlation** — the 40 region histograms against the library's 100 models (one
  batched product, ``similarity_matrix``) and the best per region: the road values are defined
  by these comparisons;
* **MLP forward** — 40 → 5 → 3 and the command (``mlp_forward``, ``select_action``);
* **physics** — one control period of the rover (``Rover.step``).

Left out of the floor: the camera's image pipeline (auto-exposure, tone curve, vignetting, white
balance, sensor noise), the episode's bookkeeping and Python's glue — they are our step's
overhead over the floor.

Our step against the floor: the closed loop's time per step without resets (a reset, every ~20
steps of a random controller, renders a frame and places the rover, which no step needs), and
with them. Also measured: the env step's budget per texture filter (physics, the whole render and each
camera stage inside it, ``bench_env.py``'s instrumentation), and, in the same process, in
interleaved rounds (``bench_env.py``'s workloads): the env
alone and the closed loop with ``texture_filter = "bilinear"`` and ``"mipmap"``, and
Gymnasium's ``CarRacing-v3``, so every ratio is taken within one round. Everything runs on one
thread (``single_thread.pin_one_thread``).

Run: ``.venv/bin/python benchmarks/speed/bench_floor.py [--seconds N] [--rounds R]`` — prints a
table and writes ``benchmarks/speed/results/floor.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path

import cv2
import gymnasium as gym
import numpy as np
from bench_env import (
    ClosedLoop,
    RandomCarRacing,
    RandomLfDTrack,
    full_library,
    instrument,
    run_for,
    time_camera_stages,
)
from bench_env import vector_scaling as env_vector_scaling
from single_thread import load_average, pin_one_thread, run_facts

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.policy.mlp import mlp_forward, n_weights, select_action
from lfd_track.render.camera import CameraRenderer
from lfd_track.render.texture import build_ground
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.histograms import GridHistogrammer, centred_unit, similarity_matrix
from lfd_track.world.rover import Rover
from lfd_track.world.track import load_track

RESULTS = Path(__file__).resolve().parent / "results" / "floor.json"
FILTERS = ("bilinear", "mipmap")


def preset_with(texture_filter: str) -> Preset:
    """The paper preset with the camera's ``texture_filter`` set."""
    paper = load_preset("paper")
    camera = dataclasses.replace(paper.camera, texture_filter=texture_filter)
    return dataclasses.replace(paper, camera=camera)


class FilteredLfDTrack(RandomLfDTrack):
    def __init__(self, seed: int, texture_filter: str) -> None:
        self.name = f"lfdtrack_{texture_filter}"
        self.env = gym.make("LfDTrack-v0", preset=preset_with(texture_filter))
        self.env.reset(seed=seed)
        self.rng = np.random.default_rng(seed)


class FilteredClosedLoop(ClosedLoop):
    def __init__(self, seed: int, library, texture_filter: str) -> None:
        self.name = f"closed_loop_{texture_filter}"
        self.env = gym.make("LfDTrack-v0", preset=preset_with(texture_filter))
        self.library = library
        self.rng = np.random.default_rng(seed)
        self.frame, _ = self.env.reset(seed=seed)
        self._new_controller()


def vector_scaling(texture_filter: str, seconds: float, rounds: int, seed: int) -> dict:
    """``bench_env.vector_scaling`` (two async envs against one) with the given texture filter."""
    preset = preset_with(texture_filter)
    return {
        "texture_filter": texture_filter,
        **env_vector_scaling(seconds, rounds, seed, preset=preset),
    }


def stage_budget(texture_filter: str, steps: int, seed: int) -> dict[str, float]:
    """Median ms per env step of physics, the render and each camera stage inside it (the
    OpenCV calls of ``lfd_track/render/camera.py``, timed call by call), random actions."""
    env = gym.make("LfDTrack-v0", preset=preset_with(texture_filter))
    env.reset(seed=seed)
    times = instrument(env)
    rng = np.random.default_rng(seed)
    time_camera_stages(True)
    try:
        for _ in range(steps):
            _, _, terminated, truncated, _ = env.step(int(rng.integers(3)))
            if terminated or truncated:
                env.reset()
    finally:
        time_camera_stages(False)
        env.close()
    return {k.removeprefix("stage: "): 1e3 * statistics.median(v) for k, v in times.items()}


def median_ms(fn: Callable[[int], object], calls: int) -> float:
    times = []
    for i in range(calls):
        t0 = time.perf_counter()
        fn(i)
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times)


def floor_pieces(library, seed: int, calls: int) -> dict[str, float]:
    """Median ms per call of each piece of the floor, on 16 poses of the testing track."""
    preset = preset_with("mipmap")
    track = load_track("testing")
    rng = np.random.default_rng(seed)
    ground = build_ground(track, preset.appearance, preset.lighting, rng)
    renderer = CameraRenderer(preset.camera, preset.sensor)
    renderer.reset(rng)
    poses = []
    for s in np.linspace(0.0, track.length_m, 16, endpoint=False):
        point, heading = track.point_at(float(s))
        poses.append(np.array([point[0], point[1], heading + rng.uniform(-0.3, 0.3)]))
    frames = [renderer.render(ground, p, rng) for p in poses]
    mats = [np.linalg.inv(renderer.model.homography(p, ground)) for p in poses]
    bands = renderer.mip_bands(ground.metres_per_px)
    levels4 = {lv: ground.mip_level(lv) for _, _, lv in bands}
    levels3 = {lv: np.ascontiguousarray(img[..., :3]) for lv, img in levels4.items()}
    h, w = preset.camera.height_px, preset.camera.width_px
    out4 = np.empty((h, w, 4), np.uint8)
    out3 = np.empty((h, w, 3), np.uint8)
    rgb = np.empty((h, w, 3), np.uint8)
    flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP

    def warp(levels: dict, out: np.ndarray, i: int) -> None:
        base = mats[i % len(mats)]
        for v0, v1, lv in bands:
            m = np.diag([0.5**lv, 0.5**lv, 1.0]) @ base
            m[:, 2] += m[:, 1] * v0
            cv2.warpPerspective(
                levels[lv], m, (w, v1 - v0), dst=out[v0:v1], flags=flags,
                borderMode=cv2.BORDER_REFLECT,
            )  # fmt: skip

    def warp4(i: int) -> None:
        warp(levels4, out4, i)
        cv2.cvtColor(out4, cv2.COLOR_RGBA2RGB, dst=rgb)

    grid = GridHistogrammer(library.bins, threads=1)
    hsv = grid._hsv  # the buffer its regions read

    def to_hsv(i: int) -> None:
        cv2.cvtColor(frames[i % len(frames)], cv2.COLOR_RGB2HSV, dst=hsv)

    def histograms(i: int) -> None:
        grid._count(frames[i % len(frames)], 0, 40)

    hists = [library.region_histograms(f) for f in frames]
    prepared, _ = library._stacked()

    def correlation(i: int) -> None:
        sims = similarity_matrix(centred_unit(hists[i % len(hists)]), prepared)
        sims.max(axis=1)

    weights = rng.uniform(-1.0, 1.0, n_weights())
    values = library.road_values(frames[0], update_statistics=False)

    def mlp(i: int) -> None:
        select_action(mlp_forward(weights, values), None)

    rover = Rover(preset.rover)
    rover.reset(tuple(poses[0]), rng)

    def physics(i: int) -> None:
        rover.step(i % 3, rng)

    pieces = {
        "sample frame, 3-channel warp": lambda i: warp(levels3, out3, i),
        "sample frame, 4-channel warp + RGBA->RGB": warp4,
        "RGB->HSV": to_hsv,
        "200 region histograms": histograms,
        "road-value correlation (40 x 100 models)": correlation,
        "MLP forward + command": mlp,
        "physics step": physics,
    }
    for fn in pieces.values():  # warm caches and lazy builds
        fn(0)
    return {name: median_ms(fn, calls) for name, fn in pieces.items()}


def floor_ms(pieces: dict[str, float]) -> float:
    sample = min(
        pieces["sample frame, 3-channel warp"], pieces["sample frame, 4-channel warp + RGBA->RGB"]
    )
    rest = (k for k in pieces if not k.startswith("sample frame"))
    return sample + sum(pieces[k] for k in rest)


#: The camera's image pipeline inside a render (``bench_env``'s stage names): everything the
#: render does besides sampling the frame, and none of it in the floor.
CAMERA_EFFECTS = (
    "exposure meter",
    "tone curve",
    "vignetting and white balance",
    "sensor noise",
    "motion blur",
    "JPEG round trip",
)


def overhead(summary: dict, texture_filter: str) -> dict[str, float]:
    """Where the closed-loop step's time over the floor goes, from the medians of ``summary``:
    the camera's image pipeline (timed stage by stage inside the env's renders) and the rest
    (the episode's bookkeeping, Python's glue, colder caches than the floor's pieces see).
    Also the bounds the floor sets: the step if nothing but the floor and the camera effects
    were left, and the env-alone rate against CarRacing-v3 at the env's own floor (sampling
    the frame and the physics), with and without the camera effects."""
    pieces, floor = summary["floor_pieces_ms"], summary["floor_ms"]
    step = 1e3 / summary["steps_only_per_s"][f"closed_loop_{texture_filter}"]
    budget = summary["env_step_budget_ms"][texture_filter]
    camera = sum(budget.get(k, 0.0) for k in CAMERA_EFFECTS)
    sample = min(v for k, v in pieces.items() if k.startswith("sample frame"))
    env_floor = sample + pieces["physics step"]
    carracing_ms = 1e3 / summary["steps_per_s"]["carracing"]
    return {
        "step": step,
        "floor": floor,
        "over_floor": step - floor,
        "camera_effects": camera,
        "rest": step - floor - camera,
        "floor_and_camera_effects_per_floor": (floor + camera) / floor,
        "env_floor": env_floor,
        "env_floor_per_carracing": carracing_ms / env_floor,
        "env_floor_and_camera_per_carracing": carracing_ms / (env_floor + camera),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=2.0, help="per workload per round")
    parser.add_argument("--rounds", type=int, default=5, help="counted rounds (after a warm-up)")
    parser.add_argument("--calls", type=int, default=200, help="calls per floor piece per round")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument(
        "--vec-rounds", type=int, default=3, help="rounds of one env vs 2 async envs (0: skip)"
    )
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    pin_one_thread()
    load_before = load_average()
    library = full_library(args.seed)
    workloads = [FilteredLfDTrack(args.seed, f) for f in FILTERS]
    workloads += [FilteredClosedLoop(args.seed, library, f) for f in FILTERS]
    workloads.append(RandomCarRacing(args.seed))
    rounds = []
    for r in range(args.rounds + 1):
        order = workloads if r % 2 == 0 else workloads[::-1]
        samples = {wl.name: run_for(wl, args.seconds) for wl in order}
        rates = {name: sample.rate for name, sample in samples.items()}
        step_rates = {name: sample.step_only_rate for name, sample in samples.items()}
        pieces = floor_pieces(library, args.seed + r, args.calls)
        budgets = {f: stage_budget(f, args.calls, args.seed + r) for f in FILTERS}
        if r == 0:
            continue  # warm-up
        floor = floor_ms(pieces)
        row = {"steps_per_s": rates, "steps_only_per_s": step_rates}
        row.update(floor_pieces_ms=pieces, floor_ms=floor)
        row["env_step_budget_ms"] = budgets
        row["floor_steps_per_s"] = 1e3 / floor
        row["load_average"] = load_average()
        rounds.append(row)
        print(f"round {r}: " + ", ".join(f"{k} {v:.0f}" for k, v in rates.items())
              + f", floor {floor:.2f} ms, load {row['load_average'][0]}", flush=True)  # fmt: skip
    for wl in workloads:
        wl.close()

    def med(fn: Callable[[dict], float]) -> float:
        return statistics.median(fn(row) for row in rounds)

    summary: dict[str, object] = {
        "floor_ms": med(lambda r: r["floor_ms"]),
        "floor_pieces_ms": {k: med(lambda r, k=k: r["floor_pieces_ms"][k]) for k in rounds[0]["floor_pieces_ms"]},
        "steps_per_s": {k: med(lambda r, k=k: r["steps_per_s"][k]) for k in rounds[0]["steps_per_s"]},
        "steps_only_per_s": {k: med(lambda r, k=k: r["steps_only_per_s"][k]) for k in rounds[0]["steps_only_per_s"]},
    }  # fmt: skip
    summary["env_step_budget_ms"] = {
        f: {k: med(lambda r, f=f, k=k: r["env_step_budget_ms"][f][k]) for k in rounds[0]["env_step_budget_ms"][f]}
        for f in FILTERS
    }  # fmt: skip
    ratios: dict[str, float] = {}
    for f in FILTERS:
        loop = f"closed_loop_{f}"
        ratios[f"{loop} step / floor"] = med(
            lambda r, loop=loop: r["floor_steps_per_s"] / r["steps_only_per_s"][loop]
        )
        ratios[f"{loop} step with resets / floor"] = med(
            lambda r, loop=loop: r["floor_steps_per_s"] / r["steps_per_s"][loop]
        )
        for wl in (f"lfdtrack_{f}", loop):
            ratios[f"{wl} / carracing"] = med(
                lambda r, wl=wl: r["steps_per_s"][wl] / r["steps_per_s"]["carracing"]
            )
    for wl in ("lfdtrack", "closed_loop"):
        ratios[f"{wl} mipmap / bilinear"] = med(
            lambda r, wl=wl: r["steps_per_s"][f"{wl}_mipmap"] / r["steps_per_s"][f"{wl}_bilinear"]
        )
    summary["ratios"] = ratios
    summary["overhead_ms"] = {f: overhead(summary, f) for f in FILTERS}
    if args.vec_rounds > 0:
        summary["two_async_envs"] = vector_scaling(
            "mipmap", args.seconds, args.vec_rounds, args.seed
        )
    result = {
        "benchmark": "floor",
        "command": "benchmarks/speed/bench_floor.py " + " ".join(sys.argv[1:] if argv is None else argv),
        "seconds_per_slot": args.seconds,
        **run_facts(load_before),
        "summary": summary,
        "rounds": rounds,
    }  # fmt: skip
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(f"floor {summary['floor_ms']:.2f} ms ({1e3 / summary['floor_ms']:.0f} steps/s)")
    for k, v in summary["floor_pieces_ms"].items():
        print(f"  {k:45s} {v:6.3f} ms")
    for k, v in ratios.items():
        print(f"{k:40s} {v:5.2f}x")
    for f, budget in summary["env_step_budget_ms"].items():
        print(f"env step budget, {f}: " + ", ".join(f"{k} {v:.2f}" for k, v in budget.items()))
    for f, o in summary["overhead_ms"].items():
        print(
            f"closed loop over the floor, {f}: {o['over_floor']:.2f} ms = camera effects"
            f" {o['camera_effects']:.2f} + the rest {o['rest']:.2f}; floor + camera effects ="
            f" {o['floor_and_camera_effects_per_floor']:.2f}x the floor; an env step at its own"
            f" floor (sampling + physics) would run {o['env_floor_per_carracing']:.2f}x"
            f" CarRacing-v3, with the camera effects {o['env_floor_and_camera_per_carracing']:.2f}x"
        )
    if "two_async_envs" in summary:
        vec = summary["two_async_envs"]
        print(
            f"2 async envs (mipmap) {vec['two_async_envs_steps_per_s']:.0f} vs one"
            f" {vec['one_env_steps_per_s']:.0f} steps/s: {vec['scaling']:.2f}x"
        )
    print(f"load average {result['load_average_before']} -> {result['load_average_after']}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
