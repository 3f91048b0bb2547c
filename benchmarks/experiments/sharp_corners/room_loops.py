"""Part 56 of ``README.md``, beside the pins: is a room's shortfall its world or its loops?

For every repetition of the committed study results given (``--results``, folders of
``seed*/results.json`` of one condition), the room's loop laps beside what its draw put in it:
how many of its loops have a sharpest turn past 135 degrees and past 150 degrees, and the room's
white-balance cast, noise and camera height (its world, ``runner.repetition_preset`` under the
study file's condition). Rank correlations (Spearman) of the loop laps with each, over all the
rooms. Reads committed results only.

    .venv/bin/python benchmarks/experiments/sharp_corners/room_loops.py --study benchmarks/experiments/sharp_corners/trials/goal41_validation.toml --results benchmarks/experiments/human_goal/round41/results/prior/rooms.round39+prior benchmarks/experiments/sharp_corners/results/goal41_again/rooms.round39+prior --out benchmarks/experiments/sharp_corners/results/room_loops.md
"""

from __future__ import annotations

import argparse
import json
import sys
from collections import defaultdict
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "human_goal"))

from room_measures import spearman  # noqa: E402

from lfd_track.benchmark import runner  # noqa: E402
from lfd_track.study.spec import load_study  # noqa: E402
from lfd_track.world.loops import sharpest_turn_deg  # noqa: E402
from lfd_track.world.track import load_track  # noqa: E402


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", required=True, help="the study file the rooms are drawn by")
    parser.add_argument("--results", nargs="+", required=True, help="condition folders")
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    study = load_study(args.study)
    config = study.conditions[0].config
    sharp: dict[str, float] = {}
    lines = [
        "# A room's loop laps beside its loops and its world (room_loops.py)",
        "",
        "| run | room (seed, repetition) | loop laps | loops > 135° | loops > 150° | cast | noise"
        " | camera height (m) |",
        "|---|---|---|---|---|---|---|---|",
    ]
    columns: dict[str, list[float]] = defaultdict(list)
    for folder in args.results:
        for results in sorted(Path(folder).glob("seed*/results.json")):
            data = json.loads(results.read_text(encoding="utf-8"))
            seed = int(data["seed"])
            seeds = runner.repetition_seeds(seed, int(data["repetitions"]))
            laps: dict[int, int] = defaultdict(int)
            loops: dict[int, set[str]] = defaultdict(set)
            for o in data["outcomes"]:
                if o["track"].startswith("random"):
                    laps[o["repetition"]] += bool(o["success"])
                    loops[o["repetition"]].add(o["track"])
            for rep in sorted(laps):
                for name in loops[rep]:
                    if name not in sharp:
                        sharp[name] = sharpest_turn_deg(load_track(name))
                over135 = sum(sharp[n] > 135 for n in loops[rep])
                over150 = sum(sharp[n] > 150 for n in loops[rep])
                room = runner.repetition_preset(config, seeds[rep])
                cast = room.sensor.white_balance_cast
                noise, height = room.sensor.noise_std, room.camera.height_m
                for key, value in (
                    ("laps", laps[rep]),
                    ("over135", over135),
                    ("over150", over150),
                    ("cast", cast),
                    ("noise", noise),
                    ("height", height),
                ):
                    columns[key].append(float(value))
                lines.append(
                    f"| {Path(folder).parent.name} | {seed}, {rep} | {laps[rep]}/{2 * len(loops[rep])}"
                    f" | {over135} | {over150} | {cast:.3f} | {noise:.1f} | {height:.3f} |"
                )
    lines += ["", "| loop laps against | Spearman, all rows |", "|---|---|"]
    for key, label in (
        ("over135", "loops > 135°"),
        ("over150", "loops > 150°"),
        ("cast", "white-balance cast"),
        ("noise", "noise"),
        ("height", "camera height"),
    ):
        lines.append(
            f"| {label} | {spearman(np.asarray(columns['laps']), np.asarray(columns[key])):+.2f} |"
        )
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
