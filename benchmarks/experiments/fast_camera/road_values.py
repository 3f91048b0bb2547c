"""Road values of the same poses through the full (640 x 480) and the half (320 x 240) camera.

The protocol and the tolerance are in README.md beside this file (fixed before the first run):
the poses of the seed-0 demonstration (training track) and 200 random poses on the testing track,
each rendered through both cameras on the same painted floor with the exposure settled on that
view; |road value (full) - road value (half)| per region with (1) the demonstration's library for
both, (2) each camera's own library learned along the same demonstration, and (3) as a baseline,
the full camera against itself with another sensor draw.

    .venv/bin/python benchmarks/experiments/fast_camera/road_values.py [--poses 200] [--out DIR]

``--half-floor-metres-per-px M`` paints the half camera's floors (its demonstration's and the
compared poses', from the same seeds) at ``M`` metres per texel instead of ``paper_fast``'s own,
set past the preset's 2 mm check on a copy of it: the measurement of floors at 4 mm
(README.md, "Floors at 4 mm"; ``results/floor_4mm/``).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np

from lfd_track.dataset.reader import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.render.camera import CameraRenderer
from lfd_track.render.texture import build_ground
from lfd_track.vision.grid import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.track import load_track

HERE = Path(__file__).resolve().parent
#: The tolerance README.md states: mean and 95th percentile of |difference| over poses and regions.
MEAN_BOUND = 0.05
P95_BOUND = 0.15
#: Random poses on the testing track: across the centreline [m] and off its heading [deg].
ACROSS_M = 0.10
HEADING_DEG = 25.0
#: Seeds of the painted floors (one per track) and of the sensors' draws.
WORLD_SEED = {"training": 100, "testing": 101}
SENSOR_SEED, BASELINE_SEED = 1, 2


def demonstration(preset: Preset, folder: Path) -> tuple[np.ndarray, RoadLibrary]:
    """Poses (N, 3) and road library of the seed-0 demonstration under ``preset``."""
    path = folder / f"demo_{preset.name}.lfdemo"
    run_demonstration(path, seed=0, track="training", preset=preset, fsync=False)
    demo = load_demonstration(path)
    return np.asarray(demo.poses), demo.road_library()


def random_poses(count: int, seed: int) -> np.ndarray:
    """``count`` poses on the testing track: uniform along it, near its centreline and heading."""
    track = load_track("testing")
    rng = np.random.default_rng(seed)
    poses = np.empty((count, 3))
    for i in range(count):
        point, heading = track.point_at(float(rng.uniform(0.0, track.length_m)))
        across = float(rng.uniform(-ACROSS_M, ACROSS_M))
        normal = np.array([-math.sin(heading), math.cos(heading)])
        poses[i, :2] = np.asarray(point)[:2] + across * normal
        poses[i, 2] = heading + math.radians(float(rng.uniform(-HEADING_DEG, HEADING_DEG)))
    return poses


class Camera:
    """A renderer whose exposure settles on each pose it is shown (pools drawn once)."""

    def __init__(self, p: Preset, pools_seed: int, frames_seed: int) -> None:
        self.renderer = CameraRenderer(p.camera, p.sensor)
        self.renderer.reset(np.random.default_rng(pools_seed))
        self.frames_seed = frames_seed

    def frame(self, ground, pose: np.ndarray, index: int) -> np.ndarray:
        self.renderer.reset(np.random.default_rng(0), new_pools=False)  # forget the exposure
        return self.renderer.render(ground, pose, np.random.default_rng((self.frames_seed, index)))


def values(library: RoadLibrary, frame: np.ndarray) -> np.ndarray:
    return library.road_values(frame, update_statistics=False)


def summary(diff: np.ndarray) -> dict:
    """Distribution of |diff| (poses, 40): overall and per region."""
    a = np.abs(diff)
    return {
        "mean": round(float(a.mean()), 4),
        "p95": round(float(np.percentile(a, 95)), 4),
        "max": round(float(a.max()), 4),
        "mean_signed": round(float(diff.mean()), 4),
        "per_region_mean": [round(float(v), 4) for v in a.mean(axis=0)],
        "per_region_p95": [round(float(v), 4) for v in np.percentile(a, 95, axis=0)],
        "per_region_max": [round(float(v), 4) for v in a.max(axis=0)],
        "within_tolerance": bool(a.mean() <= MEAN_BOUND and np.percentile(a, 95) <= P95_BOUND),
    }


def grid_table(per_region: list[float]) -> list[str]:
    rows = ["| row \\ column | " + " | ".join(str(c) for c in range(GRID_COLUMNS)) + " |"]
    rows.append("|---" * (GRID_COLUMNS + 1) + "|")
    for r in range(GRID_ROWS):
        cells = per_region[r * GRID_COLUMNS : (r + 1) * GRID_COLUMNS]
        rows.append(f"| {r} | " + " | ".join(f"{v:.3f}" for v in cells) + " |")
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--poses", type=int, default=200, help="random testing-track poses")
    parser.add_argument("--out", type=Path, default=HERE / "results")
    parser.add_argument("--half-floor-metres-per-px", type=float, default=None)
    args = parser.parse_args()
    paper, fast = load_preset("paper"), load_preset("paper_fast")
    if args.half_floor_metres_per_px is not None:
        appearance = dataclasses.replace(fast.appearance)
        object.__setattr__(appearance, "metres_per_px", args.half_floor_metres_per_px)
        fast = dataclasses.replace(fast)
        object.__setattr__(fast, "appearance", appearance)
    cv2.setNumThreads(1)
    started = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        demo_poses, library_full = demonstration(paper, Path(tmp))
        _, library_half = demonstration(fast, Path(tmp))
    pose_sets = {
        "training: seed-0 demonstration": ("training", demo_poses),
        "testing: random poses": ("testing", random_poses(args.poses, 0)),
    }
    full = Camera(paper, SENSOR_SEED, SENSOR_SEED)
    half = Camera(fast, SENSOR_SEED, SENSOR_SEED)
    again = Camera(paper, BASELINE_SEED, BASELINE_SEED)
    results: dict = {
        "tolerance": {"mean": MEAN_BOUND, "p95": P95_BOUND},
        "floor_metres_per_px": {
            "full (paper)": paper.appearance.metres_per_px,
            "half (paper_fast)": fast.appearance.metres_per_px,
        },
        "libraries": {
            "full (paper)": {"types": library_full.n_types, "models": library_full.n_models},
            "half (paper_fast)": {"types": library_half.n_types, "models": library_half.n_models},
        },
        "pose_sets": {},
    }
    for name, (track_name, poses) in pose_sets.items():
        ground, ground_half = (
            build_ground(
                load_track(track_name),
                p.appearance,
                p.lighting,
                np.random.default_rng(WORLD_SEED[track_name]),
            )
            for p in (paper, fast)
        )  # each camera's floor as its preset paints it, from the same seed
        same, own, base = [], [], []
        for i, pose in enumerate(poses):
            f_full = full.frame(ground, pose, i)
            f_half = half.frame(ground_half, pose, i)
            f_again = again.frame(ground, pose, i)
            v_full = values(library_full, f_full)
            same.append(v_full - values(library_full, f_half))
            own.append(v_full - values(library_half, f_half))
            base.append(v_full - values(library_full, f_again))
        results["pose_sets"][name] = {
            "poses": len(poses),
            "same library": summary(np.array(same)),
            "own libraries": summary(np.array(own)),
            "baseline (full vs full, another sensor draw)": summary(np.array(base)),
        }
    results["seconds"] = round(time.perf_counter() - started, 1)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "road_values.json").write_text(json.dumps(results, indent=1) + "\n")
    lines = [
        "# Road values: full (640 x 480) against half (320 x 240) camera",
        "",
        "Written by `benchmarks/experiments/fast_camera/road_values.py` (rule in README.md):"
        f" |road value (full) - road value (half)| over {N_REGIONS} regions; tolerance: mean"
        f" <= {MEAN_BOUND}, 95th percentile <= {P95_BOUND}.",
        "",
        f"Libraries of the seed-0 demonstration: full camera {library_full.n_types} types /"
        f" {library_full.n_models} models, half camera {library_half.n_types} types /"
        f" {library_half.n_models} models.",
        *(
            [
                "",
                f"Floors painted at {paper.appearance.metres_per_px} m per texel for the full"
                f" camera and {fast.appearance.metres_per_px} m for the half camera (the same"
                " seeds).",
            ]
            if fast.appearance.metres_per_px != paper.appearance.metres_per_px
            else []
        ),
        "",
        "| poses | comparison | mean | 95th pct | max | mean signed (full - half) | within |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, entry in results["pose_sets"].items():
        for comparison in (
            "same library",
            "own libraries",
            "baseline (full vs full, another sensor draw)",
        ):
            s = entry[comparison]
            within = (
                "—"
                if comparison.startswith("baseline")
                else ("yes" if s["within_tolerance"] else "**no**")
            )
            lines.append(
                f"| {name} ({entry['poses']}) | {comparison} | {s['mean']:.3f} | {s['p95']:.3f} |"
                f" {s['max']:.3f} | {s['mean_signed']:+.3f} | {within} |"
            )
    for name, entry in results["pose_sets"].items():
        for comparison in ("same library", "own libraries"):
            lines += ["", f"Mean |difference| per region, {name}, {comparison} (row 0 = top):", ""]
            lines += grid_table(entry[comparison]["per_region_mean"])
    lines += ["", f"{results['seconds']} s on one thread."]
    (args.out / "road_values.md").write_text("\n".join(lines) + "\n")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
