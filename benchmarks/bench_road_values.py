"""Road values per 640x480 frame with a full library (10 types x 10 examples): vectorised
``RoadLibrary.road_values`` against the naive per-region ``cv2.calcHist`` + per-pair
``cv2.compareHist`` loop, measured in the same run.

Run: ``.venv/bin/python benchmarks/bench_road_values.py [--rounds 3]`` — prints a table and writes
``benchmarks/results/road_values.json``. Each bin count is measured with OpenCV's default thread
count and again pinned to one thread (both sides), since the grid histograms use a second thread
only when OpenCV may.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import time
from pathlib import Path

import cv2
import numpy as np

from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import patch_library, synthetic_frames

RESULTS = Path(__file__).resolve().parent / "results" / "road_values.json"
CHANNELS = [(0, 256), (1, 256), (2, 256), (0, 180), (1, 256)]  # plane, range: R G B H S


def rendered_frames(n: int, seed: int) -> list[np.ndarray]:
    """Frames from the simulated camera if the renderer is installed, else []."""
    try:
        from lfd_track.render.camera import CameraRenderer
        from lfd_track.render.texture import AppearanceConfig, LightingConfig, build_ground
        from lfd_track.world.track import load_track
    except ImportError:
        return []
    rng = np.random.default_rng(seed)
    ground = build_ground(load_track("testing"), AppearanceConfig(), LightingConfig(), rng)
    renderer = CameraRenderer()
    renderer.reset(rng)
    return [
        renderer.render(ground, np.array([0.3 + 0.3 * i, 0.0, rng.uniform(-0.5, 0.5)]), rng)
        for i in range(n)
    ]


def full_library(frames: list[np.ndarray], bins: int, rng: np.random.Generator) -> RoadLibrary:
    """10 types x 10 examples from random 50 x 50 patches of the frames."""
    return patch_library(frames, bins, rng)


def naive_road_values(frame: np.ndarray, models: list[list[np.ndarray]], bins: int) -> np.ndarray:
    """Algorithm 2 the direct way: OpenCV per region, per type, per example, per channel."""
    hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV)
    values = np.empty(40)
    for region in range(40):
        row, col = divmod(region, 8)
        rows, cols = slice(row * 96, (row + 1) * 96), slice(col * 80, (col + 1) * 80)
        hists = []
        for c, (plane, upper) in enumerate(CHANNELS):
            image = frame if c < 3 else hsv
            hist = cv2.calcHist([image[rows, cols]], [plane], None, [bins], [0, upper])
            hists.append(cv2.normalize(hist, None, 0, 1, cv2.NORM_MINMAX))
        best = -np.inf
        for examples in models:
            for example in examples:
                corr = 0.0
                for c in range(5):
                    corr += cv2.compareHist(hists[c], example[c], cv2.HISTCMP_CORREL)
                corr /= 5
                if corr > best:
                    best = corr
        values[region] = best
    return values


def timed(fn, repeats: int) -> float:
    best = np.inf
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def measure(library: RoadLibrary, models, bins: int, frames, threads: int) -> dict:
    """Best-of-repeats time per frame for both sides with OpenCV limited to ``threads``."""
    cv2.setNumThreads(threads)
    naive_s = timed(lambda: [naive_road_values(f, models, bins) for f in frames], 3)
    fast_s = timed(lambda: [library.road_values(f) for f in frames], 10)
    return {
        "naive_ms_per_frame": 1e3 * naive_s / len(frames),
        "vectorised_ms_per_frame": 1e3 * fast_s / len(frames),
        "speedup": naive_s / fast_s,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=3, help="measurement rounds (median kept)")
    args = parser.parse_args()
    default_threads = cv2.getNumThreads()
    rng = np.random.default_rng(0)
    frames = synthetic_frames(rng, 8) + rendered_frames(4, seed=1)
    rows = []
    for bins in (16, 32, 256):
        library = full_library(frames, bins, rng)
        data = library.to_dict()["types"]
        models = [[np.asarray(e["model"], np.float32) for e in t["examples"]] for t in data]
        max_diff = max(
            float(
                np.abs(
                    library.road_values(f, update_statistics=False)
                    - naive_road_values(f, models, bins)
                ).max()
            )
            for f in frames
        )
        for threads in sorted({default_threads, 1}, reverse=True):
            rounds = [measure(library, models, bins, frames, threads) for _ in range(args.rounds)]
            cv2.setNumThreads(default_threads)
            speedups = [r["speedup"] for r in rounds]
            rows.append(
                {
                    "bins": bins,
                    "opencv_threads": threads,
                    "frames": len(frames),
                    "naive_ms_per_frame": float(
                        np.median([r["naive_ms_per_frame"] for r in rounds])
                    ),
                    "vectorised_ms_per_frame": float(
                        np.median([r["vectorised_ms_per_frame"] for r in rounds])
                    ),
                    "speedup": float(np.median(speedups)),
                    "speedup_rounds": speedups,
                    "max_abs_difference": max_diff,
                }
            )
    print(
        f"{'bins':>5} {'threads':>7} {'naive ms':>10} {'ours ms':>9} {'speedup':>8}"
        f" {'rounds':>18} {'max |diff|':>11}"
    )
    for r in rows:
        each = "/".join(f"{x:.1f}" for x in r["speedup_rounds"])
        print(
            f"{r['bins']:>5} {r['opencv_threads']:>7} {r['naive_ms_per_frame']:>10.2f}"
            f" {r['vectorised_ms_per_frame']:>9.2f} {r['speedup']:>7.1f}x {each:>18}"
            f" {r['max_abs_difference']:>11.1e}"
        )
    result = {
        "benchmark": "road_values_full_library",
        "library": "10 types x 10 examples",
        "frame": "640x480 RGB",
        "target": "speedup >= 10 at equal values (1e-6)",
        "method": (
            "per round: naive best of 3 passes, ours best of 10 passes over the same frames in"
            " the same process; rows give the median over rounds; opencv_threads is"
            " cv2.setNumThreads for both sides (ours uses a second thread only when it is > 1)"
        ),
        "machine": {
            "python": platform.python_version(),
            "processor": platform.machine(),
            "cpus": os.cpu_count(),
            "load_average_at_end": list(os.getloadavg()),
            "opencv": cv2.__version__,
            "numpy": np.__version__,
        },
        "rows": rows,
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
