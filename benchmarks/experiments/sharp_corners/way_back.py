"""Part 59 of ``README.md``: the way back at a hairpin, by the rover's own motion (a prototype map).

Part 39 ended on a design it did not build: a map that knows which way the rover came, so that
at a hairpin's vertex the felt back along the incoming direction stays visited while the
outgoing strip beside it, within the path's radius of the incoming places, comes back as fresh.
Part 59's traces (``hairpin_trace.py``) show the rover at hairpins past 155°: it reaches the
vertex, the map goes blank, it pivots round and round with nothing fresh (facing the outgoing
strip included) until its path of 40 commands has forgotten the incoming strip; then both strips
come back as fresh felt, and it drives out along one of them, often the one it came by.

:class:`WayBackMemory` is the ``fresh_felt`` map with one thing added. It remembers the place
where the last forward command ended and the direction it came from (moved with the map). When
the rover pivots right after a frame that left the map blank, and the branch side (the map's
fourth input) named a side at that frame, it marks that place ``P`` and that direction: from then
on, felt lying back along the way it came from ``P`` (:data:`ALONG_M` along that line) and to the
branch side of that line by :data:`SIDE_M` or more counts fresh however near the path lies (the
outgoing strip of a corner sharp enough to run back beside the incoming one), until the rover
is more than :data:`ALONG_M`'s far end from ``P`` or :data:`KEEP_COMMANDS` commands have passed.
Everything else is the map's own: what counts as ahead, on the rover's strip, within reach and
in sight. :data:`SIDES` = ``"both"`` takes either side of the line, without the branch side.
The numbers come from the loops' geometry, set before any probe: strips are at most
0.45 m wide, so the incoming strip's felt lies within 0.225 m of its centreline and within about
0.3 m of a line the rover drove off its centre; a hairpin of 155-165 degrees puts its outgoing
strip's centreline 0.17-0.51 m to the side of the incoming one 0.4-1.2 m back from the vertex; the
map looks for the rover's own strip within 1.2 m of the axle.

Part 59 probed it through ``hairpin_trace.py --way-back`` (``--sides``, ``--side-m``; the
README's commands); this script's own study run, below, was not made.

    .venv/bin/python benchmarks/experiments/sharp_corners/way_back.py --seed N --study benchmarks/experiments/sharp_corners/hairpins.toml --out benchmarks/experiments/sharp_corners/results/way_back/hairpins
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402

#: [m] how far back along the incoming direction from P the felt may come back as fresh
ALONG_M = (0.4, 1.2)
#: [m] how far to the branch side of that line it must lie
SIDE_M = 0.3
#: commands after which a marked place is forgotten
KEEP_COMMANDS = 40
#: the branch side's values (the map's fourth input): left, right
LEFT, RIGHT = 1.0, 0.0
#: which side of the line the felt may lie on: "branch" (the side the branch side named at the
#: frame before the pivot; no mark without one) or "both" (either side, no branch side needed)
SIDES = "branch"


class WayBackMemory(oracle_learner.PrototypeMemory):
    """The ``fresh_felt`` map with the way back at a hairpin (see the module docstring)."""

    def reset(self) -> None:
        super().reset()
        # (2, 2): the place after the last forward command and the point 1 m back along the
        # direction it came from, in the rover's frame (None before any forward command)
        self._came: np.ndarray | None = None
        # the marked place and its back point, the side (+1 left, -1 right), commands since
        self._mark: np.ndarray | None = None
        self._mark_side = 0.0
        self._mark_age = 0
        self._blank = False  # the last frame left the map blank
        self._seen_side = 0.5  # the branch side at that frame

    def _carry(self, move: Any) -> None:
        if self._came is not None:
            self._came = move(self._came)
        if self._mark is not None:
            self._mark = move(self._mark)

    def _move(self, command: int, measured: Any = None) -> None:
        pivot_on_blank = command != Command.FORWARD and self._blank
        super()._move(command, measured)
        if measured is None:
            self._carry(lambda p: self._moved(p, command))
        else:
            self._carry(measured.move_points)
        if command == Command.FORWARD:
            self._came = np.array([[0.0, 0.0], [-1.0, 0.0]])
        if self._mark is not None:
            self._mark_age += 1
            far = float(np.hypot(*self._mark[0]))
            if self._mark_age > KEEP_COMMANDS or far > ALONG_M[1]:
                self._mark = None
        if (
            pivot_on_blank
            and self._mark is None
            and self._came is not None
            and (SIDES == "both" or self._seen_side in (LEFT, RIGHT))
        ):
            self._mark = self._came.copy()
            self._mark_side = 1.0 if self._seen_side == LEFT else -1.0
            self._mark_age = 0

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._carry(lambda p: self._placed_before(p, command))

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        self._blank = self.bearing_deg is None
        self._seen_side = float(self._side)

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or self._mark is None:
            return kept
        place, back_point = self._mark
        back = back_point - place
        rel = self._points - place
        along = rel @ back
        side = rel[:, 0] * back[1] - rel[:, 1] * back[0]
        side = np.abs(side) if SIDES == "both" else self._mark_side * side
        way_back = where & (along >= ALONG_M[0]) & (along <= ALONG_M[1]) & (side >= SIDE_M)
        kept = kept.copy()
        kept[way_back] = 1.0
        return kept


def main() -> None:
    oracle_learner.run_with_map(WayBackMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
