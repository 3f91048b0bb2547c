"""Does the episode's 0.30 m reversal margin end laps the map rule would go on with? (part 18 of
``README.md``)

Drives ``../generalization/rules.py`` unchanged (its arguments are passed on) with one change to
how the map rule's laps are judged: a lap fails as ``reversed`` only when progress falls more
than ``--reverse-margin M`` below its maximum, instead of the episode rules' 0.30 m. Everything
else is as it is: the road library's demonstration and the teacher's laps that admit each
procedural loop keep the 0.30 m margin, so the loops, rooms and libraries are the very ones of
the rule as it is, and a lap goes command for command as it did until the 0.30 m margin would
have ended it. So the laps won against the rule as it is are exactly those it would have lapped
had the 0.30 m margin not ended them.

For every such lap, the moment the 0.30 m margin would have ended it is recorded (``--events
FILE``, JSON lines, one per lap): the corner nearest the rover's greatest progress, its turn,
where the rover was then against that corner's vertex (along the track, metres; negative before
it) and the rover's heading against the track's direction at its progress (degrees; near 0 is
driving on along the track, near 180 driving back); and, in a second line with the same ``lap``,
how the lap ended under the wider margin (``lapped``, ``reversed`` or ``off_track``; no second
line: it ran out of commands) and the rover's poses over the whole lap (x, y, heading; the first
is the first after the start).

This is a measurement of the episode rule's reading, not a product setting: the benchmark's
episode rules (0.30 m) are unchanged. ``--seed-m M`` (part 23) also drives the rule on a map
whose own strip starts at the felt within M of the axle instead of 0.3 m.

    .venv/bin/python benchmarks/experiments/sharp_corners/margins.py --summary benchmarks/experiments/sharp_corners/results/margins/rooms_1.0/events.jsonl
    .venv/bin/python benchmarks/experiments/sharp_corners/margins.py --reverse-margin 1.0 --events benchmarks/experiments/sharp_corners/results/margins/rooms_1.0/events.jsonl --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --out benchmarks/experiments/sharp_corners/results/margins/rooms_1.0 --workers 2
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402

from lfd_track.benchmark import runner  # noqa: E402
from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402
from lfd_track.world.episode import EpisodeState, EpisodeTracker  # noqa: E402
from lfd_track.world.track import Track, load_track  # noqa: E402

#: [m] the episode rules' reversal margin, whose reading this script measures
EPISODE_MARGIN_M = 0.30
#: [m] ``--summary``: a rover this close to the corner's vertex is at the corner
NEAR_VERTEX_M = 0.65
#: whether the laps being driven now are the map rule's (judged with ``margin_m``) and the
#: wider margin; the output file of the 0.30 m events
NOW: dict[str, Any] = {"scoring": False, "margin_m": EPISODE_MARGIN_M, "events": None, "count": 0}

_update, _reset = EpisodeTracker.update, EpisodeTracker.reset
_teacher_lap = runner.teacher_lap


def corner_near(track: Track, progress_m: float) -> dict[str, Any]:
    """The corner whose vertex lies nearest ``progress_m`` along ``track`` (on a loop, either
    way round): its label and turn, and ``progress_m`` against its vertex [m]."""
    best: dict[str, Any] = {}
    for corner in track.corners:
        gap = progress_m - corner.s_m
        if track.closed:
            gap = (gap + 0.5 * track.length_m) % track.length_m - 0.5 * track.length_m
        if not best or abs(gap) < abs(best["from_vertex_m"]):
            best = {"corner": corner.label, "turn_deg": corner.turn_deg, "from_vertex_m": gap}
    return best


def update(self: EpisodeTracker, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> Any:
    if not NOW["scoring"]:
        return _update(self, pose, tread_on_felt)
    rules = self.rules
    self.rules = dataclasses.replace(rules, reverse_margin_m=NOW["margin_m"])
    try:
        st: EpisodeState = _update(self, pose, tread_on_felt)
    finally:
        self.rules = rules
    event = self.__dict__.get("_margin_event")
    poses = self.__dict__.setdefault("_margin_poses", [])
    poses.append([round(float(v), 3) for v in pose])
    if event is None and st.progress_m < st.max_progress_m - EPISODE_MARGIN_M:
        _, along = self.track.point_at(st.progress_m)
        back = math.degrees(pose[2] - along)
        event = corner_near(self.track, st.max_progress_m)
        NOW["count"] += 1
        event.update(
            lap=f"{os.getpid()}.{NOW['count']}",
            track=self.track.name,
            heading_deg=abs((back + 180.0) % 360.0 - 180.0),
            now_from_vertex_m=event["from_vertex_m"] - (st.max_progress_m - st.progress_m),
            pose=[float(v) for v in pose],
        )
        write(event)
        self._margin_event = event  # type: ignore[attr-defined]
    if event is not None and "end" not in event and (st.failure is not None or st.success):
        event["end"] = "lapped" if st.success else st.failure
        write({"lap": event["lap"], "end": event["end"], "poses": poses})
    return st


def write(record: dict[str, Any]) -> None:
    with open(f"{NOW['events']}.{os.getpid()}", "a") as out:
        out.write(json.dumps(record) + "\n")


def reset(self: EpisodeTracker, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> Any:
    self._margin_event = None  # type: ignore[attr-defined]
    self._margin_poses = []  # type: ignore[attr-defined]
    return _reset(self, pose, tread_on_felt)


def teacher_lap(env: Any, world_seed: int) -> dict[str, Any]:
    """The teacher's admission lap, judged by the episode rules as they are."""
    scoring, NOW["scoring"] = NOW["scoring"], False
    try:
        return _teacher_lap(env, world_seed)
    finally:
        NOW["scoring"] = scoring


def scored(function: Any) -> Any:
    def wrapped(*args: Any, **kwargs: Any) -> Any:
        NOW["scoring"] = True
        try:
            return function(*args, **kwargs)
        finally:
            NOW["scoring"] = False

    return wrapped


def read_laps(events: Path) -> dict[str, dict[str, Any]]:
    """The laps of ``events`` (the JSON lines this script writes), each line of a lap merged
    into one record, by the lap's key."""
    laps: dict[str, dict[str, Any]] = {}
    for line in events.read_text().splitlines():
        record = json.loads(line)
        laps.setdefault(record["lap"], {}).update(record)
    return laps


def vertex_of(name: str, label: str) -> np.ndarray:
    """(2,) [m] the vertex of the corner ``label`` of the track ``name``."""
    track = load_track(name)
    return next(track.vertices[c.vertex] for c in track.corners if c.label == label)


def progress_bin(from_vertex_m: float) -> str:
    """Where the rover's greatest progress lay against the nearest corner's vertex."""
    if from_vertex_m < -0.05:
        return "before it"
    return "0-0.35 m" if from_vertex_m <= 0.35 else "past 0.35 m"


def summary(events: Path) -> str:
    """A markdown table of ``events`` (the JSON lines this script writes): the laps the 0.30 m
    margin ends, by the turn of the corner nearest the rover's greatest progress and whether the
    rover still faced on along the track (heading under 90 degrees), and how many of each the
    wider margin lets lap."""
    laps = read_laps(events)
    rows: dict[tuple[str, str], list[int]] = {}
    for lap in laps.values():
        turn = abs(lap["turn_deg"])
        sharp = "100° or more" if turn >= 100.0 else "below 100°"
        facing = "on along the track" if lap["heading_deg"] < 90.0 else "turned back"
        row = rows.setdefault((sharp, facing), [0, 0])
        row[0] += 1
        row[1] += lap.get("end") == "lapped"
    out = ["| nearest corner | the rover at 0.30 m | laps ended | lapped with the wider margin |"]
    out.append("|---|---|---|---|")
    for (sharp, facing), (ended, lapped) in sorted(rows.items()):
        out.append(f"| {sharp} | {facing} | {ended} | {lapped} |")
    places: dict[tuple[str, str], int] = {}
    for lap in laps.values():
        near = math.dist(lap["pose"][:2], vertex_of(lap["track"], lap["corner"])) <= NEAR_VERTEX_M
        key = (
            progress_bin(lap["from_vertex_m"]),
            f"within {NEAR_VERTEX_M} m" if near else "further",
        )
        places[key] = places.get(key, 0) + 1
    out += [
        "",
        "| greatest progress against the vertex | the rover from the vertex at 0.30 m | laps |",
    ]
    out.append("|---|---|---|")
    out += [f"| {at} | {near} | {n} |" for (at, near), n in sorted(places.items())]
    return "\n".join(out) + "\n"


class SeedMemory(FreshFeltMemory):
    """The ``fresh_felt`` map whose own strip starts at the felt within ``NOW["seed_m"]`` of the
    axle (``--seed-m``; the map's own: 0.3 m, the camera's nearest row)."""

    def __init__(self, config: Any, geometry: Any = None) -> None:
        super().__init__(config, geometry)
        self._seed_m = NOW["seed_m"]


def main() -> None:
    if "--seed-m" in sys.argv:
        at = sys.argv.index("--seed-m")
        NOW["seed_m"] = float(sys.argv[at + 1])
        del sys.argv[at : at + 2]
        oracle_visited.maps_made_as(SeedMemory)
    if "--summary" in sys.argv:
        print(summary(Path(sys.argv[sys.argv.index("--summary") + 1])), end="")
        return
    at = sys.argv.index("--reverse-margin")
    NOW["margin_m"] = float(sys.argv[at + 1])
    if not NOW["margin_m"] >= EPISODE_MARGIN_M:
        raise SystemExit(f"--reverse-margin takes metres >= {EPISODE_MARGIN_M}")
    del sys.argv[at : at + 2]
    events = NOW["events"] = oracle_visited.worker_file("--events")
    EpisodeTracker.update, EpisodeTracker.reset = update, reset  # type: ignore[method-assign]
    runner.teacher_lap = teacher_lap
    rules = oracle_visited.load_rules()
    rules.run_trials = scored(rules.run_trials)
    rules.run_loop_trials = scored(rules.run_loop_trials)
    rules.main()
    gather(events)


def gather(path: Path) -> None:
    """Join the workers' parts of ``path`` (``path.PID``, JSON lines) into ``path``, sorted, and
    remove the parts."""
    lines: list[str] = []
    for part in sorted(path.parent.glob(f"{path.name}.*")):
        lines += part.read_text().splitlines()
        part.unlink()
    path.write_text("".join(f"{line}\n" for line in sorted(lines)))


if __name__ == "__main__":
    main()
