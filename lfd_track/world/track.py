"""Track geometry: centreline, felt strips, arc length and continuous progress.

A track is a centreline polyline of straight felt strips (file format: tracks/README.md). Coordinates are metres,
x to the right and y up when seen from above; loops are listed counter-clockwise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

import numpy as np

from ..core.config import read_toml
from ..errors import FileFormatError, LfdTrackError
from ..utils.data import resolve_data_file
from .loops import (
    DEFAULT_LOOPS,
    LoopDistribution,
    generate_loop,
    is_loop_name,
    loop_name,
    loop_seed,
    parse_loop_name,
)
from .track_file import MAX_FILE_BYTES, parse_track

#: Shipped loops of our own design that no demonstration uses: a generalization set beside the
#: paper's testing track (``tracks/README.md``).
UNSEEN_TRACKS: tuple[str, ...] = ("notch", "bolt", "step")
#: Two more unseen loops of ours, added later and scored beside :data:`UNSEEN_TRACKS` where a
#: study lists them (``tracks/README.md``); like them, never used to choose anything.
MORE_UNSEEN_TRACKS: tuple[str, ...] = ("arrow", "zed")
#: Loops of ours for choosing settings only, never scored as unseen (``tracks/README.md``).
VALIDATION_TRACKS: tuple[str, ...] = ("kite", "cove", "ledge")


@dataclass(frozen=True)
class Corner:
    """A named corner of the track, at a centreline vertex."""

    label: str
    vertex: int  # index into Track.vertices (driving order)
    s_m: float  # arc length of the vertex from the start [m]
    turn_deg: float  # turning angle at the vertex, positive = left (counter-clockwise) [deg]


@dataclass(frozen=True)
class Track:
    """A track as driven: vertices in driving order, starting at the start point.

    ``vertices`` has shape (V, 2) float64 [m]. For a loop the start vertex is not repeated at the
    end; ``segment_starts``/``segment_ends`` list the driven segments (V for a loop, V-1 if open).
    """

    name: str
    source: str
    vertices: np.ndarray
    closed: bool
    width_m: float
    corners: tuple[Corner, ...]
    reversed: bool = False

    # ---- derived geometry -------------------------------------------------------------
    @cached_property
    def segment_starts(self) -> np.ndarray:
        """(S, 2) start points of the driven segments [m]."""
        return self.vertices if self.closed else self.vertices[:-1]

    @cached_property
    def segment_ends(self) -> np.ndarray:
        """(S, 2) end points of the driven segments [m]."""
        return np.roll(self.vertices, -1, axis=0) if self.closed else self.vertices[1:]

    @cached_property
    def segment_lengths(self) -> np.ndarray:
        """(S,) segment lengths [m]."""
        return np.linalg.norm(self.segment_ends - self.segment_starts, axis=1)

    @cached_property
    def segment_s(self) -> np.ndarray:
        """(S,) arc length at the start of each segment [m]."""
        return np.concatenate([[0.0], np.cumsum(self.segment_lengths)[:-1]])

    @cached_property
    def length_m(self) -> float:
        """Centreline length: perimeter for a loop, end-to-end length if open [m]."""
        return float(self.segment_lengths.sum())

    @cached_property
    def vertex_turns_rad(self) -> np.ndarray:
        """(V,) signed turning angle at each vertex, left positive [rad]; 0 at open-track ends."""
        return vertex_turns_rad(self.vertices, self.closed)

    def strip_polygons(self) -> list[np.ndarray]:
        """Felt strips as (4, 2) rectangles [m], counter-clockwise corners.

        Each strip is extended by half the width past both of its ends, except the two ends of an
        open track, so strips overlap at corners as laid fabric does.
        """
        half = self.width_m / 2.0
        polys = []
        n = len(self.segment_starts)
        for i, (a, b) in enumerate(zip(self.segment_starts, self.segment_ends, strict=True)):
            d = (b - a) / np.linalg.norm(b - a)
            nrm = np.array([-d[1], d[0]])
            ext_a = 0.0 if (not self.closed and i == 0) else half
            ext_b = 0.0 if (not self.closed and i == n - 1) else half
            a2, b2 = a - d * ext_a, b + d * ext_b
            polys.append(
                np.array([a2 - nrm * half, b2 - nrm * half, b2 + nrm * half, a2 + nrm * half])
            )
        return polys

    def bounds(self, margin_m: float = 0.0) -> tuple[float, float, float, float]:
        """(xmin, ymin, xmax, ymax) of the felt plus ``margin_m`` [m]."""
        pts = np.concatenate(self.strip_polygons())
        lo, hi = pts.min(axis=0) - margin_m, pts.max(axis=0) + margin_m
        return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])

    @cached_property
    def _strip_frames(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Per strip: start (S, 2), unit direction (S, 2), length, back and front extension [m]."""
        a = self.segment_starts
        lengths = self.segment_lengths
        d = (self.segment_ends - a) / lengths[:, None]
        half = self.width_m / 2.0
        ext_a = np.full(len(a), half)
        ext_b = np.full(len(a), half)
        if not self.closed:
            ext_a[0] = 0.0
            ext_b[-1] = 0.0
        return a, d, lengths, ext_a, ext_b

    @cached_property
    def _felt_test(self) -> tuple[np.ndarray, ...]:
        """Per strip, as contiguous (S,) arrays: start x and y, direction x and y, minus the
        direction's y, the extent along the strip (from minus the back extension to the length
        plus the front one), and half the width (S, the same for every strip)."""
        a, d, lengths, ext_a, ext_b = self._strip_frames
        half = np.full(len(a), self.width_m / 2.0)
        columns = (a[:, 0], a[:, 1], d[:, 0], d[:, 1], -d[:, 1], -ext_a, lengths + ext_b, half)
        return tuple(np.ascontiguousarray(c) for c in columns)

    def on_felt(self, points: np.ndarray) -> np.ndarray:
        """Whether each of ``points`` (..., 2) [m] lies on the felt; returns bool array (...).

        Each point relative to each strip's start, measured along the strip and across it, as
        ``rel @ d`` and ``rel @ (-d_y, d_x)`` element by element (``-r_x * d_y`` as ``r_x *
        (-d_y)``: the same number), with the strip-wise constants computed once."""
        pts = np.asarray(points, dtype=np.float64)
        flat = pts.reshape(-1, 2)
        ax, ay, dx, dy, minus_dy, low, high, half = self._felt_test
        rx = flat[:, 0, None] - ax  # (P, S)
        ry = flat[:, 1, None] - ay
        along = rx * dx
        along += ry * dy
        across = rx * minus_dy
        across += ry * dx
        inside = along >= low
        inside &= along <= high
        np.abs(across, out=across)
        inside &= across <= half
        return np.logical_or.reduce(inside, axis=1).reshape(pts.shape[:-1])

    def point_at(self, s_m: float) -> tuple[np.ndarray, float]:
        """Centreline point (2,) [m] and heading [rad] at arc length ``s_m`` (wrapped on loops)."""
        length = self.length_m
        s = s_m % length if self.closed else min(max(s_m, 0.0), length)
        seg_s = self.segment_s
        i = int(np.searchsorted(seg_s, s, side="right") - 1)
        i = min(max(i, 0), len(seg_s) - 1)
        a, b = self.segment_starts[i], self.segment_ends[i]
        d = (b - a) / self.segment_lengths[i]
        return a + d * (s - seg_s[i]), math.atan2(d[1], d[0])

    def project(self, point: np.ndarray) -> np.ndarray:
        """Arc length of the foot of ``point`` (2,) on every segment, and distance: (S, 2) [m];
        for points (..., 2), each point's: (..., S, 2)."""
        a, b = self.segment_starts, self.segment_ends
        lengths = self.segment_lengths
        d = (b - a) / lengths[:, None]
        points = np.asarray(point, dtype=np.float64)[..., None, :]
        rel = points - a
        t = np.clip((rel * d).sum(axis=-1), 0.0, lengths)
        foot = a + d * t[..., None]
        dist = np.linalg.norm(points - foot, axis=-1)
        return np.stack([self.segment_s + t, dist], axis=-1)


class ProgressTracker:
    """Continuous arc-length progress of a point moving along a track.

    Each segment owns the zone between the bisectors of its two end vertices; inside it a point's
    progress interpolates between those bisectors along the line at the point's lateral offset, so
    progress equals the arc length on the centreline and is continuous everywhere near the track,
    also on the inside of sharp corners (plain closest-point projection jumps there).

    Progress is unwrapped (it keeps growing past the perimeter on a loop). After the first update,
    each update only considers positions within ``window_m`` of the previous progress, so a pose is
    never snapped to a far segment that happens to be close (e.g. across the 135° corner).
    """

    def __init__(self, track: Track, start_progress_m: float = 0.0, window_m: float = 0.6) -> None:
        self.track = track
        self.window_m = window_m
        self.progress_m = float(start_progress_m)
        self._first = True
        a, b = track.segment_starts, track.segment_ends
        self._a = a
        self._len = track.segment_lengths
        self._dir = (b - a) / self._len[:, None]
        self._s0 = track.segment_s
        n = len(a)
        turns = track.vertex_turns_rad
        m = len(turns)
        start_idx = np.arange(n)
        end_idx = (start_idx + 1) % m
        self._tan0 = np.tan(turns[start_idx] / 2.0)
        self._tan1 = np.tan(turns[end_idx] / 2.0)
        # The same numbers as Python floats, one tuple per segment, for ``update``: a track has a
        # few segments, and the arithmetic of a handful of floats costs less in Python than the
        # calls of some twenty numpy operations on arrays that short.
        self._segments = tuple(
            zip(
                a[:, 0].tolist(),
                a[:, 1].tolist(),
                self._dir[:, 0].tolist(),
                self._dir[:, 1].tolist(),
                self._len.tolist(),
                self._s0.tolist(),
                self._tan0.tolist(),
                self._tan1.tolist(),
                strict=True,
            )
        )

    def candidates(self, point: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Progress on every segment's zone (S,) [m] and a closeness cost (S,) [m]."""
        rel = np.asarray(point, dtype=np.float64)[None, :] - self._a
        along = rel[:, 0] * self._dir[:, 0] + rel[:, 1] * self._dir[:, 1]
        lateral = -rel[:, 0] * self._dir[:, 1] + rel[:, 1] * self._dir[:, 0]  # left positive
        a0 = lateral * self._tan0
        a1 = self._len - lateral * self._tan1
        span = np.maximum(a1 - a0, 1e-6)
        u = (along - a0) / span
        inside = (u >= 0.0) & (u <= 1.0) & (a1 - a0 > 1e-6)
        u_clipped = np.clip(u, 0.0, 1.0)
        s = self._s0 + u_clipped * self._len
        outside_by = np.where(inside, 0.0, np.abs(u - u_clipped) * span)
        cost = np.abs(lateral) + outside_by
        return s, cost

    def update(self, point: np.ndarray) -> float:
        """Advance to the progress of ``point`` (2,) [m]; returns the new progress [m].

        The arithmetic of :meth:`candidates` and of the choice below, float by float in the same
        order (the same IEEE operations numpy applies element by element), so the same progress
        to the bit; a point that is not finite takes the array path (:meth:`_update_arrays`)."""
        x, y = float(point[0]), float(point[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            return self._update_arrays(point)
        track = self.track
        closed = track.closed
        length = track.length_m
        progress = self.progress_m
        s_all: list[float] = []
        cost_all: list[float] = []
        for ax, ay, dx, dy, seg_len, s0, tan0, tan1 in self._segments:
            rx, ry = x - ax, y - ay
            along = rx * dx + ry * dy
            lateral = -rx * dy + ry * dx
            a0 = lateral * tan0
            a1 = seg_len - lateral * tan1
            width = a1 - a0
            span = width if width > 1e-6 else 1e-6
            u = (along - a0) / span
            # np.clip(u, 0, 1): the larger of u and 0 (0 for -0.0), then the smaller of that and 1.
            clipped = u if u > 0.0 else 0.0
            clipped = clipped if clipped < 1.0 else 1.0
            s = s0 + clipped * seg_len
            inside = u >= 0.0 and u <= 1.0 and width > 1e-6
            cost = abs(lateral) + (0.0 if inside else abs(u - clipped) * span)
            if closed:
                # np.round: half to even, with the sign of a zero kept.
                ratio = (progress - s) / length
                k = math.copysign(float(round(ratio)), ratio)
                s = s + k * length
            s_all.append(s)
            cost_all.append(cost)
        best = 0
        if self._first:
            # First fix: the globally closest zone (ties go to the earliest segment).
            self._first = False
            for i, c in enumerate(cost_all):
                if c < cost_all[best]:
                    best = i
        else:
            delta = [abs(s - progress) for s in s_all]
            window = self.window_m
            ok = [d <= window for d in delta]
            if not any(ok):
                # Far from everywhere we could have reached: keep the nearest in arc length.
                limit = min(delta) + 1e-9
                ok = [d <= limit for d in delta]
            best_cost = math.inf
            for i, c in enumerate(cost_all):
                if ok[i] and c < best_cost:
                    best, best_cost = i, c
        self.progress_m = s_all[best]
        return self.progress_m

    def _update_arrays(self, point: np.ndarray) -> float:
        """:meth:`update` on numpy arrays (the reference the float-by-float path follows)."""
        track = self.track
        length = track.length_m
        s_candidates, cost = self.candidates(point)
        if track.closed:
            # Unwrap each candidate to the lap copy nearest to the current progress.
            k = np.round((self.progress_m - s_candidates) / length)
            s_candidates = s_candidates + k * length
        if self._first:
            # First fix: the globally closest zone (ties go to the earliest segment).
            self._first = False
            best = int(np.argmin(cost))
        else:
            delta = np.abs(s_candidates - self.progress_m)
            ok = delta <= self.window_m
            if not ok.any():
                # Far from everywhere we could have reached: keep the nearest in arc length.
                ok = delta <= delta.min() + 1e-9
            best = int(np.argmin(np.where(ok, cost, np.inf)))
        self.progress_m = float(s_candidates[best])
        return self.progress_m


class StartCornerError(LfdTrackError, ValueError):
    """A ``start_corner`` argument that does not fit the track."""


def vertex_turns_rad(vertices: np.ndarray, closed: bool) -> np.ndarray:
    """(V,) signed turning angle at each of ``vertices`` (V, 2), left positive [rad].

    The two end vertices of an open track have no turn (0).
    """
    incoming = vertices - np.roll(vertices, 1, axis=0)
    outgoing = np.roll(vertices, -1, axis=0) - vertices
    cross = incoming[:, 0] * outgoing[:, 1] - incoming[:, 1] * outgoing[:, 0]
    dot = (incoming * outgoing).sum(axis=1)
    turns = np.arctan2(cross, dot)
    if not closed:
        turns[[0, -1]] = 0.0
    return turns


def build_track(
    name: str,
    vertices: np.ndarray,
    closed: bool,
    width_m: float,
    label_to_vertex: dict[str, int],
    *,
    reverse: bool = False,
    start_corner: str | None = None,
    source: str = "<memory>",
) -> Track:
    """Make a Track in driving order from file-order geometry."""
    verts = np.asarray(vertices, dtype=np.float64)
    index = np.arange(len(verts))
    if reverse:
        # A reversed loop keeps its file start vertex first; an open track starts at its far end.
        shift = 1 if closed else 0
        verts = np.roll(verts[::-1], shift, axis=0)
        index = np.roll(index[::-1], shift)
    if start_corner is not None:
        if not closed:
            raise StartCornerError(f"start_corner='{start_corner}': track '{name}' is not a loop")
        if start_corner not in label_to_vertex:
            raise StartCornerError(
                f"start_corner='{start_corner}': track '{name}' has no such corner"
                f" (corners: {', '.join(label_to_vertex)})"
            )
        pos = int(np.nonzero(index == label_to_vertex[start_corner])[0][0])
        verts = np.roll(verts, -pos, axis=0)
        index = np.roll(index, -pos)
    track = Track(
        name=name,
        source=source,
        vertices=verts,
        closed=closed,
        width_m=width_m,
        corners=(),
        reversed=reverse,
    )
    seg_s = np.concatenate([track.segment_s, [track.length_m]])
    corners = []
    for label, file_idx in label_to_vertex.items():
        drive_idx = int(np.nonzero(index == file_idx)[0][0])
        s = float(seg_s[drive_idx])
        if closed and drive_idx == 0:
            s = track.length_m  # the start corner is met at the end of the lap
        turn_deg = math.degrees(track.vertex_turns_rad[drive_idx])
        corners.append(Corner(label, drive_idx, s, turn_deg))
    corners.sort(key=lambda c: c.s_m)
    return Track(
        name=name,
        source=source,
        vertices=verts,
        closed=closed,
        width_m=width_m,
        corners=tuple(corners),
        reversed=reverse,
    )


def loop_track(
    split: str,
    index: int,
    *,
    reverse: bool = False,
    start_corner: str | None = None,
    dist: LoopDistribution = DEFAULT_LOOPS,
) -> Track:
    """Loop ``index`` of ``split`` (:mod:`lfd_track.world.loops`) as a :class:`Track` named (and
    sourced) ``random:<split>:<index>``."""
    name = loop_name(split, index)
    vertices, width, corners = generate_loop(loop_seed(split, index), dist)
    return build_track(
        name,
        vertices,
        True,
        width,
        corners,
        reverse=reverse,
        start_corner=start_corner,
        source=name,
    )


def load_track(
    name_or_path: str | Path, *, reverse: bool = False, start_corner: str | None = None
) -> Track:
    """Load a shipped track by name (``"testing"``), a procedural loop by name
    (``"random:test:17"``, :mod:`lfd_track.world.loops`) or a track TOML file, in driving order.

    Raises FileFormatError (one line naming the file and the problem) for malformed files; the
    file format and its limits are in :mod:`lfd_track.world.track_file`.
    """
    if is_loop_name(name_or_path):
        split, index = parse_loop_name(str(name_or_path))
        return loop_track(split, index, reverse=reverse, start_corner=start_corner)
    path = resolve_data_file("tracks", name_or_path)
    data = read_toml(path, max_bytes=MAX_FILE_BYTES, what="track")
    name, vertices, closed, width, corners = parse_track(data, path)
    try:
        return build_track(
            name,
            vertices,
            closed,
            width,
            corners,
            reverse=reverse,
            start_corner=start_corner,
            source=str(path),
        )
    except StartCornerError:
        raise  # the argument is wrong, not the file
    except ValueError as exc:
        raise FileFormatError(path, str(exc).split(": ", 1)[-1]) from None
