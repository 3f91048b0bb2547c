"""The map's path as places rather than commands (part 36 of ``README.md``).

The ``fresh_felt`` map keeps the places the rover has been as the last 40 *commands*' places, so
a rover that pivots again and again at a sharp corner's vertex fills its path with the one place
it turns on: after some 35 pivots the path no longer reaches the strip it came along, the felt of
that strip (seen again while it turns) counts fresh, and the rule drives back along it. At the
start of an episode the path is empty, so the felt behind the rover's start counts fresh once the
rover has turned toward it. Part 35's screen frames show both: of the 28 commands the oracle
changes on seed 202, 15 come with a full path reaching at most 0.6 m back and 7 in an episode's
first dozen commands.

This script runs ``../generalization/rules.py`` (its arguments passed on) with every
``fresh_felt`` map made as :class:`PlacesMemory`: a place joins the path only when the rover
stands at least ``--place-m`` from the last one (a pivot on the spot adds none), and with
``--start-behind M`` an episode starts with places every forward step up to M behind the rover
(a rover set down on a trail facing the way it is to go has, as it were, come along it).
With ``--along-felt CELL`` (part 37) a place visits only the felt it reaches without crossing
carpet, and with ``--forget-blank`` (part 38) a pivot made while the map holds no fresh felt still
adds its place, so that a turn on a blank map forgets the path as the map's own does; with
``--blank-radius R`` (part 39) the path visits felt within R instead of ``path_radius_m`` (the
fade beyond it unchanged) from a frame that found no fresh felt until the next forward command.
``--along-felt-run K`` (part 40) asks for K carpet samples in a row, and ``--strip-band R`` (part
41) lets each place visit the felt of its strip as measured abeam when it joined the path, and a
disc of R round it, instead of the map's disc and fade; ``--abeam M`` reads the strip's edges
from the map's points within M along the heading (0.1 m), ``--band-fade`` (part 42) keeps the
map's fade beyond the band and the disc, and ``--bands FILE`` appends each band's width to
FILE.<pid>. ``--tip-ahead L`` (part 44; not with ``--strip-band``) keeps the path as the other
options do and counts visited the felt straight on from a forward move the rover has since turned
``--tip-turn`` degrees (90) or more from, up to L on (part 46: ``--tip-turn 0``, from every
forward move); with ``--tip-on-blank`` (part 49) the corridor is laid instead once a frame
since that move has found no fresh felt.

    .venv/bin/python benchmarks/experiments/sharp_corners/path_places.py --place-m 0.05 --start-behind 0.4 --study benchmarks/experiments/human_goal/round27/balance.toml --condition rooms.round20+visual+balance --rule map-rule --map branch_side=true --map branch_window=commands --map motion=visual --map colour_balance=safe_box --map fresh_sight_m=0.05 --out /tmp/path_places --workers 2
"""

from __future__ import annotations

import math
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_visited  # noqa: E402

from lfd_track.policy.memory import FreshFeltMemory  # noqa: E402

#: ``--place-m`` (0: every command adds a place, as the map does), ``--start-behind``,
#: ``--along-felt`` (part 37: the raster's cell; 0: off), ``--forget-blank`` (part 38: 1 on) and
#: ``--blank-radius`` (part 39; 0: off), ``--along-felt-run`` (part 40: carpet samples in a row
#: that cross; 1 as in part 37) and ``--strip-band`` (part 41: the radius kept round each place;
#: 0: off), ``--tip-ahead`` (part 44: metres on; 0: off), ``--tip-turn`` (degrees) and
#: ``--tip-on-blank`` (part 49: 1 on). The
#: path keeps as many places as the map's own (40).
PLACES = {
    "place_m": 0.0,
    "start_behind_m": 0.0,
    "along_felt_m": 0.0,
    "forget_blank": 0.0,
    "blank_radius_m": 0.0,
    "along_felt_run": 1.0,
    "strip_band": 0.0,
    "band_fade": 0.0,
    "abeam_m": 0.1,
    "tip_ahead_m": 0.0,
    "tip_turn_deg": 90.0,
    "tip_on_blank": 0.0,
}


def crosses_carpet(
    points: np.ndarray,
    felt: np.ndarray,
    starts: np.ndarray,
    ends: np.ndarray,
    cell: float,
    run: int = 1,
) -> np.ndarray:
    """(P,) bool: whether the straight line from each of ``starts`` (P, 2) to the matching one
    of ``ends`` (P, 2) crosses carpet on the map whose ``points`` (N, 2) have the felt levels
    ``felt`` (N,): the map is rastered in squares of ``cell`` metres as ``fresh_sight_m`` does
    (a square's felt the mean of its points', a square with no point not carpet), and the line is
    sampled every ``cell`` from one cell past its start to one cell short of its end; with
    ``run`` above 1 it crosses carpet only where that many samples in a row fall on carpet."""
    origin = points.min(axis=0) - cell
    keys = np.floor((points - origin) / cell).astype(np.int64)
    size = keys.max(axis=0) + 2
    index = keys[:, 0] * size[1] + keys[:, 1]
    total = np.bincount(index, weights=felt, minlength=int(size[0] * size[1]))
    count = np.bincount(index, minlength=int(size[0] * size[1]))
    carpet = (count > 0) & (total < 0.5 * count)
    gap = ends - starts
    length = np.hypot(gap[:, 0], gap[:, 1])
    longest = float(length.max()) if len(length) else 0.0
    steps = np.arange(cell, max(longest, cell), cell)
    unit = gap / np.maximum(length, 1e-9)[:, None]
    at = starts[:, None, :] + unit[:, None, :] * steps[None, :, None]
    cells = np.floor((at - origin) / cell).astype(np.int64)
    outside = (cells < 0).any(axis=2) | (cells >= size[None, None, :]).any(axis=2)
    cells = np.clip(cells, 0, size - 1)
    sampled = (steps[None, :] < length[:, None] - cell) & ~outside
    on = carpet[cells[..., 0] * size[1] + cells[..., 1]] & sampled
    for _ in range(1, run):  # samples k .. k + run - 1 all on carpet
        on = on[:, :-1] & on[:, 1:] if on.shape[1] > 1 else on[:, :0]
    return on.any(axis=1)


class PlacesMemory(FreshFeltMemory):
    """The ``fresh_felt`` map whose path holds places the rover has moved between."""

    #: ``--blank-radius``: a frame has found no fresh felt since the last forward command
    _narrow = False

    def reset(self) -> None:
        super().reset()
        self._narrow = False
        behind = PLACES["start_behind_m"]
        if behind > 0.0:
            steps = int(math.floor(behind / self._step + 1e-9))
            self._path = np.array([[-k * self._step, 0.0] for k in range(steps, 0, -1)])

    def _carried(
        self,
        points: np.ndarray,
        command: int,
        measured=None,  # noqa: ANN001 - PlanarMotion | None
    ) -> np.ndarray:
        """``points`` moved with the map by ``command`` (or the ``measured`` motion)."""
        return self._moved(points, command) if measured is None else measured.move_points(points)

    def _move(self, command: int, measured=None) -> None:  # noqa: ANN001 - PlanarMotion | None
        """The map's own move, but the place the rover stands on joins the path only when it
        lies at least ``--place-m`` from the last place in it."""
        here_already = not self._joins_path()
        kept = self._path
        super()._move(command, measured)
        if here_already:  # the path without the place the map's own move added, moved alike
            self._path = self._carried(kept, command, measured)
        if self._forward:
            self._narrow = False

    def _joins_path(self) -> bool:
        """Whether the place the rover stands on joins the path at the next move: it lies at
        least ``--place-m`` from the last place in it, or, with ``--forget-blank``, the map
        holds no fresh felt."""
        if not len(self._path) or math.hypot(*self._path[-1]) >= PLACES["place_m"]:
            return True
        return bool(PLACES["forget_blank"]) and self._blank()

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        super().see(values, levels)
        if self._blank():
            self._narrow = True

    def _blank(self) -> bool:
        """Whether the last frame the map saw found no fresh felt."""
        return float(self._inputs[1]) <= 0.0

    def _away(self, chosen: np.ndarray, marks: np.ndarray, radius: float) -> np.ndarray:
        """The map's own, but within ``--blank-radius`` from a blank frame to the next forward step,
        and with ``--along-felt`` a point whose straight line from the nearest of ``marks``
        crosses carpet stays fully fresh: a place visits only the felt it reaches along felt,
        not a strip beside its own across a gap of carpet."""
        if PLACES["blank_radius_m"] and self._narrow:
            radius = min(radius, PLACES["blank_radius_m"])
        away = super()._away(chosen, marks, radius)
        cell = PLACES["along_felt_m"]
        if not cell or not len(chosen) or not len(marks):
            return away
        near = away < 1.0
        if not near.any():
            return away
        targets = chosen[near]
        gap_x = targets[:, 0, None] - marks[None, :, 0]
        gap_y = targets[:, 1, None] - marks[None, :, 1]
        nearest = marks[(gap_x * gap_x + gap_y * gap_y).argmin(axis=1)]
        run = int(PLACES["along_felt_run"])
        across = crosses_carpet(self._points, self._felt, nearest, targets, cell, run)
        away[np.flatnonzero(near)[across]] = 1.0
        return away


#: [m] ``--strip-band``: the felt abeam of a new place is read from the map's points within
#: ``--abeam`` (0.1 m) of it along the heading, in lateral bins of ``BIN_M``; a place visits felt
#: within ``ALONG_M`` of it along its heading and out to its strip's measured edges and ``EDGE_M``
#: more
BIN_M, ALONG_M, EDGE_M = 0.05, 0.1, 0.05
#: ``--bands FILE``: each new place's measured band width [m] is appended to FILE.<pid>
BANDS: dict[str, str] = {"file": ""}


def strip_extent(points: np.ndarray, felt: np.ndarray) -> tuple[float, float]:
    """[m] How far the felt abeam of the rover reaches to its right (negative) and left: from
    the lateral bin the axle is in, outward bin by bin while the bins' mean felt is 0.5 or more
    (a bin with no point is passed over, two in a row end it); (0, 0) when the axle's own bin
    is not felt."""
    abeam = np.abs(points[:, 0]) <= PLACES["abeam_m"]
    bins = np.floor(points[abeam, 1] / BIN_M).astype(np.int64)
    level = felt[abeam]
    edges = []
    for step in (-1, 1):
        reach, empty, k = 0.0, 0, 0 if step > 0 else -1
        while abs(k) < 20:
            here = bins == k
            if not here.any():
                empty += 1
                if empty == 2:
                    break
            elif float(level[here].mean()) >= 0.5:
                empty = 0
                reach = (k + 1) * BIN_M if step > 0 else k * BIN_M
            else:
                break
            k += step
        edges.append(reach)
    return edges[0], edges[1]


class StripBandMemory(PlacesMemory):
    """Part 41: each place of the path (forward travel only, with ``--place-m``) visits the felt
    of its own strip as measured abeam when it joined the path, and a disc of ``--strip-band``
    round it, not the map's disc of ``path_radius_m`` and its fade."""

    def reset(self) -> None:
        super().reset()
        self._heads = np.zeros((0, 2))  # a point ALONG_M ahead of each place along its heading
        self._bands = np.zeros((0, 2))  # each place's strip edges, right and left of it [m]

    def _move(self, command: int, measured=None) -> None:  # noqa: ANN001 - PlanarMotion | None
        if self._joins_path():  # record the joining place's heading and band with it
            self._heads = np.vstack([self._heads, [[ALONG_M, 0.0]]])
            band = strip_extent(self._points, self._felt)
            self._bands = np.vstack([self._bands, [band]])
            if BANDS["file"]:
                with open(f"{BANDS['file']}.{os.getpid()}", "a") as out:
                    out.write(f"{band[1] - band[0]:.3f}\n")
        super()._move(command, measured)
        n = len(self._path)
        self._bands = self._bands[-n:]
        heads = self._heads[-n:]
        self._heads = self._carried(heads, command, measured)

    def _away(self, chosen: np.ndarray, marks: np.ndarray, radius: float) -> np.ndarray:
        band_m = PLACES["strip_band"]
        if not band_m or marks is not self._path or len(self._heads) != len(marks):
            return super()._away(chosen, marks, radius)
        gap = chosen[:, None, :] - marks[None, :, :]  # (N, M, 2)
        heading = self._heads - marks
        heading = heading / np.maximum(np.hypot(heading[:, 0], heading[:, 1]), 1e-9)[:, None]
        along = gap[..., 0] * heading[None, :, 0] + gap[..., 1] * heading[None, :, 1]
        left = heading[None, :, 0] * gap[..., 1] - heading[None, :, 1] * gap[..., 0]
        in_band = (
            (np.abs(along) <= ALONG_M)
            & (left >= self._bands[None, :, 0] - EDGE_M)
            & (left <= self._bands[None, :, 1] + EDGE_M)
        )
        in_disc = (gap[..., 0] ** 2 + gap[..., 1] ** 2) <= band_m**2
        if not PLACES["band_fade"]:
            return (~(in_band | in_disc).any(axis=1)).astype(np.float64)
        # --band-fade (part 42): fresh rises over the map's fade with the distance from the
        # nearest band or footprint disc, as the map's own from its disc
        beyond_along = np.maximum(np.abs(along) - ALONG_M, 0.0)
        below = self._bands[None, :, 0] - EDGE_M - left
        above = left - self._bands[None, :, 1] - EDGE_M
        beyond_side = np.maximum(np.maximum(below, above), 0.0)
        from_band = np.hypot(beyond_along, beyond_side)
        from_disc = np.maximum(np.hypot(gap[..., 0], gap[..., 1]) - band_m, 0.0)
        nearest = np.minimum(from_band, from_disc).min(axis=1)
        fade = self.config.visited_fade_m
        if not fade:
            return (nearest > 0.0).astype(np.float64)
        return np.clip(nearest / fade, 0.0, 1.0)


#: ``--tip-ahead L`` (part 44): once the rover's heading has turned ``--tip-turn`` degrees or more
#: (90) from its last forward move, the felt straight on from where that move ended, up to L along
#: it and within ``TIP_HALF_M`` of its line, counts visited; the last ``TIP_KEPT`` such corridors
#: are kept
TIP_HALF_M, TIP_KEPT = 0.25, 4


class PassedTipMemory(PlacesMemory):
    """Part 44: the felt straight on from a stretch the rover turned away from (a corner's tip,
    which a rover that turned before the vertex never drove into) counts visited."""

    def reset(self) -> None:
        super().reset()
        self._stretch = np.zeros((0, 2))  # the last forward move: where it began and ended
        self._tips = np.zeros((0, 2))  # each corridor: its start, then a point 1 m on along it
        self._tipped = False  # the last stretch has its corridor

    def _move(self, command: int, measured=None) -> None:  # noqa: ANN001 - PlanarMotion | None
        if command == 0:  # forward: a new last stretch, from here one step on
            self._stretch, self._tipped = np.array([[0.0, 0.0], [self._step, 0.0]]), False
        super()._move(command, measured)
        self._stretch = self._carried(self._stretch, command, measured)
        self._tips = self._carried(self._tips, command, measured)

    def place_before(self, command: int) -> None:  # type: ignore[override]
        """The map's own; the stretch and the corridors are dropped, not carried (only a view
        for teaching places a map before a command; the map rule never does)."""
        super().place_before(command)
        self._stretch, self._tips, self._tipped = np.zeros((0, 2)), np.zeros((0, 2)), False

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        if not PLACES["tip_on_blank"]:
            self._lay_corridor(turned=True)
        super().see(values, levels)
        if PLACES["tip_on_blank"] and self._blank():
            self._lay_corridor(turned=False)  # part 49: this frame found no fresh felt

    def _lay_corridor(self, turned: bool) -> None:
        """Lay the last stretch's corridor, once, if it has none; with ``turned``, only when the
        rover has turned ``--tip-turn`` degrees or more from it."""
        if not len(self._stretch) or self._tipped:
            return
        start, end = self._stretch
        along = end - start
        length = math.hypot(*along)
        cos = math.cos(math.radians(PLACES["tip_turn_deg"]))
        if length > 0.0 and (not turned or along[0] <= cos * length):
            corridor = np.array([end, end + along / length])
            self._tips = np.vstack([self._tips, corridor])[-2 * TIP_KEPT :]
            self._tipped = True

    def _away(self, chosen: np.ndarray, marks: np.ndarray, radius: float) -> np.ndarray:
        away = super()._away(chosen, marks, radius)
        if marks is not self._path or not len(self._tips) or not len(chosen):
            return away
        for start, on in zip(self._tips[0::2], self._tips[1::2], strict=True):
            unit = on - start
            rel = chosen - start
            along = rel @ unit
            side = unit[0] * rel[:, 1] - unit[1] * rel[:, 0]
            inside = (
                (along >= 0.0) & (along <= PLACES["tip_ahead_m"]) & (np.abs(side) <= TIP_HALF_M)
            )
            away[inside] = 0.0
        return away


def memory_from_args() -> type[PlacesMemory]:
    """The map class this script's options (taken out of ``sys.argv``) ask for."""
    for flag, key in (
        ("--place-m", "place_m"),
        ("--start-behind", "start_behind_m"),
        ("--along-felt", "along_felt_m"),
        ("--blank-radius", "blank_radius_m"),
        ("--along-felt-run", "along_felt_run"),
        ("--strip-band", "strip_band"),
        ("--abeam", "abeam_m"),
        ("--tip-ahead", "tip_ahead_m"),
        ("--tip-turn", "tip_turn_deg"),
    ):
        if flag in sys.argv:
            at = sys.argv.index(flag)
            PLACES[key] = float(sys.argv[at + 1])
            if not PLACES[key] >= 0.0:
                raise SystemExit(f"{flag} takes a number >= 0 (metres; --tip-turn degrees)")
            del sys.argv[at : at + 2]
    if "--forget-blank" in sys.argv:
        PLACES["forget_blank"] = 1.0
        sys.argv.remove("--forget-blank")
    if "--bands" in sys.argv:
        at = sys.argv.index("--bands")
        BANDS["file"] = sys.argv[at + 1]
        del sys.argv[at : at + 2]
    if "--tip-on-blank" in sys.argv:
        PLACES["tip_on_blank"] = 1.0
        sys.argv.remove("--tip-on-blank")
    if PLACES["tip_on_blank"] and not PLACES["tip_ahead_m"]:
        raise SystemExit("--tip-on-blank takes --tip-ahead")
    if "--band-fade" in sys.argv:
        PLACES["band_fade"] = 1.0
        sys.argv.remove("--band-fade")
    if PLACES["strip_band"] and (PLACES["start_behind_m"] or not PLACES["place_m"]):
        raise SystemExit("--strip-band takes --place-m and no --start-behind")
    if PLACES["tip_ahead_m"]:
        if PLACES["strip_band"]:
            raise SystemExit("--tip-ahead takes no --strip-band")
        return PassedTipMemory
    return StripBandMemory if PLACES["strip_band"] else PlacesMemory


def main() -> None:
    oracle_visited.map_rule_with(memory_from_args())


if __name__ == "__main__":
    main()
