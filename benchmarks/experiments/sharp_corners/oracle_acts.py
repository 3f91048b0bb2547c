"""Part 71 of ``README.md``: where the track's visited felt first changes the goal's learner's
command, on the rooms' laps its own map loses.

Part 70: the goal's learner, taught on its own map, laps all 400 of round 41's validation rooms'
loop laps when driven on part 12's oracle (the track's visited felt, covering from 0.3 m behind
the rover's progress), and 386 on its own map. Each lap a ``hairpin_trace.py --loops-from``
record (``--lost``, the goal's map's) lost is driven again by the one learner taught on its own map
(each room taught once, as ``hairpin_trace.py`` teaches it), on its own map and on the oracle's, in
the lap's world: the two drives are the same until the first command they differ in. At that
frame the page gives where the rover is against the loop's nearest corner of 90° or more (its
progress past the corner's vertex, [m]), the two commands, and the felt the oracle's map covers
that the goal's map keeps fresh (within the map's reach, ahead of the axle; summed felt levels):
in the rover's frame (ahead, left [m]), along the track from that vertex (negative: the incoming
leg), to the corner's turn side of the centreline (negative: its outer side), and how far behind
the rover's progress the track puts it. With ``--windows N ...`` each lap is also driven on the goal's
map with the oracle's cover only for N frames from the one at which the two drives part (part 73):
whether that one decision decides the lap. A measurement on validation loops and rooms only; it
chooses nothing and drives no test loop.

    .venv/bin/python benchmarks/experiments/sharp_corners/oracle_acts.py --study benchmarks/experiments/human_goal/round44/edge_cover.toml --loops-from benchmarks/experiments/human_goal/round41/results/prior/rooms.round39+prior --lost benchmarks/experiments/sharp_corners/results/tip_cover/rooms_own.json --workers 2 --out benchmarks/experiments/sharp_corners/results/tip_cover/oracle_acts.md
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import multiprocessing
import sys
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import hairpin_trace  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402
import trace_rooms  # noqa: E402

from lfd_track.benchmark import runner  # noqa: E402
from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.policy.memory import BEHIND_M, memory_for  # noqa: E402
from lfd_track.study.spec import load_study  # noqa: E402
from lfd_track.teaching import perception as perception_module  # noqa: E402
from lfd_track.world.track import vertex_turns_rad  # noqa: E402

#: [deg] the corners the rover's place is given against
CORNER_DEG = 90.0

#: each frame the oracle's map saw in the drive under way: the rover's pose, and what it covers
FRAMES: list[dict[str, Any]] = []


class ShadowMemory(oracle_visited.TrackVisitedMemory):
    """Part 12's oracle map, noting at each frame the felt it covers that the goal's map keeps."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        pose = oracle_visited.NOW["pose"]
        record: dict[str, Any] = {"pose": tuple(pose), "taken": 0.0}
        FRAMES.append(record)
        points, felt = self._points, self._felt
        near = np.hypot(points[:, 0], points[:, 1]) < self.config.reach_m
        inside = near & (points[:, 0] > -BEHIND_M) & (felt > 0.0)
        own = super(oracle_visited.TrackVisitedMemory, self)._kept(inside)
        oracle = self._kept(inside)
        if own is None or oracle is None:
            return
        taken = (own - oracle) * felt * inside
        idx = np.flatnonzero(taken > 0.0)
        if len(idx):
            record.update(
                taken=float(taken.sum()),
                points=points[idx].tolist(),
                floor=oracle_visited.to_floor(points[idx], pose).tolist(),
            )


#: ``--windows``: the oracle's cover used only for this many frames, from the frame at which the
#: two drives first part (``start``, counted from the lap's first frame)
WINDOW = {"start": -1, "frames": 0}


class WindowMemory(oracle_visited.TrackVisitedMemory):
    """The goal's map, with part 12's oracle cover only in :data:`WINDOW`'s frames."""

    def reset(self) -> None:
        super().reset()
        self._frame = -1  # the frame being seen, counted from the lap's first

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._frame += 1
        super().see(values, levels)

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        if WINDOW["start"] <= self._frame < WINDOW["start"] + WINDOW["frames"]:
            return super()._kept(where)
        return super(oracle_visited.TrackVisitedMemory, self)._kept(where)


def corners(track: Any) -> list[tuple[float, float]]:
    """(arc length of the vertex [m], signed turn [deg]) of ``track``'s corners of
    :data:`CORNER_DEG` or more, in its driving order."""
    vertices = np.asarray(track.vertices, dtype=np.float64)
    turns = np.degrees(vertex_turns_rad(vertices, True))
    lengths = np.linalg.norm(np.diff(np.vstack([vertices, vertices[:1]]), axis=0), axis=1)
    arcs = np.concatenate([[0.0], np.cumsum(lengths)[:-1]])
    return [(float(arcs[k]), float(turns[k])) for k in range(len(turns)) if abs(turns[k]) >= 90]


def nearest(track: Any, arc: float) -> tuple[float, float]:
    """(``arc`` past the nearest corner's vertex [m], on a loop wrapped to within half its
    length; that corner's signed turn [deg])."""
    length = track.length_m
    best = min(corners(track), key=lambda c: abs((arc - c[0] + length / 2) % length - length / 2))
    return (arc - best[0] + length / 2) % length - length / 2, best[1]


def describe(track: Any, record: dict[str, Any], progress: float) -> dict[str, Any]:
    """The felt ``record`` says the oracle covers, placed (module docstring)."""
    past, turn = nearest(track, progress)
    out: dict[str, Any] = {"rover_past": past, "turn": turn, "taken": record["taken"]}
    if not record["taken"]:
        return out
    points, floor = np.array(record["points"]), np.array(record["floor"])
    arc = oracle_visited.centreline_at(track, floor)
    length = track.length_m
    vertex_arc = progress - past
    along = (arc - vertex_arc + length / 2) % length - length / 2
    side = np.empty(len(floor))
    for i, (s, p) in enumerate(zip(arc, floor, strict=True)):
        centre, heading = track.point_at(float(s))
        gap = p - centre
        side[i] = math.copysign(1.0, turn) * (
            math.cos(heading) * gap[1] - math.sin(heading) * gap[0]
        )
    out |= {
        "ahead": (float(points[:, 0].min()), float(points[:, 0].max())),
        "left": (float(points[:, 1].min()), float(points[:, 1].max())),
        "along": (float(along.min()), float(along.max())),
        "side": (float(side.min()), float(side.max())),
        "behind": (
            float(((progress - arc) % length).min()),
            float(((progress - arc) % length).max()),
        ),
    }
    return out


def drive(
    lap: tuple[str, bool, str, int], preset: Any, controller: Any, memory_class: type | None
) -> tuple[Any, list, list[dict[str, Any]], Any]:
    """Drive ``lap`` (track, reverse, direction, world seed) once on ``memory_class``'s maps
    (None: the goal's own); (last info, rows, the frames :class:`ShadowMemory` noted, the env's
    track)."""
    FRAMES.clear()
    if memory_class is None:
        perception_module.memory_for = memory_for
    else:
        oracle_visited.maps_made_as(memory_class)
    track_name, reverse, _, world = lap
    env = LfDTrackEnv(track=track_name, reverse=reverse, preset=preset)
    try:
        info, rows = hairpin_trace.trace_lap(env, controller, world)
        return info, rows, list(FRAMES), env.track
    finally:
        env.close()


def room(job: tuple[str, str, int, int, list[tuple[str, str]], list[int]]) -> list[dict[str, Any]]:
    """Teach one room on the goal's map and drive its ``lost`` laps on both maps (and, for each
    of ``windows``, on the goal's map with the oracle's cover for that many frames from where the
    two drives first part)."""
    study_file, folder, seed, repetition, lost, windows = job
    study = load_study(study_file)
    config = dataclasses.replace(study.conditions[0].config, repetitions=study.repetitions)
    config = dataclasses.replace(config, seed=seed)
    rep_seed = runner.repetition_seeds(seed, study.repetitions)[repetition]
    demo_seed, ga_seed, trial_seed = runner.repetition_streams(rep_seed)
    preset = runner.repetition_preset(config, rep_seed)
    perception_module.memory_for = memory_for
    with tempfile.TemporaryDirectory() as tmp:
        learned = runner.learn_repetition(
            config, Path(tmp), demo_seed=demo_seed, ga_seed=ga_seed, preset=preset
        )
    rows_out: list[dict[str, Any]] = []
    worlds = hairpin_trace.committed_loop_worlds(
        folder, seed, repetition, trial_seed, config.random_split
    )
    for lap in worlds:
        track_name, _, direction, _ = lap
        if (track_name, direction) not in lost:
            continue
        own_info, own_rows, _, _ = drive(lap, preset, learned.controller, None)
        or_info, or_rows, frames, track = drive(lap, preset, learned.controller, ShadowMemory)
        first = next(
            (
                k
                for k, (a, b) in enumerate(zip(own_rows, or_rows, strict=False))
                if a["command"] != b["command"]
            ),
            None,
        )
        row: dict[str, Any] = {"seed": seed, "repetition": repetition, "track": track_name}
        row |= {"direction": direction, "own": bool(own_info["success"])}
        row |= {"oracle": bool(or_info["success"]), "first": first}
        if first is not None:
            pose = or_rows[first]["pose"]
            same = own_rows[first]["pose"] == pose
            record = next((f for f in frames if f["pose"] == pose), {"taken": 0.0})
            row |= {"same_pose": same, "commands": (own_rows[first]["command"],)}
            row["commands"] += (or_rows[first]["command"],)
            row |= describe(track, record, float(or_rows[first]["progress"]))
            start = next((i for i, f in enumerate(frames) if f["pose"] == pose), None)
            row["windows"] = {}
            for frames_on in windows if start is not None else []:
                WINDOW.update(start=start, frames=frames_on)
                info = drive(lap, preset, learned.controller, WindowMemory)[0]
                row["windows"][frames_on] = bool(info["success"])
        rows_out.append(row)
    return rows_out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", required=True)
    parser.add_argument("--loops-from", required=True, metavar="FOLDER")
    parser.add_argument("--lost", required=True, help="hairpin_trace.py record whose lost laps")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument(
        "--windows",
        type=int,
        nargs="*",
        default=[],
        metavar="N",
        help="also drive each lap on the goal's map with the oracle's cover for N frames from"
        " where the two drives first part",
    )
    parser.add_argument("--out", required=True)
    args = parser.parse_args()
    lost_by_room: dict[tuple[int, int], list[tuple[str, str]]] = {}
    for (seed, repetition, track_name, direction), lapped in trace_rooms.load(args.lost).items():
        if not lapped:
            lost_by_room.setdefault((seed, repetition), []).append((track_name, direction))
    oracle_learner.use_oracle("cover", 0.3)
    jobs = [
        (args.study, args.loops_from, seed, repetition, lost, args.windows)
        for (seed, repetition), lost in sorted(lost_by_room.items())
    ]
    with multiprocessing.get_context("fork").Pool(args.workers) as pool:
        rows = [row for some in pool.map(room, jobs, chunksize=1) for row in some]
    letter = {0: "F", 1: "L", 2: "R"}

    def span(pair: Any) -> str:
        return "–" if pair is None else f"{pair[0]:+.2f} to {pair[1]:+.2f}"

    lines = [
        "# Where the track's visited felt first changes the goal's learner's command",
        "",
        f"`{Path(args.lost).name}`'s lost laps, each driven again by the learner taught on the"
        " goal's map, on that map and on part 12's oracle (`oracle_acts.py`); at the first"
        " command the two drives differ in: the rover against the nearest corner of 90° or more,"
        " the commands (own, oracle), and the felt the oracle covers that the goal's map keeps"
        " fresh [m]. `same`: the two drives' poses equal there.",
        "",
        "| room | loop | dir. | own | oracle | first | same | corner | rover past its vertex |"
        " commands | felt taken | ahead | left | along from the vertex | to the turn's side |"
        " behind the progress |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        head = (
            f"| {r['seed']}/{r['repetition']} | `{r['track']}` | {r['direction']} |"
            f" {'lapped' if r['own'] else 'lost'} | {'lapped' if r['oracle'] else 'lost'} |"
        )
        if r["first"] is None:
            lines.append(head + " – | – | – | – | – | – | – | – | – | – | – |")
            continue
        own_c, or_c = r["commands"]
        lines.append(
            head + f" {r['first']} | {'yes' if r['same_pose'] else 'no'} | {r['turn']:+.0f}° |"
            f" {r['rover_past']:+.2f} | {letter[own_c]} → {letter[or_c]} | {r['taken']:.1f} |"
            f" {span(r.get('ahead'))} | {span(r.get('left'))} | {span(r.get('along'))} |"
            f" {span(r.get('side'))} | {span(r.get('behind'))} |"
        )
    if args.windows:
        lines += [
            "",
            "Each lap again on the goal's map with the oracle's cover only for N frames from the"
            " one at which the two drives first part (`--windows`):",
            "",
            "| room | loop | dir. | " + " | ".join(f"{n} frames" for n in args.windows) + " |",
            "|---|---|---|" + "---|" * len(args.windows),
        ]
        for r in rows:
            done = r.get("windows", {})
            cells = " | ".join(
                "–" if n not in done else ("lapped" if done[n] else "lost") for n in args.windows
            )
            lines.append(
                f"| {r['seed']}/{r['repetition']} | `{r['track']}` | {r['direction']} | {cells} |"
            )
        lines += [
            "",
            "| lapped | " + " | ".join(f"{n} frames" for n in args.windows) + " |",
            "|---|" + "---|" * len(args.windows),
            "| of "
            + str(len(rows))
            + " | "
            + " | ".join(
                str(sum(bool(r.get("windows", {}).get(n)) for r in rows)) for n in args.windows
            )
            + " |",
        ]
    hairpin_trace.write_page(args.out, lines)
    Path(args.out).with_suffix(".json").write_text(json.dumps(rows, indent=1), encoding="utf-8")


if __name__ == "__main__":
    main()
