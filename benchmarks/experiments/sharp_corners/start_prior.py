"""Part 76 of ``README.md``: a rover placed on a loop's start corner counts the strip it came
along as behind it (a prototype map).

Part 75 found that the track's cover of the felt behind a lap's start, alone, wins three of the
14 laps the goal's map loses on the rooms' own laps. Every lap starts on the loop's first vertex
facing the first leg; where that vertex is a sharp corner the loop's last leg meets the first
there, and on an empty map it is fresh felt beside or ahead of the rover. A rover placed there
knows one thing the map does not use: it stands on the trail facing the way to go, so a second
strip leaving the very place it stands, other than the one ahead of it, is where it came from.
:class:`StartPriorMemory` keeps the start place and heading (moved with the map) and, until it
has driven :data:`PRIOR_M` forward or turned :data:`END_TURN_DEG` off the start heading:

- **finds the last leg**: of the rays from the start place :data:`RAY_DEG` off the start heading
  (either side, every :data:`RAY_STEP_DEG`), the one whose map points within :data:`RAY_HALF_M`
  of it from :data:`RAY_FROM_M` to :data:`RAY_TO_M` along it (leaving out the first leg's felt,
  within :data:`FIRST_HALF_M` of the start heading ahead of the start) are felt (at least
  :data:`MIN_RAY_POINTS` of them, mean felt level at least :data:`RAY_FELT`) with the most felt;
  the first such ray found is held;
- **counts it visited**: the felt within :data:`COVER_HALF_M` of the held ray, from the start
  place to :data:`COVER_TO_M` along it, but not the first leg's.

After that the map is the goal's own, so the last leg is fresh again when the lap comes round
to it, and a strip the next corner sends back past the start is not hidden. The numbers were set from the loops' geometry before any
run (strips 0.25-0.45 m wide; the first legs the rooms' lost laps start on are 0.46-2.6 m long).

Run as a script it runs a study with every ``fresh_felt`` map a :class:`StartPriorMemory`; it
drives no test loop unless the study named does. ``hairpin_trace.py --start-prior`` drives a
committed round's loop laps on it.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402

#: [m] forward travel since the start during which the prior holds
PRIOR_M = 2.0
#: [deg] the prior ends for good once the heading has turned this far off the start heading
#: (the rover turns at a corner; a loop's next corner may send its strip back past the start)
END_TURN_DEG = 45.0
#: [deg] the rays sought, off the start heading: from ... to
RAY_DEG = (25.0, 175.0)
#: [deg] between rays
RAY_STEP_DEG = 5.0
#: [m] a ray's band: the map points this close to it ...
RAY_HALF_M = 0.1
#: [m] ... from this far along it ...
RAY_FROM_M = 0.3
#: [m] ... to this far
RAY_TO_M = 1.2
#: map points a ray's band needs
MIN_RAY_POINTS = 3
#: mean felt level a ray's band needs
RAY_FELT = 0.6
#: [m] the first leg: felt ahead of the start place this close to the start heading
FIRST_HALF_M = 0.25
#: [m] the cover: felt this close to the held ray ...
COVER_HALF_M = 0.25
#: [m] ... up to this far along it
COVER_TO_M = 3.0


class StartPriorMemory(oracle_learner.PrototypeMemory):
    """The goal's ``fresh_felt`` map with the start prior (module docstring)."""

    def reset(self) -> None:
        super().reset()
        self._start_at = np.zeros((1, 2))  # the start place (rover frame)
        self._start_way = np.array([[1.0, 0.0]])  # the start heading (unit, rover frame)
        self._start_travel = 0.0  # [m] forward travel since the start
        self._start_over = False  # the prior has ended (driven PRIOR_M or turned END_TURN_DEG)
        self._last_leg: np.ndarray | None = None  # the held ray's unit direction (rover frame)
        self.start_rays = 0
        """Laps (0 or 1 this episode) in which a last leg was found."""

    def _move(self, command: int, measured: Any = None) -> None:
        advance, _ = self._command_motion(command, measured)
        if command == Command.FORWARD:
            self._start_travel += abs(advance)
        super()._move(command, measured)
        self._start_at = self._carried(self._start_at, command, measured)
        self._start_way = self._turned_dirs(self._start_way, command, measured)
        if self._last_leg is not None:
            self._last_leg = self._turned_dirs(self._last_leg, command, measured)

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._start_at = self._placed_before(self._start_at, command)
        self._start_way = self._placed_before(self._start_way, command, directions=True)
        if self._last_leg is not None:
            self._last_leg = self._placed_before(self._last_leg, command, directions=True)

    def _off_first_leg(self, gap: np.ndarray) -> np.ndarray:
        """(N,) bool: the map points whose offsets ``gap`` (N, 2) from the start place lie off
        the first leg (not ahead of the start within :data:`FIRST_HALF_M` of its heading)."""
        way = self._start_way[0]
        along = gap @ way
        across = np.abs(gap[:, 0] * way[1] - gap[:, 1] * way[0])
        return ~((along >= 0.0) & (across <= FIRST_HALF_M))

    def _find_last_leg(self) -> None:
        """Hold the ray of the last leg, where one is found now (module docstring)."""
        gap = self._points - self._start_at[0]
        off = self._off_first_leg(gap)
        way = self._start_way[0]
        heading = math.atan2(float(way[1]), float(way[0]))
        best = 0.0
        count = int(round((RAY_DEG[1] - RAY_DEG[0]) / RAY_STEP_DEG)) + 1
        for step in range(count):
            for side in (1.0, -1.0):
                angle = heading + side * math.radians(RAY_DEG[0] + step * RAY_STEP_DEG)
                ray = np.array([math.cos(angle), math.sin(angle)])
                along = gap @ ray
                across = np.abs(gap[:, 0] * ray[1] - gap[:, 1] * ray[0])
                band = off & (along >= RAY_FROM_M) & (along <= RAY_TO_M) & (across <= RAY_HALF_M)
                seen = int(band.sum())
                if seen < MIN_RAY_POINTS:
                    continue
                felt = self._felt[band]
                if float(felt.mean()) >= RAY_FELT and float(felt.sum()) > best:
                    best, self._last_leg = float(felt.sum()), ray[None, :]
        if self._last_leg is not None:
            self.start_rays += 1

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if not self._start_over:
            way = self._start_way[0]
            turned = abs(math.degrees(math.atan2(float(way[1]), float(way[0]))))
            self._start_over = self._start_travel >= PRIOR_M or turned >= END_TURN_DEG
        if self._start_over or not where.any():
            return kept
        if self._last_leg is None:
            self._find_last_leg()
            if self._last_leg is None:
                return kept
        ray = self._last_leg[0]
        gap = self._points - self._start_at[0]
        along = gap @ ray
        across = np.abs(gap[:, 0] * ray[1] - gap[:, 1] * ray[0])
        covered = where & self._off_first_leg(gap)
        covered &= (along >= 0.0) & (along <= COVER_TO_M) & (across <= COVER_HALF_M)
        if not covered.any():
            return kept
        kept = np.where(where, 1.0, 0.0) if kept is None else kept.copy()
        kept[covered] = 0.0
        return kept


def main() -> None:
    oracle_learner.run_with_map(StartPriorMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
