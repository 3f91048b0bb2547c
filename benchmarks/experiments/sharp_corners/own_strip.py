"""Does the map take another part of the loop for the rover's own strip before a shortcut? (part
23 of ``README.md``)

Drives the map rule exactly as ``margins.py`` does (its arguments are passed on, the episode's
0.30 m margin included, so the laps are the rule's own) and, at every frame of the scored laps,
carries the map's felt points to the floor by the rover's true pose (``oracle_visited.to_floor``)
and asks the track which part of the loop each lies on: the rover's own (felt within half a width
plus ``shortcuts.OFF_M`` of the centreline less than ``shortcuts.APART_M`` of track from the
rover's progress) or only another, a **foreign** part. It records, per frame, how many points of
the map's own strip (``_own_strip``: felt linked along felt to the felt within 0.3 m of the axle)
are foreign, how many of those the seed itself (the felt within 0.3 m) takes in, and what share
of the fresh felt's weight (the felt that draws the rule) lies on foreign parts. The map's
decisions are not changed; the track is read, never used.

``--strip FILE`` (JSON lines, one per scored lap: its key as in ``margins.py``'s events where the
lap was reversed, its end and its frames with foreign felt); ``--summary FILE EVENTS`` joins them
with the shortcuts ``shortcuts.py`` finds in ``margins.py``'s events. ``--seed-within R`` (part
25) drives the rule on a map whose own strip starts at the felt within R of the axle, and at the
felt within 0.3 m (the map's own seed) only in frames with no felt that near. ``--carpet-clears
R`` (part 25) drives it on a map where each frame's carpet clears the older frames' felt within R
of it: a newer look at the floor, nearer the camera as the rover drives on, overrides an older,
coarser one. ``--hop-weight W`` (part 25) weighs the fresh felt by W to the power of the links
by which the own strip reaches it from the seed: felt further along the strip draws the rover
less than felt it would reach first. ``--true-felt`` (part 25, an oracle) gives the map, in place
of each region's road value, whether the floor at the region's centre is felt, by the rover's true
pose: a perfect point sensor at the camera's own regions. Part 26's fresh felt in sight along
felt is the map's own setting now, ``--map fresh_sight_m=0.05`` (its run was made with this
script's ``--felt-sight 0.05``, the same code before it moved into ``lfd_track``).

    .venv/bin/python benchmarks/experiments/sharp_corners/own_strip.py --strip benchmarks/experiments/sharp_corners/results/margins/rooms_own_strip/strip.jsonl --reverse-margin 0.3 --events benchmarks/experiments/sharp_corners/results/margins/rooms_own_strip/events.jsonl --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --out benchmarks/experiments/sharp_corners/results/margins/rooms_own_strip --workers 2
    .venv/bin/python benchmarks/experiments/sharp_corners/own_strip.py --summary benchmarks/experiments/sharp_corners/results/margins/rooms_own_strip/strip.jsonl benchmarks/experiments/sharp_corners/results/margins/rooms_own_strip/events.jsonl
"""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import margins  # noqa: E402
import oracle_visited  # noqa: E402
import shortcuts  # noqa: E402

from lfd_track.core.frame import N_REGIONS  # noqa: E402
from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402
from lfd_track.world.episode import EpisodeTracker  # noqa: E402

#: frames before the shortcut's pose in which the summary looks for foreign felt
BEFORE_FRAMES = 15
#: a frame whose fresh felt lies at least this share on foreign parts draws the rover there
DRAWN_SHARE = 0.5

#: the frames of the lap being driven: [steps done, own-strip points, foreign, foreign in the
#: seed, foreign share of the fresh weight, the nearest foreign point's distance from the axle
#: (m)] for frames with foreign felt on the own strip; the
#: output file; laps written; ``--seed-within`` (None: the map as it is); ``--carpet-clears``
#: (0: the map as it is); ``--hop-weight`` (1: the map as it is); ``--true-felt``
LAP: dict[str, Any] = {
    "frames": [],
    "steps": 0,
    "file": None,
    "count": 0,
    "seed_within_m": None,
    "carpet_clears_m": 0.0,
    "hop_weight": 1.0,
    "true_felt": False,
}

_margins_update, _margins_reset = margins.update, margins.reset


def foreign(points: np.ndarray) -> np.ndarray:
    """(N,) bool: map points ``points`` (N, 2) whose floor lies on the felt of another part of the
    loop and not on the rover's own part (by :data:`oracle_visited.NOW`'s pose and progress)."""
    now = oracle_visited.NOW
    track = now["track"]
    floor = oracle_visited.to_floor(points, now["pose"])
    projected = track.project(floor)  # (N, S, 2)
    on = projected[..., 1] <= 0.5 * track.width_m + shortcuts.OFF_M
    length = track.length_m
    apart = np.abs((projected[..., 0] - now["progress_m"] + 0.5 * length) % length - 0.5 * length)
    own = (on & (apart <= shortcuts.APART_M)).any(axis=1)
    return on.any(axis=1) & ~own


class StripMemory(FreshFeltMemory):
    """The ``fresh_felt`` map as it is, read at every frame of the scored laps."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        now = oracle_visited.NOW
        if not LAP["true_felt"] or now["track"] is None:
            super().see(values, levels)
            return
        floor = oracle_visited.to_floor(self._region_points, now["pose"])
        super().see(now["track"].on_felt(floor).astype(np.float64), (0.0, 1.0))

    def _own_strip(self, dist: np.ndarray) -> np.ndarray:
        within = LAP["seed_within_m"]
        if within is not None:  # the seed only from the felt this near the axle, where any
            seed = (dist <= self._seed_m) & (self._felt >= 0.5)
            near = seed & (dist <= within)
            if near.any():
                dist = np.where(seed & ~near, np.nextafter(self._seed_m, 1.0), dist)
        hops = self._strip_hops(dist)  # the map's own strip, as its _own_strip joins it
        reached = hops >= 0
        self._hops = hops if LAP["hop_weight"] != 1.0 else None
        self._foreign = None
        if margins.NOW["scoring"] and oracle_visited.NOW["track"] is not None and reached.any():
            where = np.flatnonzero(reached)
            away = np.zeros(len(dist), dtype=bool)
            away[where] = foreign(self._points[where])
            self._foreign = away
            self._own_count = len(where)
            self._seed_foreign = int((away & (dist <= self._seed_m)).sum())
            self._nearest_foreign = round(float(dist[away].min()), 3) if away.any() else None
        return reached

    def _link_newest_frame(self, full: bool) -> None:
        clears = LAP["carpet_clears_m"]
        if clears:  # the newest frame's carpet clears the older felt this near it
            first = len(self._points) - N_REGIONS
            carpet = self._points[first:][self._felt[first:] < 0.5]
            older = np.flatnonzero(self._felt[:first] > 0.0)
            if len(carpet) and len(older):
                gap = self._points[older, None, :] - carpet[None, :, :]
                near = np.einsum("ijk,ijk->ij", gap, gap).min(axis=1) <= clears**2
                self._felt[older[near]] = 0.0
        super()._link_newest_frame(full)

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        hops = self.__dict__.get("_hops")
        if hops is not None:  # felt further along the strip from the seed weighs less
            weights = weights * np.where(hops >= 0, LAP["hop_weight"] ** np.maximum(hops, 0), 0.0)
        away = self.__dict__.get("_foreign")
        if away is None:
            return weights
        mass = float(weights.sum())
        share = float(weights[away].sum()) / mass if mass > 0.0 else 0.0
        count = int(away.sum())
        if count:
            frame = [
                LAP["steps"],
                self._own_count,
                count,
                self._seed_foreign,
                round(share, 3),
                self._nearest_foreign,
            ]
            if LAP["frames"] and LAP["frames"][-1][0] == LAP["steps"]:
                LAP["frames"][-1] = frame  # the wider look of the same frame
            else:
                LAP["frames"].append(frame)
        return weights


def update(self: EpisodeTracker, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> Any:
    st = _margins_update(self, pose, tread_on_felt)
    if not margins.NOW["scoring"]:
        return st
    LAP["steps"] += 1
    if (st.failure is not None or st.success) and not self.__dict__.get("_strip_written"):
        self._strip_written = True  # type: ignore[attr-defined]
        event = self.__dict__.get("_margin_event")
        LAP["count"] += 1
        key = event["lap"] if event is not None else f"{os.getpid()}.s{LAP['count']}"
        record = {
            "lap": key,
            "track": self.track.name,
            "end": "lapped" if st.success else st.failure,
            "steps": LAP["steps"],
            "frames": LAP["frames"],
        }
        with open(f"{LAP['file']}.{os.getpid()}", "a") as out:
            out.write(json.dumps(record) + "\n")
    return st


def reset(self: EpisodeTracker, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> Any:
    LAP["frames"], LAP["steps"] = [], 0
    self._strip_written = False  # type: ignore[attr-defined]
    return _margins_reset(self, pose, tread_on_felt)


def summary(strip: Path, events: Path) -> str:
    """Markdown: per kind of lap, the laps with a frame whose fresh felt lies mostly on another
    part of the loop (for a shortcut: within :data:`BEFORE_FRAMES` frames before it), and how many
    of those had that part in the seed in any such frame, and in the first."""
    laps = margins.read_laps(events)
    rows: dict[str, list[int]] = {}
    for line in strip.read_text().splitlines():
        lap = json.loads(line)
        frames = lap["frames"]
        kind = lap["end"]
        if kind == "reversed" and "poses" in laps.get(lap["lap"], {}):
            poses = np.asarray(laps[lap["lap"]]["poses"])
            track, progress = shortcuts.driven(lap["track"], poses)
            found = shortcuts.shortcut(track, poses, progress)
            if found is not None:
                kind = "reversed after a shortcut"
                last = found["pose"] + 1
                frames = [f for f in frames if last - BEFORE_FRAMES <= f[0] <= last]
            else:
                kind = "reversed, no shortcut"
        drawn = [f for f in frames if f[4] >= DRAWN_SHARE]
        row = rows.setdefault(kind, [0, 0, 0, 0, 0])
        row[0] += 1
        row[1] += bool(frames)
        row[2] += bool(drawn)
        row[3] += any(f[3] > 0 for f in drawn)
        row[4] += bool(drawn) and drawn[0][3] > 0
    out = [
        "| laps | count | foreign felt on the own strip | fresh felt mostly foreign"
        " | of those, foreign felt in the seed | ... in the first such frame's seed |",
        "|---|---|---|---|---|---|",
    ]
    out += [f"| {kind} | " + " | ".join(map(str, row)) + " |" for kind, row in sorted(rows.items())]
    return "\n".join(out) + "\n"


def main() -> None:
    if "--summary" in sys.argv:
        at = sys.argv.index("--summary")
        print(summary(Path(sys.argv[at + 1]), Path(sys.argv[at + 2])), end="")
        return
    if "--seed-within" in sys.argv:
        at = sys.argv.index("--seed-within")
        LAP["seed_within_m"] = float(sys.argv[at + 1])
        del sys.argv[at : at + 2]
    if "--true-felt" in sys.argv:
        LAP["true_felt"] = True
        sys.argv.remove("--true-felt")
    if "--hop-weight" in sys.argv:
        at = sys.argv.index("--hop-weight")
        LAP["hop_weight"] = float(sys.argv[at + 1])
        del sys.argv[at : at + 2]
    if "--carpet-clears" in sys.argv:
        at = sys.argv.index("--carpet-clears")
        LAP["carpet_clears_m"] = float(sys.argv[at + 1])
        del sys.argv[at : at + 2]
    strip = LAP["file"] = oracle_visited.worker_file("--strip")
    LfDTrackEnv.reset, LfDTrackEnv.step = oracle_visited.reset, oracle_visited.step  # type: ignore[method-assign]
    oracle_visited.maps_made_as(StripMemory)
    margins.update, margins.reset = update, reset
    margins.main()
    margins.gather(strip)


if __name__ == "__main__":
    main()
