"""The map's motion per command: nominal, calibrated and measured from the camera, against the
simulated rover's true motion, in the paper world and with more slip.

The ``fresh_felt`` map moves what it remembers by a motion per executed command. Today that is
the nominal motion (the world's forward step and pivot) or a calibration's measurement of it; a
rover whose treads slip moves differently at each command. This measures, per command, how far
each motion the map could use lies from the rover's true motion (the env's ground-truth pose):

* **nominal**: the world's forward step (forward speed x control period) and pivot (pivot rate
  x control period), no turn on a forward command and no shift on a pivot;
* **calibrated**: the same with the step and pivot a calibration measures in that world
  (``lfd_track.methods.common.simulated_calibration``, the routine ``lfd-track hardware
  calibrate --sim`` runs, from seed 0);
* **visual**: the motion :class:`~lfd_track.policy.odometry.FloorOdometry` measures between the
  frame before and the frame after the command, started from the nominal motion, and the
  nominal motion where the estimate is not reliable (what a map with ``motion = "visual"``
  uses); the share of commands where it fell back is reported.

Worlds: the paper world (slip noise std 0.03) and the same with slip noise std 0.05 and 0.10 (the
sweeps' slip point, ``presets/slip.toml``). Drives: the centreline driver (pure pursuit on the
known track) with one command in seven drawn at random (so pivots both ways and off-centre
views occur), on the training track and the procedural loop ``random:validation:0``,
``--commands`` commands each (a new episode, the next seed, where one ends).

Reported per world and command kind: the forward step error (forward commands), the turn error
(pivots; and the heading a forward command turns, which the nominal motion takes as 0), median
and 90th percentile of the absolute error; the heading and position error of the map's pose
accumulated over 10 consecutive commands (every window of 10 within an episode); and the
estimator's time per frame (the floor view) and per pair (the registration), one thread.

Writes ``results/odometry.json`` and ``results/odometry.md``; about 2 minutes on one core.

    .venv/bin/python benchmarks/experiments/robustness/odometry.py
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from lfd_track.envs.presets import Preset, load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.methods.common import simulated_calibration
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.policy.odometry import FloorOdometry, PlanarMotion
from lfd_track.world.driver import CentrelineDriver, DriverConfig

HERE = Path(__file__).resolve().parent
OUT = HERE / "results"
TRACKS = ("training", "random:validation:0")
SLIPS = (None, 0.05, 0.10)  # None: the paper world's own (0.03)
WINDOW = 10  # commands over which the accumulated error is measured
RANDOM_SHARE = 1.0 / 7.0  # commands drawn at random instead of the driver's
KINDS = ("forward", "left", "right")


def _world(slip: float | None) -> Preset:
    paper = load_preset("paper")
    if slip is None:
        return paper
    rover = dataclasses.replace(paper.rover, slip_noise_std=slip)
    return dataclasses.replace(paper, name=f"paper-slip-{slip:g}", rover=rover)


def _nominal(geometry: MapGeometry) -> dict[int, PlanarMotion]:
    return {
        0: PlanarMotion(geometry.step_m, 0.0, 0.0),
        1: PlanarMotion(0.0, 0.0, geometry.pivot_deg),
        2: PlanarMotion(0.0, 0.0, -geometry.pivot_deg),
    }


def _drive(
    world: Preset, track: str, commands: int, odometry: FloorOdometry, nominal: dict
) -> list[dict[str, Any]]:
    """Drive ``commands`` commands and measure each: the true motion, the visual estimate and
    its timing. Each record carries its episode's number (windows stay within one)."""
    env = LfDTrackEnv(track=track, preset=world)
    rng = np.random.default_rng(0)
    records: list[dict[str, Any]] = []
    episode = 0
    frame, info = env.reset(seed=episode)
    driver = CentrelineDriver(env.track, DriverConfig())
    start = time.perf_counter()
    view = odometry.view(frame)
    view_s = [time.perf_counter() - start]
    while len(records) < commands:
        pose = np.array(info["pose"])
        command = int(driver.act(pose, info["progress_m"]))
        if rng.random() < RANDOM_SHARE:
            command = int(rng.integers(3))
        frame, _, terminated, truncated, info = env.step(command)
        start = time.perf_counter()
        after = odometry.view(frame)
        middle = time.perf_counter()
        found = odometry.motion(view, after, nominal[command])
        end = time.perf_counter()
        view_s.append(middle - start)
        truth = PlanarMotion.from_poses(pose, np.array(info["pose"]))
        records.append(
            {
                "episode": episode,
                "command": command,
                "true": dataclasses.astuple(truth),
                "visual": dataclasses.astuple(found.motion),
                "reliable": found.reliable,
                "correlation": found.correlation,
                "texture": found.texture,
                "motion_s": end - middle,
            }
        )
        view = after
        if terminated or truncated:
            episode += 1
            frame, info = env.reset(seed=episode)
            driver = CentrelineDriver(env.track, DriverConfig())
            view = odometry.view(frame)
    env.close()
    for record, seconds in zip(records, view_s[1:], strict=True):
        record["view_s"] = seconds
    return records


def _compose(motions: list[tuple[float, float, float]]) -> np.ndarray:
    """The pose (x, y, heading [deg]) after ``motions`` in turn, from the origin."""
    pose = np.eye(3)
    for forward, left, turn in motions:
        pose = pose @ PlanarMotion(forward, left, turn).matrix()
    return np.array([pose[0, 2], pose[1, 2], math.degrees(math.atan2(pose[1, 0], pose[0, 0]))])


def _stats(values: list[float]) -> dict[str, float]:
    array = np.abs(np.asarray(values, dtype=np.float64))
    return {
        "median": float(np.median(array)),
        "p90": float(np.percentile(array, 90)),
        "n": int(len(array)),
    }


def _summary(records: list[dict[str, Any]], motions: dict[str, dict[int, PlanarMotion]]) -> dict:
    """Error statistics of each motion source (``nominal``, ``calibrated``, ``visual``)."""

    def used(source: str, record: dict[str, Any]) -> tuple[float, float, float]:
        if source == "visual" and record["reliable"]:
            return tuple(record["visual"])
        return dataclasses.astuple(
            motions["nominal" if source == "visual" else source][record["command"]]
        )

    out: dict[str, Any] = {}
    for source in ("nominal", "calibrated", "visual"):
        errors = {
            kind: np.array(
                [np.subtract(used(source, r), r["true"]) for r in records if r["command"] == index]
            ).reshape(-1, 3)
            for index, kind in enumerate(KINDS)
        }
        pivots = np.concatenate([errors["left"], errors["right"]])
        heading, position = [], []
        for first in range(len(records) - WINDOW + 1):
            window = records[first : first + WINDOW]
            if window[0]["episode"] != window[-1]["episode"]:
                continue
            truth = _compose([tuple(r["true"]) for r in window])
            belief = _compose([used(source, r) for r in window])
            heading.append(math.remainder(belief[2] - truth[2], 360.0))
            position.append(math.hypot(belief[0] - truth[0], belief[1] - truth[1]))
        out[source] = {
            "forward_step_m": _stats(list(errors["forward"][:, 0])),
            "forward_turn_deg": _stats(list(errors["forward"][:, 2])),
            "pivot_turn_deg": _stats(list(pivots[:, 2])),
            "pivot_shift_m": _stats(list(np.hypot(pivots[:, 0], pivots[:, 1]))),
            f"heading_{WINDOW}_deg": _stats(heading),
            f"position_{WINDOW}_m": _stats(position),
        }
    reliable = [r["reliable"] for r in records]
    out["visual"]["fallback_share"] = 1.0 - float(np.mean(reliable))
    out["visual"]["view_ms"] = _stats([1000.0 * r["view_s"] for r in records])
    out["visual"]["motion_ms"] = _stats([1000.0 * r["motion_s"] for r in records])
    out["texture_min"] = float(min(r["texture"] for r in records))
    return out


def _table(results: dict[str, Any]) -> str:
    lines = [
        "# The map's motion per command against the true motion",
        "",
        "Written by `benchmarks/experiments/robustness/odometry.py` (its docstring gives the"
        " protocol). Absolute errors, median / 90th percentile; over 10 commands: the map's pose"
        " after 10 consecutive commands against the true one. Visual: the camera's estimate,"
        " the nominal motion where it is not reliable.",
        "",
        "| world | motion | forward step [mm] | forward turn [deg] | pivot [deg] | pivot shift"
        " [mm] | heading over 10 [deg] | position over 10 [mm] |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for world, found in results["worlds"].items():
        for source in ("nominal", "calibrated", "visual"):
            row = found["summary"][source]

            def cell(key: str, scale: float = 1.0, row: dict = row) -> str:
                return f"{scale * row[key]['median']:.2f} / {scale * row[key]['p90']:.2f}"

            lines.append(
                f"| {world} | {source} | {cell('forward_step_m', 1000)} |"
                f" {cell('forward_turn_deg')} | {cell('pivot_turn_deg')} |"
                f" {cell('pivot_shift_m', 1000)} | {cell(f'heading_{WINDOW}_deg')} |"
                f" {cell(f'position_{WINDOW}_m', 1000)} |"
            )
    lines += [
        "",
        "| world | commands (forward / left / right) | calibrated step, pivot | visual fell back"
        " | floor view [ms] | registration [ms] | least texture |",
        "|---|---|---|---|---|---|---|",
    ]
    for world, found in results["worlds"].items():
        visual = found["summary"]["visual"]
        counts = " / ".join(str(found["commands"][k]) for k in KINDS)
        lines.append(
            f"| {world} | {counts} | {found['calibrated_step_m']:.4f} m,"
            f" {found['calibrated_pivot_deg']:.2f} deg | {100 * visual['fallback_share']:.1f} %"
            f" | {visual['view_ms']['median']:.2f} / {visual['view_ms']['p90']:.2f}"
            f" | {visual['motion_ms']['median']:.2f} / {visual['motion_ms']['p90']:.2f}"
            f" | {found['summary']['texture_min']:.1f} |"
        )
    lines += ["", f"Total CPU time {results['cpu_s']:.0f} s; OpenCV on one thread.", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--commands", type=int, default=200, help="commands per world and track")
    args = parser.parse_args()
    cv2.setNumThreads(1)
    start = time.process_time()
    results: dict[str, Any] = {"commands_per_track": args.commands, "tracks": list(TRACKS)}
    worlds: dict[str, Any] = {}
    for slip in SLIPS:
        world = _world(slip)
        name = "paper (slip 0.03)" if slip is None else f"slip {slip:g}"
        geometry = MapGeometry.from_preset(world)
        calibration = simulated_calibration(world, seed=0).geometry
        motions = {
            "nominal": _nominal(geometry),
            "calibrated": _nominal(calibration),
        }
        odometry = FloorOdometry(geometry)
        records: list[dict[str, Any]] = []
        for offset, track in enumerate(TRACKS):
            driven = _drive(world, track, args.commands, odometry, motions["nominal"])
            for record in driven:  # episodes numbered apart per track
                record["episode"] += 1000 * offset
            records += driven
        worlds[name] = {
            "slip_noise_std": world.rover.slip_noise_std,
            "nominal_step_m": geometry.step_m,
            "nominal_pivot_deg": geometry.pivot_deg,
            "calibrated_step_m": calibration.step_m,
            "calibrated_pivot_deg": calibration.pivot_deg,
            "commands": {k: sum(r["command"] == i for r in records) for i, k in enumerate(KINDS)},
            "summary": _summary(records, motions),
        }
        print(name, json.dumps(worlds[name]["summary"]["visual"]["heading_10_deg"]), flush=True)
    results["worlds"] = worlds
    results["cpu_s"] = time.process_time() - start
    OUT.mkdir(exist_ok=True)
    (OUT / "odometry.json").write_text(json.dumps(results, indent=1) + "\n", encoding="utf-8")
    (OUT / "odometry.md").write_text(_table(results), encoding="utf-8")
    print(_table(results))


if __name__ == "__main__":
    main()
