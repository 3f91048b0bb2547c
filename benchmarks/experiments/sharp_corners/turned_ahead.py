"""Part 61 of ``README.md``: the way on after a hairpin's turn on a blank map (a prototype map).

Part 59's spins: at a hairpin's vertex the map goes blank and the rover pivots round and round,
passing the heading of the outgoing strip with nothing fresh ahead, because that strip lies
within the path's radius of the incoming one for its first metre or so. A rover that has turned
on the spot some 145–175° with nothing fresh faces back along the way it came, give or take the
hairpin's angle; at a hairpin the strip straight ahead then is the outgoing one, at the incoming
strip's side. :class:`TurnedAheadMemory` is the ``fresh_felt`` map with one thing added: when the
last frame left the map blank and the rover has now turned within :data:`TURN_DEG` since the map
last held fresh felt (either way, summed from the motions the map moves by), it lays, before this
frame's inputs, a corridor straight ahead of the axle (:data:`CORRIDOR_M` along,
:data:`HALF_WIDTH_M` either side of the heading), moved with the map, whose felt counts fresh
however near the path lies; the corridor is forgotten once the axle is past its far end or
:data:`KEEP_COMMANDS` commands have passed. Everything else is the map's own (what counts as
ahead, on the rover's strip, within reach and in sight). The numbers come from the geometry, set
before any run: a 22.9° pivot turns 160° in seven, the window takes that one pivot and no other
(137° and 183° fall outside); the corridor's half width is about half the narrowest strip
(0.25 m) less a margin, its length the map's reach for the rover's own strip (1.2 m).

    .venv/bin/python benchmarks/experiments/sharp_corners/turned_ahead.py --seed N --study benchmarks/experiments/sharp_corners/hairpins.toml --out benchmarks/experiments/sharp_corners/results/turned_ahead/hairpins
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import blank_turn  # noqa: E402
import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402

#: [deg] the turn since the map last held fresh felt (either way) that lays a corridor
TURN_DEG = (145.0, 175.0)
#: [m] the corridor's reach ahead of the axle where it is laid
CORRIDOR_M = 1.2
#: [m] its half width
HALF_WIDTH_M = 0.1
#: commands after which a corridor is forgotten
KEEP_COMMANDS = 20


class TurnedAheadMemory(blank_turn.TurnOnBlank):
    """The ``fresh_felt`` map with the way on after a hairpin's turn (see the module docstring)."""

    def reset(self) -> None:
        super().reset()
        # (2, 2): the corridor's start (the axle where it was laid) and a point 1 m ahead of it,
        # in the rover's frame; None without one
        self._corridor: np.ndarray | None = None
        self._corridor_age = 0
        self._was_blank = False  # the last frame left the map blank

    def _move(self, command: int, measured: Any = None) -> None:
        super()._move(command, measured)  # the turn counted
        if self._corridor is None:
            return
        if measured is None:
            self._corridor = self._moved(self._corridor, command)
        else:
            self._corridor = measured.move_points(self._corridor)
        self._corridor_age += 1
        start, ahead = self._corridor
        along = float(-start @ (ahead - start))  # the axle's advance along the corridor
        if self._corridor_age > KEEP_COMMANDS or along > CORRIDOR_M:
            self._corridor = None

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        if self._corridor is not None:
            self._corridor = self._placed_before(self._corridor, command)

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._settle_without_frame()  # the turn counts every command before this frame
        turned = abs(self._blank_turn)
        if self._was_blank and self._corridor is None and TURN_DEG[0] <= turned <= TURN_DEG[1]:
            self._corridor = np.array([[0.0, 0.0], [1.0, 0.0]])
            self._corridor_age = 0
        super().see(values, levels)  # fresh felt starts the count again
        self._was_blank = self.bearing_deg is None

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or self._corridor is None:
            return kept
        start, ahead = self._corridor
        line = ahead - start
        rel = self._points - start
        along = rel @ line
        across = np.abs(rel[:, 0] * line[1] - rel[:, 1] * line[0])
        inside = where & (along >= 0.0) & (along <= CORRIDOR_M) & (across <= HALF_WIDTH_M)
        kept = kept.copy()
        kept[inside] = 1.0
        return kept


def main() -> None:
    oracle_learner.run_with_map(TurnedAheadMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()
