"""Part 68 of ``README.md``: the incoming strip's outer half, out to the felt's own edge, covered
through a spin (a prototype map).

Part 67's ``outer_cover.py`` covered the felt within a fixed reach of each place laid before a
spin, on the outer side of the way the rover went from that place; ``outer_shadow.py`` found it (on
a map whose side the branch side input overwrote, part 68) leaving fresh much of the outer felt
part 66's oracle covers, and covering some of the way on. :class:`EdgeCoverMemory` keeps
``outer_cover.py``'s trail of forward places, its spin and its turn's side, and covers by a line
instead: the line fitted through the places laid :data:`FIT_FROM_M` to :data:`FIT_TO_M` of travel
before the spin (the incoming strip's direction, which the rover's last steps before the vertex,
often turned, do not set), and on its outer side (away from the turn) the felt out to the strip's
outer edge as the felt itself shows it there: going out from the line across the felt beside the
fitted places, the first gap of carpet wider than :data:`GAP_M` (plus :data:`EDGE_MARGIN_M`; where
no felt lies beside them, :data:`NO_EDGE_M`). Felt on that side of the line, within that edge, from
:data:`COVER_BACK_M` to :data:`COVER_FROM_M` before the spin's place along the line, counts
visited; the turn's side and the last :data:`COVER_FROM_M` keep the map's own state. As in
``outer_cover.py`` the cover waits for a side and ends after ``outer_cover.END_M`` of forward
travel since the spin; unlike ``outer_cover.py``'s, the spin starts again (its line, side and
travel afresh) at every blank frame and pivot in it (:data:`REANCHOR`), since counted from its
first blank pivot the cover often ran out before the vertex (part 68). The numbers were set before
the probes from the loops' geometry (``outer_cover.py``'s docstring) and the map's region spacing
(about 0.1 m across the near floor). The other classes here are part 68's probes and oracles:
:class:`StripCoverMemory`, :class:`TurnCoverMemory`, :class:`TrackSideEdgeCoverMemory` (the track's
side) and :class:`SpinOracleMemory` (part 66's cover, only in such spins). Run as a script it runs
a study with every ``fresh_felt`` map this map (round 44 of ``../human_goal/``).

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --edge-cover --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 --workers 2 --out benchmarks/experiments/sharp_corners/results/edge_cover/probe.md
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import cover_near  # noqa: E402
import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402
import outer_cover  # noqa: E402
import track_branch  # noqa: E402

#: [m] travel before the spin of the places the line is fitted through (and whose felt beside
#: shows the edge): from ...
FIT_FROM_M = 0.3
#: [m] ... to
FIT_TO_M = 1.5
#: places needed in that range to fit a line
MIN_PLACES = 4.0
#: [m] a gap in the felt across the line wider than this ends the strip
GAP_M = 0.12
#: [m] added beyond the last felt before that gap
EDGE_MARGIN_M = 0.05
#: [m] the edge's offset where no felt lies beside the fitted places
NO_EDGE_M = 0.3
#: [m] how far to the turn's side of the line the cover reaches (0: from the line outward)
INNER_M = 0.0
#: [m] how far out from the line felt is looked at for the edge
LOOK_M = 0.9
#: [m] the cover along the line: from this far before the spin's place ...
COVER_BACK_M = 2.0
#: [m] ... to this far before it (part 12's oracle covers from 0.3 m behind)
COVER_FROM_M = 0.3


#: 1: :class:`EdgeCoverMemory`'s spin starts again at every blank frame and pivot in it (its
#: line, side and travel afresh; ``outer_cover.REANCHOR``); 0: as ``outer_cover.py``'s
REANCHOR = 1.0

#: 1: the cover's near end follows the rover, :data:`COVER_FROM_M` before the furthest its axle
#: has come along the line since the spin (if past the spin's place), as part 12's oracle covers
#: from behind the rover's progress; 0: fixed at the spin's place
FOLLOW_ROVER = 0.0


def fitted_line(
    places: np.ndarray, first: np.ndarray, last: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The line through ``places`` (N, 2) by least squares: (their mean, the unit direction),
    the direction pointing from the place ``first`` toward ``last`` (the way the rover went)."""
    centre = places.mean(axis=0)
    _, _, rows = np.linalg.svd(places - centre, full_matrices=False)
    way = rows[0]
    if float(np.dot(last - first, way)) < 0.0:
        way = -way
    return centre, way


class EdgeCoverMemory(outer_cover.OuterCoverMemory):
    """``outer_cover.py``'s map with the cover set by a fitted line and the felt's own edge."""

    def reset(self) -> None:
        super().reset()
        self.edges: list[tuple[float, float]] = []
        """[m] each spin's covered band off the line (to its left), as first found."""
        self._edge_found = False
        self._furthest = 0.0  # [m] the furthest the axle has come along the line since the spin

    def _reanchors(self) -> bool:
        return bool(REANCHOR)

    def _end(self) -> None:
        super()._end()
        self._edge_found = False
        self._furthest = 0.0

    def _start(self) -> None:
        super()._start()
        self._furthest = 0.0

    def _line(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(a point on the line, its unit direction toward the spin, the spin's place) in the
        rover frame, or None without places enough."""
        back = self._back
        fit = np.isfinite(back) & (back >= FIT_FROM_M) & (back <= FIT_TO_M)
        if int(fit.sum()) < MIN_PLACES:
            return None
        places, order = self._trail[fit], back[fit]
        centre, way = fitted_line(places, places[np.argmax(order)], places[np.argmin(order)])
        spin = self._trail[np.isfinite(back)][np.argmin(back[np.isfinite(back)])]
        return centre, way, spin

    def _frame(
        self, points: np.ndarray, line: tuple[np.ndarray, np.ndarray, np.ndarray]
    ) -> tuple[np.ndarray, np.ndarray]:
        """``points`` (N, 2) as (along the line from the spin's place, [m], negative before it;
        off the line to its left, [m])."""
        centre, way, spin = line
        gap = points - centre
        along = gap @ way - float(np.dot(spin - centre, way))
        return along, way[0] * gap[:, 1] - way[1] * gap[:, 0]

    def _edge(self, line: tuple[np.ndarray, np.ndarray, np.ndarray], side: int) -> float:
        """[m] the strip's edge out from the line on ``side`` (+1 left, -1 right), from the felt
        beside the fitted places."""
        on = self._felt >= 0.5
        along, left = self._frame(self._points[on], line)
        out = side * left
        beside = (along >= -FIT_TO_M) & (along <= -FIT_FROM_M)
        offsets = np.sort(out[beside & (out >= 0.0) & (out <= LOOK_M)])
        if not len(offsets) or offsets[0] > GAP_M:
            return NO_EDGE_M
        gaps = np.flatnonzero(np.diff(offsets) > GAP_M)
        last = offsets[gaps[0]] if len(gaps) else offsets[-1]
        return float(last) + EDGE_MARGIN_M

    def _band(self, line: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[float, float]:
        """[m] the band off the line (to its left) that is covered: its outer side, out to the
        strip's edge there."""
        edge = self._edge(line, -self._turn_side)
        return (-INNER_M, edge) if self._turn_side < 0 else (-edge, INNER_M)

    def _covering(self) -> bool:
        """Whether the cover is on: in a spin whose turn's side has been read."""
        return bool(self._turn_side)

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super(outer_cover.OuterCoverMemory, self)._kept(where)
        if kept is None or not self._covering() or not where.any():
            return kept
        line = self._line()
        if line is None:
            return kept
        low, high = self._band(line)
        if not self._edge_found:
            self.edges.append((low, high))
            self._edge_found = True
        near_end = 0.0
        if FOLLOW_ROVER:
            axle = float(self._frame(np.zeros((1, 2)), line)[0][0])
            self._furthest = near_end = max(self._furthest, axle)
        along, left = self._frame(self._points[where], line)
        covered = (left >= low) & (left <= high)
        covered &= (along >= -COVER_BACK_M) & (along <= near_end - COVER_FROM_M)
        kept = kept.copy()
        kept[where] = np.where(covered, 0.0, kept[where])
        return kept


class StripCoverMemory(EdgeCoverMemory):
    """:class:`EdgeCoverMemory` covering the incoming strip on both sides of the line, each out
    to the nearer of the strip's two edges (the outgoing strip, merged with the incoming one near
    the vertex, widens the turn's side), with no turn's side needed: on from the spin's start."""

    def _band(self, line: tuple[np.ndarray, np.ndarray, np.ndarray]) -> tuple[float, float]:
        half = min(self._edge(line, 1), self._edge(line, -1))
        return -half, half

    def _covering(self) -> bool:
        return self._spin


#: [deg] :class:`TurnCoverMemory`: the heading turned off the incoming line that turns the
#: cover on ...
TRIGGER_DEG = 100.0
#: [deg] ... and up to which the heading names the turn's side (nearer 180 it keeps the last)
SIDE_UP_TO_DEG = 170.0


class TurnCoverMemory(EdgeCoverMemory):
    """:class:`EdgeCoverMemory` turned on by the rover's own turn instead of a spin: once its
    heading lies :data:`TRIGGER_DEG` or more off the line fitted through the places laid
    :data:`FIT_FROM_M` to :data:`FIT_TO_M` of travel before (blank map or not), that line is
    kept as the incoming strip's, the turn's side is the side the heading has turned to (while it
    lies between :data:`TRIGGER_DEG` and :data:`SIDE_UP_TO_DEG` off it; a spin passing the
    incoming line's reverse keeps the last), and the cover stays on until
    ``outer_cover.END_M`` of forward travel since."""

    def _heading_off(self, line: tuple[np.ndarray, np.ndarray, np.ndarray]) -> float:
        """[deg] the rover's heading off the line's direction, left positive, in (-180, 180]."""
        way = line[1]
        return -math.degrees(math.atan2(float(way[1]), float(way[0])))

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._settle_without_frame()  # every command before this frame moved the map
        if not self._spin:
            self._start()  # tentatively: each place's travel to here
            line = self._line()
            if line is None or abs(self._heading_off(line)) < TRIGGER_DEG:
                self._end()
            else:
                self.covers += 1
        if self._spin:
            line = self._line()
            if line is not None:
                off = self._heading_off(line)
                if TRIGGER_DEG <= abs(off) <= SIDE_UP_TO_DEG:
                    self._turn_side = 1 if off > 0 else -1
        super(outer_cover.OuterCoverMemory, self).see(values, levels)
        self._was_blank = self.bearing_deg is None


#: ``hairpin_trace.py --edge-mask``: :class:`TrackSideEdgeCoverMemory`'s cover kept only where
#: the track says it is the hairpin's incoming leg (``"leg"``), outside its centreline
#: (``"outer"``), or both (``"leg-outer"``); ``""``: not masked
EDGE_MASK = ""


class TrackSideEdgeCoverMemory(EdgeCoverMemory):
    """:class:`EdgeCoverMemory` whose turn's side is the track's (an oracle on the side alone):
    the side of the nearest vertex turning 90° or more near the rover's progress, as
    ``track_branch.py`` names it (``hairpin_trace.py --edge-cover-track-side``); with
    :data:`EDGE_MASK`, its cover is also cut by the track (a measurement of which of the felt it
    covers beyond the oracle's costs the laps)."""

    def _read_side(self) -> int:
        track = oracle_visited.NOW["track"]
        if track is None:
            return 0
        return track_branch.track_side(track, float(oracle_visited.NOW["progress_m"]))

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        track = oracle_visited.NOW["track"]
        if not EDGE_MASK or kept is None or track is None or not where.any():
            return kept
        own = super(outer_cover.OuterCoverMemory, self)._kept(where)
        if own is None:
            return kept
        floor = oracle_visited.to_floor(self._points[where], oracle_visited.NOW["pose"])
        allowed = np.ones(len(floor), dtype=bool)
        if "leg" in EDGE_MASK:
            start, end = cover_near.incoming_leg(track)
            arc = oracle_visited.centreline_at(track, floor)
            allowed &= (arc >= start) & (arc <= end)
        if "outer" in EDGE_MASK:
            allowed &= cover_near.turn_side_offset(track, floor) <= 0.0
        kept = kept.copy()
        kept[where] = np.where(allowed, kept[where], own[where])
        return kept


class SpinOracleMemory(TrackSideEdgeCoverMemory, cover_near.CoverNearMemory):
    """``cover_near.py``'s oracle cover (``hairpin_trace.py --oracle --cover-leg ...
    --in-spins``), on only while :class:`TrackSideEdgeCoverMemory` would cover: from a spin's
    start (once the track's side is read) until ``outer_cover.END_M`` of travel since; the map's
    own visited felt elsewhen. It asks whether the oracle's cover carries its laps when it is on
    only where a robot's spin could turn one on (an oracle, a measurement)."""

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        if not self._covering():
            return super(oracle_visited.TrackVisitedMemory, self)._kept(where)
        return cover_near.CoverNearMemory._kept(self, where)


def main() -> None:
    oracle_learner.run_with_map(EdgeCoverMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
