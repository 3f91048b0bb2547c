"""Procedural felt loops: a seeded distribution of closed tracks, split into train, validation
and test seeds (the rule of the benchmark is in ``tracks/README.md``, "Procedural loops").

A loop is drawn by rejection inside one ``np.random.Generator`` seeded with the loop's seed:
the number of corners and the strip width once, then turning angles and straight lengths until
the loop closes, fits the floor and passes the track-file rules
(:func:`lfd_track.world.track_file.parse_track`). Only the generator's draws and plain float
arithmetic (Python's ``math``, exactly rounded sums) decide a loop, and vertices are rounded to
a micrometre, so the same seed gives the same vertices on every machine.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from ..errors import FileFormatError, LfdTrackError
from .dimensions import ROVER_BODY_WIDTH_M
from .track_file import MAX_TRACK_SIZE_M, parse_track


@dataclass(frozen=True)
class LoopDistribution:
    """The distribution of procedural loops: every loop is counter-clockwise and every vertex is
    a corner labelled ``"1"`` to ``"n"`` in driving order (laps start on corner 1)."""

    min_corners: int = 3
    """Fewest corners; the count is uniform on ``min_corners..max_corners``."""
    max_corners: int = 10
    """Most corners."""
    min_turn_deg: float = 20.0
    """[deg] smallest turning angle at a corner (either sign)."""
    max_turn_deg: float = 165.0
    """[deg] largest turning angle at a corner (either sign); below the track files' 170° fold."""
    min_sharpest_turn_deg: float = 45.0
    """[deg] least cap on a loop's turns: each loop draws its cap uniformly from
    ``max(min_sharpest_turn_deg, sharpest_turn_slack * 360 / n)`` to ``max_turn_deg``, so gentle
    loops (every turn ≤ 60°) and sharp ones both occur."""
    sharpest_turn_slack: float = 1.2
    """How far above the mean left turn of an all-left loop (360° / n) the cap must lie (a cap at
    the mean could only close with every turn exactly at it)."""
    right_turn_probability: float = 0.3
    """Chance that a corner turns right (clockwise) before the loop is made to close."""
    min_straight_widths: float = 1.0
    """Shortest straight, in strip widths."""
    max_straight_m: float = 3.0
    """[m] longest straight."""
    min_width_m: float = 0.25
    """[m] narrowest strip; the width is uniform on ``min_width_m..max_width_m``."""
    max_width_m: float = 0.45
    """[m] widest strip."""
    width_step_m: float = 0.001
    """[m] the width is rounded to a multiple of this."""
    floor_m: float = MAX_TRACK_SIZE_M
    """[m] the centreline plus one width on every side fits a square of this side."""
    vertex_decimals: int = 6
    """Vertices are rounded to this many decimals of a metre (machine-independent loops)."""
    max_attempts: int = 100_000
    """Most turn-and-length draws per loop before giving up (never reached by the default)."""

    def __post_init__(self) -> None:
        if not 3 <= self.min_corners <= self.max_corners:
            raise ValueError("LoopDistribution: need 3 <= min_corners <= max_corners")
        if not 0.0 < self.min_turn_deg < self.max_turn_deg < 170.0:
            raise ValueError("LoopDistribution: need 0 < min_turn_deg < max_turn_deg < 170")
        if not self.min_sharpest_turn_deg <= self.max_turn_deg or self.sharpest_turn_slack < 1.0:
            raise ValueError("LoopDistribution: the turn cap's range is empty")
        if not 0.0 <= self.right_turn_probability < 1.0:
            raise ValueError("LoopDistribution: right_turn_probability must be in [0, 1)")
        if not ROVER_BODY_WIDTH_M <= self.min_width_m <= self.max_width_m:
            raise ValueError(
                f"LoopDistribution: widths must be >= the rover's {ROVER_BODY_WIDTH_M} m"
            )
        if not self.min_straight_widths * self.max_width_m < self.max_straight_m:
            raise ValueError("LoopDistribution: the straights' range is empty")
        if not 0.0 < self.floor_m <= MAX_TRACK_SIZE_M:
            raise ValueError(f"LoopDistribution: floor_m must be in (0, {MAX_TRACK_SIZE_M:g}]")


DEFAULT_LOOPS = LoopDistribution()
"""The benchmark's distribution of loops."""

SPLITS: tuple[str, ...] = ("train", "validation", "test")
"""The splits, in the order that fixes their seed ranges."""
LOOPS_PER_SPLIT = 1_000_000
"""Loop indices of a split are ``0..LOOPS_PER_SPLIT - 1``."""
LOOP_PREFIX = "random"
"""Track names of procedural loops start with ``random:``."""

TURN_BINS: tuple[tuple[float, float], ...] = ((0, 60), (60, 100), (100, 135), (135, 180))
"""[deg] bins of a loop's sharpest turn, each ``(low, high]`` (the first includes 0)."""
TURN_BIN_LABELS: tuple[str, ...] = ("<=60", "60-100", "100-135", ">135")
"""Labels of :data:`TURN_BINS`."""
WIDTH_BINS: tuple[tuple[float, float], ...] = ((0.25, 0.31), (0.31, 0.38), (0.38, 0.45))
"""[m] bins of strip width, each ``(low, high]`` (the first includes its low end)."""
WIDTH_BIN_LABELS: tuple[str, ...] = ("0.25-0.31", "0.31-0.38", "0.38-0.45")
"""Labels of :data:`WIDTH_BINS`."""


class LoopNameError(LfdTrackError, ValueError):
    """A procedural loop's name (``random:<split>:<index>``) that names no loop."""


def loop_seed(split: str, index: int) -> int:
    """The seed of loop ``index`` of ``split``: ``k * LOOPS_PER_SPLIT + index`` for the split's
    position ``k`` in :data:`SPLITS` (so the splits never share a seed)."""
    if split not in SPLITS:
        raise LoopNameError(f"unknown loop split '{split}' (splits: {', '.join(SPLITS)})")
    if isinstance(index, bool) or not isinstance(index, (int, np.integer)):
        raise LoopNameError(f"loop index must be a whole number, got {index!r}")
    if not 0 <= index < LOOPS_PER_SPLIT:
        raise LoopNameError(f"loop index {index} is outside 0..{LOOPS_PER_SPLIT - 1}")
    return SPLITS.index(split) * LOOPS_PER_SPLIT + int(index)


def loop_name(split: str, index: int) -> str:
    """The track name of loop ``index`` of ``split``: ``"random:<split>:<index>"``."""
    loop_seed(split, index)  # refuses what names no loop
    return f"{LOOP_PREFIX}:{split}:{int(index)}"


def is_loop_name(name: object) -> bool:
    """Whether ``name`` is meant as a procedural loop (``random`` or ``random:...``)."""
    return isinstance(name, str) and (name == LOOP_PREFIX or name.startswith(LOOP_PREFIX + ":"))


def drawn_split(name: object) -> str | None:
    """The split that a track name drawing a new loop every episode draws from: ``"random"`` →
    ``"train"``, ``"random:<split>"`` → that split; None for any other name."""
    if name == LOOP_PREFIX:
        return SPLITS[0]
    if isinstance(name, str) and name.startswith(LOOP_PREFIX + ":"):
        split = name[len(LOOP_PREFIX) + 1 :]
        return split if split in SPLITS else None
    return None


def parse_loop_name(name: str) -> tuple[str, int]:
    """``"random:test:17"`` → ``("test", 17)``; anything else raises :class:`LoopNameError`."""
    parts = name.split(":")
    usage = f"{LOOP_PREFIX}:<split>:<index> (splits: {', '.join(SPLITS)})"
    if len(parts) != 3 or parts[0] != LOOP_PREFIX:
        if drawn_split(name) is not None:
            raise LoopNameError(
                f"track '{name}' draws a new loop every episode (the env only); name one loop"
                f" as {usage}"
            )
        raise LoopNameError(f"track '{name}' is not a loop name: use {usage}")
    split, text = parts[1], parts[2]
    if split not in SPLITS:
        raise LoopNameError(
            f"track '{name}': unknown split '{split}' (splits: {', '.join(SPLITS)})"
        )
    if not (text.isascii() and text.isdigit()) or (len(text) > 1 and text[0] == "0"):
        raise LoopNameError(f"track '{name}': the index must be a whole number like 17")
    index = int(text)
    if index >= LOOPS_PER_SPLIT:
        raise LoopNameError(f"track '{name}': index outside 0..{LOOPS_PER_SPLIT - 1}")
    return split, index


def _draw_turns(
    rng: np.random.Generator, n: int, cap_deg: float, dist: LoopDistribution
) -> list[float] | None:
    """n signed turns [deg] in ``[min_turn, cap]`` of either sign summing to +360: magnitudes
    uniform, signs drawn, the last turn set to close the sum; None if no draw of a batch fits."""
    batch = 64
    mags = rng.uniform(dist.min_turn_deg, cap_deg, (batch, n - 1))
    rights = rng.random((batch, n)) < dist.right_turn_probability
    for row in range(batch):
        turns = [
            -m if r else m for m, r in zip(mags[row].tolist(), rights[row].tolist(), strict=False)
        ]
        last = 360.0 - math.fsum(turns)
        if rights[row, -1]:
            ok = -cap_deg <= last <= -dist.min_turn_deg
        else:
            ok = dist.min_turn_deg <= last <= cap_deg
        if ok:
            return [*turns, last]
    return None


def _close(lengths: list[float], cos_h: list[float], sin_h: list[float]) -> list[float]:
    """The lengths nearest to ``lengths`` (least squares) whose straights end where they start."""
    cc, ss = math.fsum(c * c for c in cos_h), math.fsum(s * s for s in sin_h)
    cs = math.fsum(c * s for c, s in zip(cos_h, sin_h, strict=True))
    gx = math.fsum(length * c for length, c in zip(lengths, cos_h, strict=True))
    gy = math.fsum(length * s for length, s in zip(lengths, sin_h, strict=True))
    det = cc * ss - cs * cs
    ax, ay = (ss * gx - cs * gy) / det, (cc * gy - cs * gx) / det
    return [length - (ax * c + ay * s) for length, c, s in zip(lengths, cos_h, sin_h, strict=True)]


@dataclass(frozen=True)
class LoopDraw:
    """One loop as :func:`draw_loop` drew it, with what the rejection cost."""

    vertices: np.ndarray
    """(V, 2) float64 [m], counter-clockwise."""
    width_m: float
    """[m] strip width."""
    corners: dict[str, int]
    """Corner label → vertex index (every vertex, ``"1"`` first)."""
    draws: int
    """Turn-and-length draws made (the last one accepted)."""
    checked: int
    """Draws that reached the track-file check (:func:`~lfd_track.world.track_file.parse_track`)."""


def draw_loop(seed: int, dist: LoopDistribution = DEFAULT_LOOPS) -> LoopDraw:
    """:func:`generate_loop` with how many draws it made and how many reached parse_track."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(dist.min_corners, dist.max_corners + 1))
    steps = round(float(rng.uniform(dist.min_width_m, dist.max_width_m)) / dist.width_step_m)
    width = round(steps * dist.width_step_m, 9)
    low_cap = max(dist.min_sharpest_turn_deg, dist.sharpest_turn_slack * 360.0 / n)
    cap = float(rng.uniform(min(low_cap, dist.max_turn_deg), dist.max_turn_deg))
    shortest = dist.min_straight_widths * width
    parsed = 0
    for attempt in range(1, dist.max_attempts + 1):
        turns = _draw_turns(rng, n, cap, dist)
        if turns is None:
            continue
        # Straight i leaves vertex i; the first runs along +x from the start corner.
        headings = [0.0]
        for turn in turns[1:]:
            headings.append(headings[-1] + math.radians(turn))
        cos_h = [math.cos(h) for h in headings]
        sin_h = [math.sin(h) for h in headings]
        drawn = rng.uniform(shortest, dist.max_straight_m, n).tolist()
        lengths = _close(drawn, cos_h, sin_h)
        if min(lengths) < shortest or max(lengths) > dist.max_straight_m:
            continue
        points = [(0.0, 0.0)]
        for length, c, s in zip(lengths[:-1], cos_h[:-1], sin_h[:-1], strict=True):
            points.append((points[-1][0] + length * c, points[-1][1] + length * s))
        # Python's round() is exactly rounded: the decimals of the file are the vertices.
        digits = dist.vertex_decimals
        vertices = np.array([[round(x, digits) + 0.0, round(y, digits) + 0.0] for x, y in points])
        span = vertices.max(axis=0) - vertices.min(axis=0) + 2.0 * width
        if span.max() > dist.floor_m:
            continue
        parsed += 1
        corners = {str(k + 1): k for k in range(n)}
        table = {
            "closed": True,
            "width_m": width,
            "vertices": vertices.tolist(),
            "corners": corners,
        }
        try:
            parse_track(table, f"{LOOP_PREFIX} seed {seed}")
        except FileFormatError:
            continue
        return LoopDraw(vertices, width, corners, attempt, parsed)
    raise RuntimeError(f"no loop of seed {seed} after {dist.max_attempts} draws")


def generate_loop(
    seed: int, dist: LoopDistribution = DEFAULT_LOOPS
) -> tuple[np.ndarray, float, dict[str, int]]:
    """The loop of ``seed``: vertices (V, 2) float64 [m] counter-clockwise (turns sum to +360°),
    the strip width [m], and corner label → vertex index (every vertex, ``"1"`` first)."""
    drawn = draw_loop(int(seed), dist)
    return drawn.vertices, drawn.width_m, drawn.corners


class _Turning(Protocol):
    @property
    def vertex_turns_rad(self) -> np.ndarray: ...


def sharpest_turn_deg(track: _Turning) -> float:
    """[deg] the largest turning angle of ``track`` (a :class:`~lfd_track.world.track.Track`),
    either sign."""
    return float(np.degrees(np.abs(track.vertex_turns_rad)).max())


def _bin(
    value: float, bins: tuple[tuple[float, float], ...], labels: tuple[str, ...], what: str
) -> str:
    for (low, high), label in zip(bins, labels, strict=True):
        if low <= value <= high and (value > low or (low, high) == bins[0]):
            return label
    raise ValueError(f"{what} {value:g} is outside {bins[0][0]:g}..{bins[-1][1]:g}")


def turn_bin(deg: float) -> str:
    """The label of :data:`TURN_BINS` holding a sharpest turn of ``deg`` [deg]."""
    return _bin(abs(deg), TURN_BINS, TURN_BIN_LABELS, "turn")


def width_bin(width_m: float) -> str:
    """The label of :data:`WIDTH_BINS` holding a strip width of ``width_m`` [m]."""
    return _bin(width_m, WIDTH_BINS, WIDTH_BIN_LABELS, "strip width")
