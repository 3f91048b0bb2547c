"""Part 63 of ``README.md``: the track's side as the branch side input (an oracle, not a design).

Part 62's traces: at a hairpin past 155° the goal's learner pivots, on a blank map, the way the
map's branch side input (its fourth) names, and that input names the way away from the corner at
half of those vertices; laps whose first blank pivot there turned the corner's way lap more
often. :class:`TrackBranchMemory` is the ``fresh_felt`` map whose branch side input is the
track's: within :data:`AHEAD_M` ahead of the rover's progress (or :data:`BEHIND_M` past it) at a
vertex turning :data:`MIN_TURN_DEG` or more, the side that vertex turns (the nearest such
vertex); elsewhere the map's own. Everything else is the map's own. The learner is taught and
driven on it (the demonstration reads the leg being driven, as ``oracle_learner.py`` does), so
what changes between this and the goal's learner is whether the input names a sharp corner's
side rightly.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --track-branch --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 2 3 4 5 6 7 8 9 --workers 2 --out benchmarks/experiments/sharp_corners/results/hairpin_trace/track_branch.md
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402

from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.teaching.scripted import ProtocolHuman  # noqa: E402
from lfd_track.world.track import Track  # noqa: E402

#: [m] how far ahead of the rover's progress a sharp vertex names the side
AHEAD_M = 1.0
#: [m] how far past it (the rover turning at the vertex has passed it along the track)
BEHIND_M = 0.3
#: [deg] the turn that makes a vertex sharp
MIN_TURN_DEG = 90.0


def vertex_arcs(track: Track) -> tuple[np.ndarray, np.ndarray]:
    """(V,) each vertex's arc length along ``track`` [m], and (V,) the length of the leg that
    starts at it (a loop's last leg closing it)."""
    vertices = np.asarray(track.vertices, dtype=np.float64)
    legs = np.linalg.norm(np.diff(np.vstack([vertices, vertices[:1]]), axis=0), axis=1)
    return np.concatenate([[0.0], np.cumsum(legs)[:-1]]), legs


def track_side(track: Track, progress_m: float) -> int:
    """+1 (left) or -1 (right): the side of the nearest vertex of ``track`` turning
    :data:`MIN_TURN_DEG` or more within :data:`AHEAD_M` ahead of ``progress_m`` or
    :data:`BEHIND_M` past it; 0 without one."""
    turns = np.asarray(track.vertex_turns_rad)
    at, _ = vertex_arcs(track)
    ahead = at - progress_m
    if track.closed:
        ahead = (ahead + BEHIND_M) % track.length_m - BEHIND_M
    sharp = (np.abs(turns) >= math.radians(MIN_TURN_DEG)) & (ahead >= -BEHIND_M)
    sharp &= ahead <= AHEAD_M
    if not sharp.any():
        return 0
    k = np.flatnonzero(sharp)[np.argmin(np.abs(ahead[sharp]))]
    return 1 if turns[k] > 0 else -1


class TrackBranchMemory(oracle_learner.PrototypeMemory):
    """The ``fresh_felt`` map with the track's side as its branch side (module docstring)."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        track = oracle_visited.NOW["track"]
        if self._branch is None or track is None:
            return
        side = track_side(track, float(oracle_visited.NOW["progress_m"]))
        if side:
            self._side = 1.0 if side > 0 else 0.0


def use_track_branch(memory_class: type[oracle_learner.PrototypeMemory] | None = None) -> None:
    """From now on every ``fresh_felt`` map this process makes is a ``memory_class`` (by
    default a :class:`TrackBranchMemory`) that can read the episode (or the demonstration's
    leg) being driven in ``oracle_visited.NOW``."""
    LfDTrackEnv.reset, LfDTrackEnv.step = (  # type: ignore[method-assign]
        oracle_visited.reset,
        oracle_visited.step,
    )
    ProtocolHuman.finished = oracle_learner.leg_finished  # type: ignore[method-assign]
    oracle_visited.maps_made_as(memory_class or TrackBranchMemory)
