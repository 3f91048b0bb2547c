"""Part 62 of ``README.md``: the spin's side of the way it came, narrowed (a prototype map).

Part 59's traces: at a hairpin past 155° the rover reaches the vertex riding the turn's side of the
incoming strip, the map goes blank (the outgoing strip lies within the path's radius and fade of the
incoming places for its first 1.9 m at 160°), and the rover pivots (the corner's way, it was assumed
when this was written; part 62 then counted the first such pivot the other way at 120 of 206
vertices) until its path of 40 commands has forgotten the incoming strip; then the incoming strip's
far part comes back as fresh with the outgoing strip, and pulls the bearing back along it (room
100's repetition 4 on ``random:validation:71``: facing the outgoing strip at 151°, the bearing input
0.82 where the oracle's is 0.63). The rover knows two things there that the map does not use: the
way it came along each place of its path, and which way it is turning on a blank map. At a hairpin
turned the corner's way, the outgoing strip lies on the turn's side of the incoming places; the
incoming strip's felt on that side lies within half its width of the centreline, and the rover,
riding the turn's side, is nearer to it still.

:class:`SpinSideMemory` is the ``fresh_felt`` map with three things added. Each place of the path
keeps the way the rover was travelling there (the heading of the forward command from it; a pivot
keeps the last one), moved with the map. When a frame has left the map blank and the rover has
since pivoted one way (net, since its last forward command), the map enters a *spin* to that
side: the places laid until the rover next drives forward visit the felt on the spin's side of
their travel within :data:`SIDE_RADIUS_M` (fading to fresh over :data:`SIDE_FADE_M`) instead of
the path's radius and fade; the other side, and the places laid after, are as before. The spin
ends when the map as it is finds fresh felt again, or after :data:`END_M` of forward travel.
Everything else is the map's own (what counts as ahead, within reach, in sight). The numbers come
from the loops' geometry, set before any run: strips are at most 0.45 m wide and the rover rides
within about 0.075 m of a strip's centre, so the incoming strip's felt on the turn's side lies
within 0.3 m of its places; at a 160° hairpin the outgoing strip's far edge leaves that band some
0.5 m from the vertex; the outgoing strip leaves the path's own radius and fade (0.65 m) about
1.9 m from it, so the spin ends by 2.0 m.

Part 62 probed both maps through ``hairpin_trace.py --spin-side`` (``--spin-hold``,
``--spin-centres``; the README's table); this script's own study run, below, was not made.

    .venv/bin/python benchmarks/experiments/sharp_corners/spin_side.py --seed N --study benchmarks/experiments/sharp_corners/hairpins.toml --out benchmarks/experiments/sharp_corners/results/spin_side/hairpins
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402

from lfd_track.core.commands import Command  # noqa: E402
from lfd_track.policy.memory import BEHIND_M, MIN_FRESH  # noqa: E402

#: [m] in a spin, the radius within which a place laid before it visits felt on the spin's side
SIDE_RADIUS_M = 0.3
#: [m] the fade beyond it to fully fresh
SIDE_FADE_M = 0.1
#: [m] forward travel after which a spin ends
END_M = 2.0
#: [deg] the net turn since the last forward command that makes a blank map's pivots a spin
MIN_TURN_DEG = 10.0
#: ``--hold``: a spin's pivots add no place to the path until it has turned this far [deg]
HOLD_DEG = 0.0


class SpinSideMemory(oracle_learner.PrototypeMemory):
    """The ``fresh_felt`` map with the spin's side narrowed (see the module docstring)."""

    def reset(self) -> None:
        super().reset()
        self._heads = np.zeros((0, 2))  # each place's way of travel (unit, rover frame)
        self._narrow = np.zeros(0, dtype=bool)  # places laid before the spin's first forward
        self._spin = 0  # +1 left, -1 right, 0 no spin
        self._spin_driven = 0.0  # [m] forward travel since the spin began
        self._spin_forward = False  # the rover has driven forward since the spin began
        self._held = 0.0  # [deg] turned in the spin with no place added
        self._was_blank = False  # the last frame left the map blank
        self.spins = 0
        """Spins entered this episode."""

    def _move(self, command: int, measured: Any = None) -> None:
        forward = command == Command.FORWARD
        if self._spin and not self._spin_forward and not forward and self._held < HOLD_DEG:
            # the spin's pivot turns the map and the path, and adds no place
            path, heads = self._path, self._heads
            super()._move(command, measured)
            if measured is None:
                self._path = self._moved(path, command)
            else:
                self._path = measured.move_points(path)
            self._held += abs(self._command_motion(command, measured)[1])
            self._heads = self._turned_dirs(heads, command, measured)
            return
        if forward or not len(self._heads):
            head = np.array([[1.0, 0.0]])
        else:
            head = self._heads[-1:]
        narrow = bool(self._spin) and not self._spin_forward and not forward
        heads = np.vstack([self._heads, head])[-len(self._path) - 1 :]
        flags = np.append(self._narrow, narrow)[-len(self._path) - 1 :]
        super()._move(command, measured)
        keep = len(self._path)
        self._heads = self._turned_dirs(heads[-keep:], command, measured)
        self._narrow = flags[-keep:]
        advance = self._turn_or_advance(command, measured)
        if advance is not None and self._spin:
            self._spin_forward = True
            self._spin_driven += advance
            if self._spin_driven > END_M:
                self._end_spin()

    def place_before(self, command: Command | int) -> None:
        super().place_before(command)
        self._heads = self._placed_before(self._heads, command, directions=True)

    def _end_spin(self) -> None:
        self._spin, self._spin_driven, self._spin_forward = 0, 0.0, False
        self._narrow = np.zeros(len(self._path), dtype=bool)

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._settle_without_frame()  # every command before this frame moved the map
        if not self._spin and self._was_blank and abs(self._turned) >= MIN_TURN_DEG:
            self._spin = 1 if self._turned > 0 else -1
            self._spin_driven, self._spin_forward, self._held = 0.0, False, 0.0
            self._narrow = np.ones(len(self._path), dtype=bool)
            self.spins += 1
        super().see(values, levels)
        if self._spin and self._plain_mass() >= MIN_FRESH:
            self._end_spin()
        self._was_blank = self.bearing_deg is None

    def _plain_mass(self) -> float:
        """The fresh felt's mass the map as it is finds in this frame (within the blank reach)."""
        spin, self._spin = self._spin, 0
        try:
            points = self._points
            dist = np.hypot(points[:, 0], points[:, 1])
            reach = self.config.blank_reach_m or self.config.reach_m
            ahead = points[:, 0] > -BEHIND_M
            if self.config.strip_link_m:
                ahead &= self._own_strip(dist)
            return float(self._fresh(dist < reach, ahead).sum())
        finally:
            self._spin = spin

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        kept = super()._kept(where)
        if kept is None or not self._spin or not self._narrow.any():
            return kept
        chosen = self._points[where]
        marks, heads = self._path[self._narrow], self._heads[self._narrow]
        gap = chosen[:, None, :] - marks[None, :, :]
        dist = np.hypot(gap[..., 0], gap[..., 1])
        lateral = heads[None, :, 0] * gap[..., 1] - heads[None, :, 1] * gap[..., 0]
        radius, fade = self.config.path_radius_m, self.config.visited_fade_m
        plain = (dist - radius) / fade if fade else (dist > radius).astype(np.float64)
        side = (dist - SIDE_RADIUS_M) / SIDE_FADE_M
        near = np.clip(np.where(self._spin * lateral > 0.0, side, plain), 0.0, 1.0).min(axis=1)
        others = ~self._narrow
        if others.any():
            near = np.minimum(near, self._away(chosen, self._path[others], radius))
        kept = kept.copy()
        kept[where] = near
        return kept


def main() -> None:
    oracle_learner.run_with_map(SpinSideMemory, __doc__.splitlines()[0])


if __name__ == "__main__":
    main()


#: [m] ``SpinCentresMemory``: in a spin, felt within this of a centre of the strip is visited
#: (the widest strips' half width, 0.225 m, and a margin; no fade)
CENTRE_BAND_M = 0.25


class SpinCentresMemory(SpinSideMemory):
    """``--centres``: the spin's visited felt measured from the strip's centreline. The map also
    keeps the centres of the strip the rover follows, as ``visited_from = "centreline"`` finds
    them (the felt abeam 0.1–0.3 m behind the axle after each forward command, near the last
    one's side offset; pivots add none). In a spin, felt counts visited within
    :data:`CENTRE_BAND_M` of those centres, or within the path's radius and fade of the places
    laid since the spin's first forward command; the places laid before (the way the rover came,
    and its pivots at the vertex) count no more, so at a hairpin the incoming strip stays visited
    across its width and its whole remembered length, whichever way the rover turns, while the
    outgoing strip's far side comes back once it lies a band's width from the incoming centres
    (about 0.35 m from a 160° vertex). The spin ends only after :data:`END_M` of forward
    travel (the map as it is may find the incoming strip fresh again after a long spin)."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        self._settle_without_frame()
        if self._forward:  # the abeam felt was seen by earlier frames
            self._mark_strip_centre()
        else:
            self._lane_y = None
        super().see(values, levels)

    def _plain_mass(self) -> float:
        return 0.0  # the spin ends by travel alone

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        if not self._spin or not len(self._centres):
            return super(SpinSideMemory, self)._kept(where)
        chosen = self._points[where]
        gap_x = chosen[:, 0, None] - self._centres[None, :, 0]
        gap_y = chosen[:, 1, None] - self._centres[None, :, 1]
        near = ((gap_x * gap_x + gap_y * gap_y).min(axis=1) > CENTRE_BAND_M**2).astype(float)
        after = ~self._narrow
        if after.any():
            near = np.minimum(
                near, self._away(chosen, self._path[after], self.config.path_radius_m)
            )
        kept = np.zeros(len(self._points))
        kept[where] = near
        return kept


class SpinBandMemory(SpinCentresMemory):
    """``--spin-band``: in a spin, the map as it is, and also the felt within
    :data:`CENTRE_BAND_M` of the strip's centres visited. The path still forgets its places as the
    rover pivots; the centres do not, so once a long spin has flushed the incoming places from
    the path, the band still covers the incoming strip, as part 12's oracle covers the felt the
    track puts behind, while the places at the vertex keep the felt round it visited."""

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        own = super(SpinSideMemory, self)._kept(where)
        if own is None or not self._spin or not len(self._centres):
            return own
        chosen = self._points[where]
        gap_x = chosen[:, 0, None] - self._centres[None, :, 0]
        gap_y = chosen[:, 1, None] - self._centres[None, :, 1]
        band = ((gap_x * gap_x + gap_y * gap_y).min(axis=1) > CENTRE_BAND_M**2).astype(float)
        own = own.copy()
        own[where] = np.minimum(own[where], band)
        return own
