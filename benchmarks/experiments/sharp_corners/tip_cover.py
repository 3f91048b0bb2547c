"""Part 69 of ``README.md``: a sharp corner's tip ahead covered, away from the branch the map
sees, as the rover nears it (a prototype map).

Part 68's ``tip_ahead.py`` found that part 66's always-on oracle covers, as the rover comes up to
a hairpin's junction, the incoming strip's felt ahead of it on the side away from the turn (the
tip, from 0.36 m before the vertex to 0.37 m past it, up to 0.6 m ahead), and that a cover which
waits for a spin cannot give it. :class:`TipCover` gives it from the robot's own map: while the
map's branch side input names a side (felt branched off the rover's strip to that side over its
last commands), fresh felt from :data:`TIP_FROM_M` to :data:`TIP_AHEAD_M` ahead of the axle, on
the other side of the rover's heading (from :data:`INNER_M` toward the branch side outward, out
to :data:`TIP_WIDE_M`), counts visited. With :data:`BESIDE` set, only while the map also holds
felt beside the rover's strip on the branch side (at least :data:`MIN_BESIDE` of felt level
lying :data:`BESIDE_M` off the heading, from :data:`BESIDE_X_M` behind to :data:`TIP_AHEAD_M`
ahead): a second strip running beside the rover's, as a sharp corner's outgoing strip does where
it leaves the incoming one, and not a single strip curving. The numbers were set before the
probes from part 68's trace (the felt the oracle took lay up to 0.6 m ahead and up to 0.24 m to
the outer side of the incoming centreline) and the loops' geometry (strips at most 0.45 m wide,
so a second strip's felt lies 0.3 m or more off a rover riding near its own strip's centre).

:class:`TipCoverMemory` is the goal's map with the tip cover; :class:`TipEdgeCoverMemory` adds it
to ``edge_cover.py``'s spin cover; :class:`TurnTipMemory` is part 71's design, the tip held in the
strip's frame instead. Run as a script it runs a study with every ``fresh_felt`` map a
:class:`TipCoverMemory` (``--edge`` a :class:`TipEdgeCoverMemory`, ``--turn-tip`` a
:class:`TurnTipMemory`). It drives no test loop unless
the study named does.

    .venv/bin/python benchmarks/experiments/sharp_corners/hairpin_trace.py --tip-cover --study benchmarks/experiments/sharp_corners/hairpins.toml --seed 100 101 --repetition 0 1 --workers 2 --out benchmarks/experiments/sharp_corners/results/tip_cover/probe.md
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import edge_cover  # noqa: E402
import oracle_learner  # noqa: E402
import outer_cover  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402

#: [m] the tip cover ahead of the axle: from ...
TIP_FROM_M = 0.0
#: [m] ... to this far ahead
TIP_AHEAD_M = 0.6
#: [m] the cover's inner edge: this far off the heading toward the branch side (0: the heading)
INNER_M = 0.0
#: [m] the cover's outer edge off the heading, away from the branch side
TIP_WIDE_M = 0.5
#: 1: the cover only while felt lies beside the rover's strip on the branch side; 0: whenever the
#: branch side input names a side
BESIDE = 0.0
#: [m] the band off the heading, on the branch side, where felt counts as beside
BESIDE_M = (0.3, 0.8)
#: [m] how far behind the axle felt counts as beside (ahead: to :data:`TIP_AHEAD_M`)
BESIDE_X_M = 0.1
#: the felt (summed levels) beside that turns the cover on
MIN_BESIDE = 3.0


class TipCover:
    """The tip cover (module docstring), for a ``fresh_felt`` map class to inherit first."""

    _points: np.ndarray
    _felt: np.ndarray
    _side: float

    def _tip_side(self) -> int:
        """+1 (left) or -1 (right): the branch side, when the input names one and, with
        :data:`BESIDE`, felt lies beside the rover's strip there; 0: no cover."""
        if self._side == 1.0:
            side = 1
        elif self._side == 0.0:
            side = -1
        else:
            return 0
        if not BESIDE:
            return side
        x, y = self._points[:, 0], side * self._points[:, 1]
        beside = (x >= -BESIDE_X_M) & (x <= TIP_AHEAD_M) & (y >= BESIDE_M[0]) & (y <= BESIDE_M[1])
        return side if float(self._felt[beside].sum()) >= MIN_BESIDE else 0

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)  # type: ignore[misc]
        if kept is None or not where.any():
            return kept
        side = self._tip_side()
        if not side:
            return kept
        x, y = self._points[:, 0], side * self._points[:, 1]
        covered = where & (x >= TIP_FROM_M) & (x <= TIP_AHEAD_M)
        covered &= (y <= INNER_M) & (y >= -TIP_WIDE_M)
        if not covered.any():
            return kept
        kept = kept.copy()
        kept[covered] = 0.0
        return kept


class TipCoverMemory(TipCover, oracle_learner.PrototypeMemory):
    """The goal's ``fresh_felt`` map with the tip cover."""


class TipEdgeCoverMemory(TipCover, edge_cover.EdgeCoverMemory):
    """``edge_cover.py``'s map (the incoming strip's outer side covered in a spin) with the tip
    cover."""


#: :class:`TurnTipMemory`: forward places kept (2 m of the paper's steps)
TIP_TRAIL = 20
#: [m] travel back from the rover of the places the line is fitted through: from ...
LINE_FROM_M = 0.3
#: [m] ... to
LINE_TO_M = 1.5
#: places needed in that range
LINE_PLACES = 4
#: [deg] the heading turned off the line that turns the cover on, and up to which it stays on
TURN_FROM_DEG, TURN_TO_DEG = 45.0, 170.0
#: [m] the cover along the line, from this far behind the rover's foot on it ...
LINE_BACK_M = 0.1
#: [m] ... to this far past it
LINE_AHEAD_M = 0.8
#: [m] off the line: to the outer side (away from the turn) ...
LINE_OUTER_M = 0.3
#: [m] ... and to the turn's side
LINE_INNER_M = 0.1


class ForwardTrailMemory(oracle_learner.PrototypeMemory):
    """The goal's ``fresh_felt`` map that keeps the places of its last :data:`TIP_TRAIL` forward
    commands (``_tip_trail``, oldest first, in the rover frame), moved with the map."""

    def reset(self) -> None:
        super().reset()
        self._tip_trail = np.zeros((0, 2))

    def _move(self, command: int, measured: Any = None) -> None:
        trail = self._tip_trail
        if command == Command.FORWARD:
            trail = np.vstack([trail, np.zeros((1, 2))])[-TIP_TRAIL:]
        super()._move(command, measured)
        self._tip_trail = self._carried(trail, command, measured)

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._tip_trail = self._placed_before(self._tip_trail, command)


class TurnTipMemory(ForwardTrailMemory):
    """Part 71's design: the incoming strip's continuation past where the rover leaves it,
    covered in the strip's frame. The line through the forward places laid :data:`LINE_FROM_M`
    to :data:`LINE_TO_M` of travel back stands for the strip the rover came along; while the
    rover's heading lies :data:`TURN_FROM_DEG` to :data:`TURN_TO_DEG` off it (turned off that
    strip toward the side the heading turned to), the felt along the line from
    :data:`LINE_BACK_M` behind the rover's foot on it to :data:`LINE_AHEAD_M` past it, from
    :data:`LINE_OUTER_M` on the outer side to :data:`LINE_INNER_M` on the turn's side, counts
    visited: the tip, which the rover never crossed. It is held by the places, not the heading,
    and reads no branch side (part 69's cover followed both and flipped)."""

    def _tip_line(self) -> tuple[np.ndarray, np.ndarray] | None:
        """(a point on the line, its unit direction the rover travelled) in the rover frame, or
        None without places enough."""
        trail = self._tip_trail
        if len(trail) < LINE_PLACES:
            return None
        back = outer_cover.travel_back(trail)
        fit = (back >= LINE_FROM_M) & (back <= LINE_TO_M)
        if int(fit.sum()) < LINE_PLACES:
            return None
        chosen = trail[fit]
        return edge_cover.fitted_line(chosen, chosen[0], chosen[-1])

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or not where.any():
            return kept
        line = self._tip_line()
        if line is None:
            return kept
        centre, way = line
        off = -math.degrees(math.atan2(float(way[1]), float(way[0])))  # heading off the line
        if not TURN_FROM_DEG <= abs(off) <= TURN_TO_DEG:
            return kept
        turn = 1.0 if off > 0 else -1.0
        gap = self._points - centre
        along = gap @ way - float(-centre @ way)  # from the rover's foot on the line
        side = turn * (way[0] * gap[:, 1] - way[1] * gap[:, 0])
        covered = where & (along >= -LINE_BACK_M) & (along <= LINE_AHEAD_M)
        covered &= (side >= -LINE_OUTER_M) & (side <= LINE_INNER_M)
        if not covered.any():
            return kept
        kept = kept.copy()
        kept[covered] = 0.0
        return kept


def main() -> None:
    memory_class: type = TipCoverMemory
    for flag, chosen in (("--edge", TipEdgeCoverMemory), ("--turn-tip", TurnTipMemory)):
        if flag in sys.argv:
            sys.argv.remove(flag)
            memory_class = chosen
    oracle_learner.run_with_map(memory_class, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
