"""Part 74 of ``README.md``: the track's progress rule on a corner the robot places from its own
map (a prototype map).

Part 70 found that the goal's learner laps every one of the rooms' 400 laps when the map counts
felt visited by the track's progress (felt whose nearest centreline lies behind the rover's), and
part 71 that the rover there rides into the merge of a sharp corner's two strips before the
vertex, nearer the outgoing strip's centreline than the incoming one's, so that the track puts the
whole incoming strip, its tip too, behind it. A robot does not know the track, but its map holds
the felt it came along and, at a sharp corner, the outgoing strip running back beside it.
:class:`CornerModelMemory` places the two from the map and applies the same rule to them:

- **the incoming strip's line**: the least-squares line through the forward places laid
  :data:`LINE_FROM_M` to :data:`LINE_TO_M` of travel back since the trail last turned
  (:data:`STRAIGHT_DEG`), then moved onto the felt: the line through the map's felt within
  :data:`STRIP_HALF_M` of it over that stretch (twice, each time about the last line), the
  strip's centre rather than the rover's path along it; the strip's width from that felt's
  spread across it (:data:`WIDTH_M`);
- **the vertex**: half the strip's width short of where the felt along that line ends ahead
  of the rover (:data:`END_BIN_M`, :data:`END_ACROSS_M`, :data:`END_CARPET`), at most
  :data:`VERTEX_BACK_M` behind the rover's foot on the line and :data:`VERTEX_AHEAD_M` ahead
  (each strip of a loop runs half its width past its vertices);
- **the outgoing strip's way**: from the vertex toward the middle of the map's felt lying
  :data:`SECOND_FROM_M` to :data:`SECOND_TO_M` off the incoming line on one side (the side with
  more of it), from :data:`ALONG_BACK_M` behind the rover's foot to the vertex, at least
  :data:`MIN_SECOND` of felt level, turning :data:`TURN_DEG` off the incoming way: the outgoing
  strip running back beside the incoming one.

With a corner placed, each felt point's progress is measured along the two strips as the track
measures it along its centreline (the incoming strip up to the vertex, then the outgoing one; a
point takes the nearer of the two), the rover's as well, and the felt whose progress is more than
:data:`COVER_FROM_M` behind the rover's counts visited (part 12's oracle covers from 0.3 m). Where
no corner is placed the map is the goal's own. The numbers were set from the loops' geometry before
any run (strips 0.25-0.45 m wide, so a second strip's felt lies 0.35 m or more off a strip's
centre except where the two merge; corners past 90° put the outgoing strip back beside the
incoming one).

Run as a script it runs a study with every ``fresh_felt`` map a :class:`CornerModelMemory`; it
drives no test loop unless the study named does. ``hairpin_trace.py --corner-model`` drives a
committed round's loop laps on it.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import edge_cover  # noqa: E402
import oracle_learner  # noqa: E402
import outer_cover  # noqa: E402
import tip_cover  # noqa: E402
from tip_cover import LINE_FROM_M, LINE_PLACES, LINE_TO_M  # noqa: E402

# The forward places kept, and the travel back of those the incoming line is fitted through
# (LINE_FROM_M to LINE_TO_M, at least LINE_PLACES of them), are tip_cover.py's.

#: [deg] the places the line is fitted through end where the trail turns this far off its newest
#: step (the corner before)
STRAIGHT_DEG = 25.0
#: [m] felt this far either side of the line is the incoming strip's (half the widest strip)
STRIP_HALF_M = 0.25
#: felt (summed levels) the incoming strip's line needs
MIN_STRIP = 3.0
#: [m] the outgoing strip's felt lies this far off the incoming line: from ...
SECOND_FROM_M = 0.35
#: [m] ... to
SECOND_TO_M = 1.0
#: [m] along the incoming line, from this far behind the rover's foot on it ...
ALONG_BACK_M = 1.5
#: [m] ... to this far ahead
ALONG_AHEAD_M = 1.0
#: felt (summed levels) the outgoing strip needs
MIN_SECOND = 5.0
#: [m] the strip's width, from its felt's spread across the line (a uniform band's standard
#: deviation times the square root of 12), held within
WIDTH_M = (0.2, 0.5)
#: [m] the strip's end is sought in stretches this long along the line ...
END_BIN_M = 0.1
#: [m] ... among the map's points this close to it
END_ACROSS_M = 0.12
#: a stretch's mean felt level below this is carpet (the strip's end) ...
END_CARPET = 0.3
#: ... and below this part felt (the end lies in it)
END_FELT = 0.5
#: [m] the vertex from this far behind the rover's foot on the incoming line ...
VERTEX_BACK_M = 0.5
#: [m] ... to this far ahead
VERTEX_AHEAD_M = 1.5
#: [deg] the corner's turn, from ... to
TURN_DEG = (90.0, 175.0)
#: [m] felt whose progress lies more than this behind the rover's counts visited
COVER_FROM_M = 0.3


def _line(points: np.ndarray, weights: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The weighted least-squares line through ``points`` (N, 2): (its centre, its unit
    direction, the points' variance across it [m²])."""
    total = float(weights.sum())
    centre = (weights[:, None] * points).sum(axis=0) / total
    gap = points - centre
    scatter = (weights[:, None] * gap).T @ gap / total
    values, vectors = np.linalg.eigh(scatter)
    return centre, vectors[:, 1], max(float(values[0]), 0.0)


def _straight_run(trail: np.ndarray) -> np.ndarray:
    """(N,) bool: the places of ``trail`` (N, 2), oldest first in the rover frame, from which
    the rover came straight on to its place: back to the first step (from one place to the
    next, or to the rover) that turns more than :data:`STRAIGHT_DEG` off the newest step."""
    places = np.vstack([trail, np.zeros((1, 2))])
    steps = np.diff(places, axis=0)
    angles = np.arctan2(steps[:, 1], steps[:, 0])
    off = np.abs((angles - angles[-1] + math.pi) % (2.0 * math.pi) - math.pi)
    bent = np.flatnonzero(off > math.radians(STRAIGHT_DEG))
    run = np.ones(len(trail), dtype=bool)
    if len(bent):
        run[: bent[-1] + 1] = False
    return run


def progress(
    points: np.ndarray, vertex: np.ndarray, way_in: np.ndarray, way_out: np.ndarray
) -> np.ndarray:
    """(N,) [m]: each of ``points``' progress along the corner's two strips, 0 at the vertex:
    along the incoming line (negative, up to the vertex) where that one is the nearer, else
    along the outgoing one (positive, from the vertex)."""
    gap = points - vertex
    s = gap @ way_in
    t = gap @ way_out
    across_in = np.abs(gap[:, 0] * way_in[1] - gap[:, 1] * way_in[0])
    across_out = np.abs(gap[:, 0] * way_out[1] - gap[:, 1] * way_out[0])
    far = np.hypot(gap[:, 0], gap[:, 1])
    to_in = np.where(s <= 0.0, across_in, far)
    to_out = np.where(t >= 0.0, across_out, far)
    return np.where(to_in <= to_out, np.minimum(s, 0.0), np.maximum(t, 0.0))


class CornerModelMemory(tip_cover.ForwardTrailMemory):
    """The goal's ``fresh_felt`` map with the track's progress rule on a corner it places
    itself (module docstring)."""

    def reset(self) -> None:
        super().reset()
        self.corners = 0
        """Frames at which a corner was placed this episode."""

    def _incoming(self) -> tuple[np.ndarray, np.ndarray, float] | None:
        """The incoming strip's line (a point on it, its unit direction the rover travelled)
        in the rover frame and the strip's width [m], or None."""
        trail = self._tip_trail
        if len(trail) < LINE_PLACES:
            return None
        back = outer_cover.travel_back(trail)
        fit = (back >= LINE_FROM_M) & (back <= LINE_TO_M) & _straight_run(trail)
        if int(fit.sum()) < LINE_PLACES:
            return None
        chosen = trail[fit]
        centre, way = edge_cover.fitted_line(chosen, chosen[0], chosen[-1])
        foot_back = float(-centre @ way)  # the rover's foot on the line, along it from centre
        lo, hi = foot_back - LINE_TO_M, foot_back - LINE_FROM_M
        across_var = 0.0
        for _ in range(2):
            gap = self._points - centre
            along = gap @ way
            across = gap[:, 0] * way[1] - gap[:, 1] * way[0]
            on = (self._felt > 0.0) & (np.abs(across) <= STRIP_HALF_M)
            on &= (along >= lo) & (along <= hi)
            weights = self._felt[on]
            if float(weights.sum()) < MIN_STRIP:
                return None
            new_centre, new_way, across_var = _line(self._points[on], weights)
            if float(new_way @ way) < 0.0:
                new_way = -new_way
            shift = float((new_centre - centre) @ way)
            centre, way = new_centre, new_way
            lo, hi = lo - shift, hi - shift
        width = min(WIDTH_M[1], max(WIDTH_M[0], math.sqrt(12.0 * across_var)))
        return centre, way, width

    def _strip_end(self, foot: np.ndarray, way: np.ndarray) -> float | None:
        """[m] where the felt along the incoming line ends, ahead of the rover's ``foot`` on it:
        the start of the first stretch of :data:`END_BIN_M` (from the foot to
        :data:`ALONG_AHEAD_M`) whose map points within :data:`END_ACROSS_M` of the line are
        carpet (mean felt level below :data:`END_CARPET`), half a stretch sooner where the one
        before it is part felt (below :data:`END_FELT`); None where none is."""
        gap = self._points - foot
        along = gap @ way
        across = np.abs(gap[:, 0] * way[1] - gap[:, 1] * way[0])
        on = (across <= END_ACROSS_M) & (along >= 0.0) & (along < ALONG_AHEAD_M)
        bins = (along[on] / END_BIN_M).astype(np.int64)
        count = np.bincount(bins, minlength=int(ALONG_AHEAD_M / END_BIN_M) + 1)
        level = np.bincount(bins, weights=self._felt[on], minlength=len(count))
        mixed = False
        for index, seen in enumerate(count):
            if not seen:
                continue
            mean = float(level[index]) / float(seen)
            if mean < END_CARPET:
                return (index - 0.5 * mixed) * END_BIN_M
            mixed = mean < END_FELT
        return None

    def _corner(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(the vertex, the incoming way, the outgoing way) in the rover frame, or None."""
        line = self._incoming()
        if line is None:
            return None
        centre, way, width = line
        foot = centre + float(-centre @ way) * way  # the rover's foot on the line
        end = self._strip_end(foot, way)
        if end is None:
            return None
        at = end - 0.5 * width  # the vertex: half the strip's width short of its end
        if not -VERTEX_BACK_M <= at <= VERTEX_AHEAD_M:
            return None
        vertex = foot + at * way
        gap = self._points - foot
        along = gap @ way
        across = way[0] * gap[:, 1] - way[1] * gap[:, 0]  # left of the line positive
        near = (self._felt > 0.0) & (along >= -ALONG_BACK_M) & (along <= at)
        best = None
        for side in (1.0, -1.0):
            off = side * across
            chosen = near & (off >= SECOND_FROM_M) & (off <= SECOND_TO_M)
            mass = float(self._felt[chosen].sum())
            if mass >= MIN_SECOND and (best is None or mass > best[0]):
                best = (mass, chosen)
        if best is None:
            return None
        weights = self._felt[best[1]]
        second = (weights[:, None] * self._points[best[1]]).sum(axis=0) / float(weights.sum())
        way_out = second - vertex
        way_out = way_out / max(float(np.hypot(*way_out)), 1e-9)
        turn = math.degrees(math.acos(max(-1.0, min(1.0, float(way @ way_out)))))
        if not TURN_DEG[0] <= turn <= TURN_DEG[1]:
            return None
        return vertex, way, way_out

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or not where.any():
            return kept
        corner = self._corner()
        if corner is None:
            return kept
        self.corners += 1
        vertex, way_in, way_out = corner
        rover = float(progress(np.zeros((1, 2)), vertex, way_in, way_out)[0])
        covered = np.zeros(len(where), dtype=bool)
        covered[where] = progress(self._points[where], vertex, way_in, way_out) < (
            rover - COVER_FROM_M
        )
        if not covered.any():
            return kept
        kept = kept.copy()
        kept[covered] = 0.0
        return kept


def main() -> None:
    oracle_learner.run_with_map(CornerModelMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
