"""Part 67 of ``README.md``: the incoming strip's outer half covered through a spin (a prototype map).

Parts 65–66: at a hairpin past 155° the track's cover of the incoming strip alone carries the
oracle's laps, and all of the outgoing strip lies on the turn's side of the incoming strip's
centreline. :class:`OuterCoverMemory` is the ``fresh_felt`` map with one thing added. It keeps
the places of its last :data:`TRAIL` forward commands with the way it travelled from each (moved
with the map; pivots add none, so a spin does not flush them). In a *spin* (a frame left the map
blank and the rover has since pivoted, as ``spin_side.py`` enters one) it reads the turn's side
from the felt beside the way it came: felt lying :data:`SIDE_BAND_M` off the places laid up to
:data:`SIDE_BACK_M` before the spin, on one side at least :data:`SIDE_RATIO` times the other and
:data:`MIN_SIDE_FELT` in all (an outgoing strip diverging beside the incoming one); until it has
a side it covers nothing. With a side, felt whose nearest place laid before the spin lies
:data:`COVER_FROM_M` or more of travel before it, within :data:`REACH_M` of that place and on the
outer side of the way it went (away from the turn), counts visited; the turn's side keeps the
map's own state. The cover ends after :data:`END_M` of forward travel since the spin. The
numbers come from the loops' geometry, set before the probes: strips are at most 0.45 m wide and
the rover rides within about 0.075 m of a strip's centre, so the incoming strip's outer felt lies
within 0.6 m of its places; a 155–175° hairpin's outgoing strip lies 0.3–0.8 m to the turn's side
of the incoming places 1–1.5 m back from the vertex, and at 160° no longer reaches the outer side
of a path ridden 0.06 m to the turn's side 0.7 m from the vertex (:data:`COVER_FROM_M`). Part 67's
first probe covered instead from 0.3 m of travel before the spin (part 12's oracle covers from
0.3 m behind), taking the nearest place among those only; the README has both probes.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --outer-cover --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 --workers 2 --out benchmarks/experiments/sharp_corners/results/outer_cover/probe_0.7.md
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402

#: forward places kept (4 m of the paper's steps)
TRAIL = 40
#: [deg] the net turn since the last forward command that makes a blank map's pivots a spin
MIN_TURN_DEG = 10.0
#: [m] the cover starts this far of travel before the spin (part 12's oracle: 0.3 m)
COVER_FROM_M = 0.7
#: [m] how far from its nearest place outer felt is covered
REACH_M = 0.6
#: [m] the side test's band off the places, and how far back before the spin it looks
SIDE_BAND_M = (0.3, 0.8)
SIDE_BACK_M = 1.5
#: the side test: one side's felt at least this many times the other's, and this much in all
SIDE_RATIO, MIN_SIDE_FELT = 2.0, 3.0
#: [m] forward travel after which the cover ends
END_M = 2.0
#: 1: a blank frame and a pivot during a spin start it again (its places' travel, its side and
#: its forward travel counted afresh from there); 0: a spin runs its :data:`END_M` from its first
REANCHOR = 0.0


def travel_back(trail: np.ndarray) -> np.ndarray:
    """(N,) [m]: the travel from each of the places ``trail`` (N, 2), oldest first in the rover
    frame, through the newer ones to the rover's place (the origin)."""
    places = np.vstack([trail, np.zeros((1, 2))])
    steps = np.hypot(*np.diff(places, axis=0).T)
    return np.cumsum(steps[::-1])[::-1]


class OuterCoverMemory(oracle_learner.PrototypeMemory):
    """The ``fresh_felt`` map with the incoming strip's outer half covered in a spin."""

    def reset(self) -> None:
        super().reset()
        self._trail = np.zeros((0, 2))  # forward places, oldest first (rover frame)
        self._ways = np.zeros((0, 2))  # the way travelled from each (unit)
        self._back = np.zeros(0)  # [m] travel from each place to the spin (inf: after it)
        self._was_blank = False
        self._spin = False  # in a spin (the cover's places are fixed)
        self._turn_side = 0  # the turn's side read in the spin: +1 left, -1 right, 0 not yet
        self._driven = 0.0  # [m] forward travel since the spin began
        self.covers = 0
        """Spins in which a side was read this episode."""

    def _move(self, command: int, measured: Any = None) -> None:
        forward = command == Command.FORWARD
        trail, ways, back = self._trail, self._ways, self._back
        if forward:
            trail = np.vstack([trail, np.zeros((1, 2))])[-TRAIL:]
            ways = np.vstack([ways, [[1.0, 0.0]]])[-TRAIL:]
            back = np.append(back, np.inf)[-TRAIL:]
        super()._move(command, measured)
        if measured is not None:
            self._trail = measured.move_points(trail)
        else:
            self._trail = self._moved(trail, command)
        self._ways = self._turned_dirs(ways, command, measured)
        self._back = back
        advance = self._turn_or_advance(command, measured)
        if advance is not None and self._spin:
            self._driven += advance
            if self._driven > END_M:
                self._end()

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._trail = self._placed_before(self._trail, command)
        self._ways = self._placed_before(self._ways, command, directions=True)

    def _reanchors(self) -> bool:
        """Whether a blank frame and a pivot during a spin start it again (:data:`REANCHOR`)."""
        return bool(REANCHOR)

    def _end(self) -> None:
        self._spin, self._turn_side, self._driven = False, 0, 0.0
        self._back = np.full(len(self._trail), np.inf)

    def _start(self) -> None:
        """A spin begins: each place's travel to the rover's place now."""
        self._spin, self._turn_side, self._driven = True, 0, 0.0
        if not len(self._trail):
            self._back = np.zeros(0)
            return
        self._back = travel_back(self._trail)

    def _read_side(self) -> int:
        """The turn's side from the felt beside the places before the spin (module docstring)."""
        near = self._back <= SIDE_BACK_M
        if not near.any():
            return 0
        on = self._felt >= 0.5
        lateral, dist, _ = self._offsets(self._points[on], near)
        band = (np.abs(lateral) >= SIDE_BAND_M[0]) & (dist <= SIDE_BAND_M[1])
        felt = self._felt[on]
        left = float(felt[band & (lateral > 0)].sum())
        right = float(felt[band & (lateral < 0)].sum())
        if left + right < MIN_SIDE_FELT:
            return 0
        if left >= SIDE_RATIO * right:
            return 1
        if right >= SIDE_RATIO * left:
            return -1
        return 0

    def _offsets(
        self, points: np.ndarray, chosen: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Each of ``points`` (N, 2): its offset to the left of the way travelled at its nearest
        place among the ``chosen`` ones, its distance to that place, and that place's travel
        before the spin."""
        marks, ways = self._trail[chosen], self._ways[chosen]
        gap = points[:, None, :] - marks[None, :, :]
        dist = np.hypot(gap[..., 0], gap[..., 1])
        nearest = np.argmin(dist, axis=1)
        rows = np.arange(len(points))
        g, w = gap[rows, nearest], ways[nearest]
        lateral = w[:, 0] * g[:, 1] - w[:, 1] * g[:, 0]
        return lateral, dist[rows, nearest], self._back[chosen][nearest]

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._settle_without_frame()  # every command before this frame moved the map
        if (not self._spin or self._reanchors()) and self._was_blank:
            if abs(self._turned) >= MIN_TURN_DEG:
                self._start()
        if self._spin and not self._turn_side:
            self._turn_side = self._read_side()
            self.covers += bool(self._turn_side)
        super().see(values, levels)
        self._was_blank = self.bearing_deg is None

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        before = np.isfinite(self._back)
        if kept is None or not self._turn_side or not before.any() or not where.any():
            return kept
        lateral, dist, back = self._offsets(self._points[where], before)
        covered = (self._turn_side * lateral <= 0.0) & (dist <= REACH_M) & (back >= COVER_FROM_M)
        kept = kept.copy()
        kept[where] = np.where(covered, 0.0, kept[where])
        return kept


def main() -> None:
    oracle_learner.run_with_map(OuterCoverMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
