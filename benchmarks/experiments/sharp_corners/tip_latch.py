"""Part 81 of ``README.md``: a strip's end seen ahead, with the way on in sight beside it, left
behind in the map's frame (a prototype map); and part 13's dead-end test on the goal's learner.

Parts 13, 14 and 48 left out a sharp corner's tip by the carpet the map sees beyond it, and were
read with the map rule driving, never with the goal's learner (which makes more of the map at a
hairpin than the rule, part 57). Part 69 covered the tip by the rover's heading and lost laps:
its cover moved with the rover, so the rover's first turn toward the way on changed what it
covered. Part 72 held a cover in the strip's frame but laid it only after the rover had turned,
where part 72's trace found the decision already made. :class:`TipLatchMemory` lays the cover
*before* the turn and holds it in the map's frame:

- **the strip's end ahead**: ``dead_ends.strip_end_m`` (part 14): carpet along the heading, within
  0.1 m of it, over 0.3 m from somewhere 0.1-0.6 m ahead;
- **the way on in sight**: with the felt the corridor would cover left out, the map's fresh felt
  (the goal's own, within reach, in sight along felt) still weighs :data:`MIN_FRESH` or more, and
  its centre lies :data:`SIDE_DEG` or more off the heading (a strip leaving to one side, not the
  same strip on past a misread patch);
- then a **corridor** from the axle along the heading to :data:`PAST_END_M` past the end, within
  :data:`HALF_M` of the heading, is laid in the map's frame and moved with the map; the felt in
  the last :data:`KEPT` corridors counts visited, whatever the rover does next.

A corridor is laid at most once a frame (at the frame's first look, within reach). The numbers
were set from the loops' geometry before any run: strips 0.25-0.45 m wide (a corridor of the
widest strip's half width less a margin, so that it does not reach across to a strip leaving
beside the rover's), 20 degrees the map rule's own turn threshold, and part 44's four corridors
kept. :class:`DeadEndPointsMemory` is part 13's point test (``dead_ends.leads_nowhere``) on the
goal's map, unchanged, for the learner.

Run as a script it runs a study with every ``fresh_felt`` map a :class:`TipLatchMemory`
(``--dead-end-points``: a :class:`DeadEndPointsMemory`); it drives no test loop unless the study
named does. ``hairpin_trace.py --tip-latch`` and ``--dead-end-points`` drive a committed round's
validation loop laps on them.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import dead_ends  # noqa: E402
import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402
from lfd_track.policy.memory import MIN_FRESH  # noqa: E402

#: [m] the corridor's half width, across the heading
HALF_M = 0.2
#: [m] how far past the strip's end the corridor reaches
PAST_END_M = 0.1
#: [deg] the way on's fresh felt must lie at least this far off the heading
SIDE_DEG = 20.0
#: corridors kept (the newest; a float, as ``hairpin_trace.py --set`` sets only floats)
KEPT = 4.0


#: the rover's axle and heading in its own frame: where a corridor laid now starts, and its way
_AXLE, _HEADING = np.zeros(2), np.array([1.0, 0.0])


def in_corridor(
    points: np.ndarray, start: np.ndarray, way: np.ndarray, length: float
) -> np.ndarray:
    """(N,) bool: which of ``points`` (N, 2) lie in the corridor from ``start`` (2,) along the unit
    ``way`` (2,) for ``length`` [m], :data:`HALF_M` either side."""
    gap = points - start
    along = gap[:, 0] * way[0] + gap[:, 1] * way[1]
    across = gap[:, 1] * way[0] - gap[:, 0] * way[1]
    return (along >= 0.0) & (along <= length) & (np.abs(across) <= HALF_M)


class TipLatchMemory(oracle_learner.PrototypeMemory):
    """The goal's ``fresh_felt`` map with the strip's end latched (module docstring)."""

    def reset(self) -> None:
        super().reset()
        self._latch_from = np.zeros((0, 2))  # each corridor's start (the axle when laid)
        self._latch_way = np.zeros((0, 2))  # its direction (unit; the heading when laid)
        self._latch_length = np.zeros(0)  # [m] its length
        self._latch_looked = False  # a corridor was considered at this frame

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._latch_looked = False
        super().see(values, levels)

    def _move(self, command: int, measured: Any = None) -> None:
        super()._move(command, measured)
        self._latch_from = self._carried(self._latch_from, command, measured)
        self._latch_way = self._turned_dirs(self._latch_way, command, measured)

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._latch_from = self._placed_before(self._latch_from, command)
        self._latch_way = self._placed_before(self._latch_way, command, directions=True)

    def _in_corridors(self, points: np.ndarray) -> np.ndarray:
        """(N,) bool: which of ``points`` (N, 2) lie in a kept corridor."""
        inside = np.zeros(len(points), dtype=bool)
        for start, way, length in zip(
            self._latch_from, self._latch_way, self._latch_length, strict=True
        ):
            inside |= in_corridor(points, start, way, length)
        return inside

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or not len(self._latch_length) or not where.any():
            return kept
        covered = where & self._in_corridors(self._points)
        if not covered.any():
            return kept
        kept = kept.copy()
        kept[covered] = 0.0
        return kept

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        weights = super()._fresh(near, ahead)
        if self._latch_looked:
            return weights
        self._latch_looked = True
        end = dead_ends.strip_end_m(self._points, self._felt)
        if end is None:
            return weights
        length = end + PAST_END_M
        corridor = in_corridor(self._points, _AXLE, _HEADING, length)
        left = np.where(corridor, 0.0, weights)
        mass = float(left.sum())
        if mass < MIN_FRESH:
            return weights
        centre_x = float((left * self._points[:, 0]).sum()) / mass  # as the map sums (no BLAS)
        centre_y = float((left * self._points[:, 1]).sum()) / mass
        bearing = math.degrees(math.atan2(centre_y, centre_x))
        if abs(bearing) < SIDE_DEG:
            return weights
        kept = int(KEPT)
        self._latch_from = np.vstack([self._latch_from, _AXLE])[-kept:]
        self._latch_way = np.vstack([self._latch_way, _HEADING])[-kept:]
        self._latch_length = np.append(self._latch_length, length)[-kept:]
        return left


class DeadEndPointsMemory(dead_ends.DeadEndMemory, oracle_learner.PrototypeMemory):
    """The goal's ``fresh_felt`` map whose fresh felt leaves out felt that leads nowhere: part
    13's ``dead_ends.DeadEndMemory``, unchanged, as a prototype map the learner is taught on."""


def main() -> None:
    memory_class: type = TipLatchMemory
    if "--dead-end-points" in sys.argv:
        sys.argv.remove("--dead-end-points")
        memory_class = DeadEndPointsMemory
    oracle_learner.run_with_map(memory_class, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
