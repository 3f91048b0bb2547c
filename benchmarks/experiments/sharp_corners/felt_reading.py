"""Part 78 of ``README.md``: where the map's felt reading parts from the floor's true felt.

Part 77 found that the true felt at the regions' centres, in place of the road values read by
the levels 0.3 and 0.5, wins 7 of the 14 laps the goal's map loses on the rooms' own laps and
loses 3. This measurement says where the reading errs. Each repetition named is taught and its
loop laps driven as ``hairpin_trace.py --loops-from`` does, on the goal's own map (nothing
changed), and at every frame the map sees, each region's road value, the felt level the map
makes of it, and whether the floor under the region's centre is felt by the rover's true pose
are recorded, with the region's row and the light the room's floor gets there (the renderer's
baked light at that floor point, 1 = the room's ambient light with no pool or shadow). Per
room it tallies the regions the map reads as felt (level 0.5 or more) against the truth, by row
and by light, and the road values' spread on each side.

A measurement on validation rooms and loops only: nothing is chosen on it, and it drives no
test loop.

    .venv/bin/python benchmarks/experiments/sharp_corners/felt_reading.py --study benchmarks/experiments/human_goal/round44/edge_cover.toml --loops-from benchmarks/experiments/human_goal/round41/results/prior/rooms.round39+prior --seed 100 101 --repetition 0 1 2 3 4 5 6 7 8 9 --workers 2 --out benchmarks/experiments/sharp_corners/results/tip_cover/felt_reading.md
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import hairpin_trace  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402
import true_senses  # noqa: E402

from lfd_track.policy.memory import CARPET_LEVEL, FELT_LEVEL  # noqa: E402

#: the frames seen in this process: (road values (40,), true felt (40,) bool, light (40,))
SEEN: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []
#: light bands: a region's floor light below each edge (a fraction of the ambient light)
LIGHT_EDGES = (0.7, 0.9, 1.1)


#: the env the lap is driven in (set by the patched reset)
ENV: dict[str, Any] = {}
_reset = oracle_visited.reset


def floor_light(env: Any, floor: np.ndarray) -> np.ndarray:
    """(N,) the baked light the room's floor gets at ``floor`` points (N, 2) [m], relative to
    its ambient light (NaN where the env has no ground to read)."""
    # the env keeps its room's floor to itself (no public accessor): a measurement reads it
    ground = getattr(env, "_ground", None)
    if ground is None:
        return np.full(len(floor), np.nan)
    ambient = float(env.preset.lighting.ambient)
    return np.asarray(ground.illumination_at(floor), dtype=np.float64) / ambient


class ReadingMemory(oracle_learner.PrototypeMemory):
    """The goal's map as it is, recording each frame's reading against the true felt."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        now = oracle_visited.NOW
        if now["track"] is not None and now["pose"] is not None:
            floor = oracle_visited.to_floor(self._region_points, now["pose"])
            truth = now["track"].on_felt(floor)
            light = floor_light(ENV.get("env"), floor)
            SEEN.append((np.array(values, dtype=np.float64), truth, light))
        super().see(values, levels)


def _remember_env(self: Any, **kw: Any) -> Any:
    ENV["env"] = self
    return _reset(self, **kw)


def measure(job: tuple[str, int, int]) -> dict[str, Any]:
    """Teach and drive one repetition's loop laps; its frames' tallies."""
    study, seed, repetition = job
    SEEN.clear()
    hairpin_trace.trace_repetition((study, seed, repetition, 0.0, False))
    values = np.array([v for v, _, _ in SEEN])
    truth = np.array([t for _, t, _ in SEEN])
    light = np.array([li for _, _, li in SEEN])
    level = np.clip((values - CARPET_LEVEL) / (FELT_LEVEL - CARPET_LEVEL), 0.0, 1.0)
    read = level >= 0.5
    rows = np.broadcast_to(np.repeat(np.arange(5), 8), values.shape)
    out: dict[str, Any] = {"seed": seed, "repetition": repetition, "frames": len(values)}
    out["felt_read_carpet"] = int((truth & ~read).sum())
    out["carpet_read_felt"] = int((~truth & read).sum())
    out["felt"] = int(truth.sum())
    out["carpet"] = int((~truth).sum())
    out["by_row"] = [
        [int((truth & ~read & (rows == r)).sum()), int((truth & (rows == r)).sum())]
        + [int((~truth & read & (rows == r)).sum()), int((~truth & (rows == r)).sum())]
        for r in range(5)
    ]
    bands = np.digitize(light, LIGHT_EDGES)
    out["by_light"] = [
        [int((truth & ~read & (bands == b)).sum()), int((truth & (bands == b)).sum())]
        + [int((~truth & read & (bands == b)).sum()), int((~truth & (bands == b)).sum())]
        for b in range(len(LIGHT_EDGES) + 1)
    ]
    out["felt_values"] = [float(q) for q in np.percentile(values[truth], [5, 25, 50])]
    out["carpet_values"] = [float(q) for q in np.percentile(values[~truth], [50, 75, 95])]
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", required=True)
    parser.add_argument("--loops-from", required=True, metavar="FOLDER")
    parser.add_argument("--seed", type=int, nargs="+", required=True)
    parser.add_argument("--repetition", type=int, nargs="+", required=True)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    hairpin_trace.LOOPS_FROM = args.loops_from
    true_senses.use_true_pose()
    from lfd_track.envs.track_env import LfDTrackEnv

    LfDTrackEnv.reset = _remember_env  # type: ignore[method-assign]
    oracle_visited.maps_made_as(ReadingMemory)
    jobs = [(args.study, s, r) for s in args.seed for r in args.repetition]
    with multiprocessing.get_context("fork").Pool(args.workers) as pool:
        rooms = pool.map(measure, jobs, chunksize=1)
    lines = [
        "# Where the goal's map reads felt against the floor's true felt (part 78)",
        "",
        "Every frame the goal's map saw while each room was taught and its loop laps driven"
        " (`felt_reading.py`); a region reads felt where its felt level (road value by the levels"
        f" {CARPET_LEVEL:g} and {FELT_LEVEL:g}) is 0.5 or more; the truth is the floor under its"
        " centre. Road values: felt's 5th/25th/50th percentiles, carpet's 50th/75th/95th.",
        "",
        "| room | frames | felt read carpet | carpet read felt | felt values | carpet values |",
        "|---|---|---|---|---|---|",
    ]
    for room in rooms:
        fv = "/".join(f"{v:.2f}" for v in room["felt_values"])
        cv = "/".join(f"{v:.2f}" for v in room["carpet_values"])
        lines.append(
            f"| {room['seed']}/{room['repetition']} | {room['frames']} |"
            f" {room['felt_read_carpet']}/{room['felt']}"
            f" ({100 * room['felt_read_carpet'] / max(1, room['felt']):.1f} %) |"
            f" {room['carpet_read_felt']}/{room['carpet']}"
            f" ({100 * room['carpet_read_felt'] / max(1, room['carpet']):.1f} %) | {fv} | {cv} |"
        )
    by_row = np.sum([room["by_row"] for room in rooms], axis=0)
    by_light = np.sum([room["by_light"] for room in rooms], axis=0)
    lines += [
        "",
        "All rooms, by the region's row (0 the farthest) and by the floor's light there:",
        "",
        "| row | felt read carpet | carpet read felt |",
        "|---|---|---|",
        *(
            f"| {r} | {a}/{b} ({100 * a / max(1, b):.1f} %) | {c}/{d} ({100 * c / max(1, d):.1f} %) |"
            for r, (a, b, c, d) in enumerate(by_row)
        ),
        "",
        "| light (of the ambient) | felt read carpet | carpet read felt |",
        "|---|---|---|",
        *(
            f"| {name} | {a}/{b} ({100 * a / max(1, b):.1f} %) |"
            f" {c}/{d} ({100 * c / max(1, d):.1f} %) |"
            for name, (a, b, c, d) in zip(
                ("below 0.7", "0.7-0.9", "0.9-1.1", "above 1.1"), by_light, strict=True
            )
        ),
    ]
    Path(args.out).write_text("\n".join(lines) + "\n", encoding="utf-8")
    Path(args.out).with_suffix(".json").write_text(json.dumps(rooms, indent=1), encoding="utf-8")
    print("\n".join(lines))


if __name__ == "__main__":
    main()
