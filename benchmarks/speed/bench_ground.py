"""Painting one floor (``build_ground``) on one thread: ms per floor on the paper preset's worlds.

Every world of a study job is a new seeded floor (each training, testing and loop world of each
repetition), so painting them is a fixed cost of every job, whatever the camera. Timed here on the
training track, the testing track and one procedural loop (``random:test:0``), each floor from its
own seed, ``--rounds`` times; min and median per track, in wall and in CPU (this thread's) time.
``--tracks`` times other tracks instead (e.g. ``notch bolt step arrow zed``, the unseen loops of
``benchmarks/experiments/goal/distilled.toml``). Everything runs on one thread
(``single_thread.pin_one_thread``).

With ``--baseline-rev REV`` the ``build_ground`` of ``lfd_track/render/texture.py`` at git revision
``REV`` is timed too, alternating with this checkout's in every round (so load from other
processes falls on both alike), and the two floors' bytes are compared (they must be identical).

Run: ``.venv/bin/python benchmarks/speed/bench_ground.py [--rounds 5] [--preset paper]
[--baseline-rev REV] [--tracks NAME ...] [--output FILE]`` — prints a table and writes
``benchmarks/speed/results/ground.json``.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import numpy as np
from single_thread import REPO, load_average, pin_one_thread, run_facts

from lfd_track.envs.presets import load_preset
from lfd_track.render import texture
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.world.track import load_track

RESULTS = Path(__file__).resolve().parent / "results" / "ground.json"
TRACKS = ("training", "testing", "random:test:0")

Builder = Callable[..., texture.GroundTexture]


def baseline_module(rev: str) -> ModuleType:
    """``lfd_track/render/texture.py`` as it was at git revision ``rev``, imported beside this
    checkout's (its relative imports resolve in this checkout's package)."""
    source = subprocess.run(
        ["git", "show", f"{rev}:lfd_track/render/texture.py"],
        cwd=REPO,
        capture_output=True,
        text=True,
        check=True,
    ).stdout
    path = Path(tempfile.mkdtemp()) / "texture_baseline.py"
    path.write_text(source)
    name = "lfd_track.render._texture_baseline"
    spec = importlib.util.spec_from_file_location(name, path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


def time_floor(
    build: Builder, track_name: str, preset_name: str, seed: int
) -> tuple[float, float, np.ndarray]:
    """Wall and CPU (this thread's) milliseconds to paint ``track_name``'s floor from ``seed``,
    and the floor's RGBA."""
    track = load_track(track_name)
    appearance, lighting = _world(preset_name)
    rng = np.random.default_rng(seed)
    t0, c0 = time.perf_counter(), time.thread_time()
    ground = build(track, appearance, lighting, rng)
    cpu_ms = (time.thread_time() - c0) * 1e3
    return (time.perf_counter() - t0) * 1e3, cpu_ms, ground.rgba


def _world(preset_name: str) -> tuple[texture.AppearanceConfig, texture.LightingConfig]:
    preset = load_preset(preset_name)
    return preset.appearance, preset.lighting


def summary(times: list[float]) -> dict[str, float]:
    return {"min_ms": round(min(times), 1), "median_ms": round(statistics.median(times), 1)}


CLOCKS = ("wall", "cpu")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--preset", default="paper")
    parser.add_argument("--baseline-rev", default=None)
    parser.add_argument("--tracks", nargs="+", default=list(TRACKS))
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    pin_one_thread()
    load_before = load_average()
    tracks = args.tracks

    sides: dict[str, Builder] = {"this checkout": texture.build_ground}
    if args.baseline_rev:
        sides[f"baseline {args.baseline_rev}"] = baseline_module(args.baseline_rev).build_ground
    # times[clock][side][track]: one value per round
    times = {c: {s: {t: [] for t in tracks} for s in sides} for c in CLOCKS}
    shapes: dict[str, list[int]] = {}
    identical = True
    for build in sides.values():  # warm up: OpenCV's first calls set up their kernels
        build(load_track("training"), *_world(args.preset), np.random.default_rng(0))
    for r in range(args.rounds):
        order = list(sides) if r % 2 == 0 else list(reversed(sides))
        for name in tracks:
            floors = []
            for side in order:
                wall, cpu, rgba = time_floor(sides[side], name, args.preset, seed=r)
                times["wall"][side][name].append(wall)
                times["cpu"][side][name].append(cpu)
                floors.append(rgba)
            shapes[name] = list(floors[0].shape[:2])
            identical &= all(np.array_equal(f, floors[0]) for f in floors)
        print(f"round {r + 1}/{args.rounds} done", flush=True)

    result: dict[str, object] = {}
    for clock in CLOCKS:
        print(f"build_ground, preset {args.preset}, {clock} ms per floor (min / median):")
        result[clock] = per_side = {}
        for side in sides:
            per_side[side] = per_track = {t: summary(times[clock][side][t]) for t in tracks}
            cells = "  ".join(
                f"{t}: {v['min_ms']:.0f} / {v['median_ms']:.0f}" for t, v in per_track.items()
            )
            print(f"  {side:24s} {cells}")
        if args.baseline_rev:
            base, ours = (
                times[clock][f"baseline {args.baseline_rev}"],
                times[clock]["this checkout"],
            )
            ratios = {
                t: round(statistics.median(base[t]) / statistics.median(ours[t]), 2) for t in tracks
            }
            per_side["speedup_of_medians"] = ratios
            print(f"  speed-up (median over median): {ratios}")
    if args.baseline_rev:
        result["identical_bytes"] = identical
        print(f"identical bytes: {identical}")
    payload = {
        "benchmark": "bench_ground",
        "preset": args.preset,
        "rounds": args.rounds,
        "baseline_rev": args.baseline_rev,
        "texture_shape_hw": shapes,
        "results_ms_per_floor": result,
        **run_facts(load_before),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(args.output, json.dumps(payload, indent=2) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
