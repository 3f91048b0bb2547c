"""Track files: validating a track TOML table (geometry lives in :mod:`.track`, which reads the
file and builds the :class:`~lfd_track.world.track.Track`; this module imports none of it).

Limits (stated in ``tracks/README.md``): at most :data:`MAX_VERTICES` vertices, the felt within a
:data:`MAX_TRACK_SIZE_M` square (centreline plus one strip width on every side), strips
:data:`~lfd_track.world.dimensions.ROVER_BODY_WIDTH_M` to :data:`MAX_WIDTH_M` wide, files up to
:data:`MAX_FILE_BYTES`. The self-intersection test is a uniform-grid broad phase followed by an
exact, vectorised segment-distance test on the candidate pairs, so validation takes time about
linear in the number of vertices (``benchmarks/speed/bench_track_validation.py``: 205 times
faster than the wave-1 all-pairs check at 1,000 vertices, 564 times at 2,000).
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import FileFormatError
from .dimensions import ROVER_BODY_WIDTH_M as ROVER_WIDTH_M

MAX_VERTICES = 10_000
"""Most centreline vertices in a track file."""
MAX_TRACK_SIZE_M = 7.0
"""[m] the felt must fit in a square of this side: with the paper preset (2 mm per texture pixel,
1.5 m of carpet around) its ground texture is then within the renderer's 100 MiB cap."""
MAX_WIDTH_M = 2.0
"""[m] widest strip accepted."""
MAX_FILE_BYTES = 4 << 20
"""Largest track file read."""
MAX_COORDINATE_M = 1000.0
"""[m] largest coordinate accepted (a floor, not a continent)."""
_MAX_LABEL_CHARS = 100
_TRACK_KEYS = {"name", "description", "closed", "width_m", "vertices", "corners"}


def _fail(path: Path | str, problem: str) -> FileFormatError:
    return FileFormatError(path, problem)


def segment_gaps(p1: np.ndarray, p2: np.ndarray, q1: np.ndarray, q2: np.ndarray) -> np.ndarray:
    """Minimum distance [m] between segments p1p2 and q1q2, 0 where they cross; (K, 2) → (K,)."""

    def cross(o: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        return (a[:, 0] - o[:, 0]) * (b[:, 1] - o[:, 1]) - (a[:, 1] - o[:, 1]) * (b[:, 0] - o[:, 0])

    def point_seg(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        ab = b - a
        t = np.clip(((p - a) * ab).sum(axis=1) / (ab * ab).sum(axis=1), 0.0, 1.0)
        return np.linalg.norm(p - (a + t[:, None] * ab), axis=1)

    d1, d2 = cross(q1, q2, p1), cross(q1, q2, p2)
    d3, d4 = cross(p1, p2, q1), cross(p1, p2, q2)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    gaps = np.minimum.reduce(
        [point_seg(p1, q1, q2), point_seg(p2, q1, q2), point_seg(q1, p1, p2), point_seg(q2, p1, p2)]
    )
    return np.where(crossing, 0.0, gaps)


# A segment piece of a valid track keeps every non-adjacent piece at least one width away, so a
# (3 x 2w)-wide square meets at most about 190 segments (disjoint w/2-neighbourhoods in its
# 7w x 7w surroundings, and at most 3 mutually adjacent pieces): more means an intersection.
_MAX_SEGMENTS_NEAR_A_CELL = 200


def check_no_self_intersection(
    source: Path | str, starts: np.ndarray, ends: np.ndarray, closed: bool, width: float
) -> None:
    """Refuse strips that cross or come within one width of a non-adjacent strip.

    Broad phase: points sampled along each segment at most one width apart are binned into
    square cells of side 2 x width; two segments closer than the width then have samples in the
    same or neighbouring cells. Narrow phase: exact distances for those pairs only.
    """
    n = len(starts)
    cell = 2.0 * width
    lengths = np.linalg.norm(ends - starts, axis=1)
    per_segment = np.ceil(lengths / (cell / 2.0)).astype(np.int64) + 1
    owner = np.repeat(np.arange(n), per_segment)
    first = np.concatenate([[0], np.cumsum(per_segment)[:-1]])
    t = (np.arange(len(owner)) - first[owner]) / (per_segment[owner] - 1)
    points = starts[owner] + t[:, None] * (ends - starts)[owner]
    keys = np.floor(points / cell).astype(np.int64)
    members: dict[tuple[int, int], set[int]] = defaultdict(set)
    for (kx, ky), seg in zip(keys.tolist(), owner.tolist(), strict=True):
        members[(kx, ky)].add(seg)
    worst: tuple[int, int, float] | None = None
    for kx, ky in sorted(members):
        here = sorted(members[(kx, ky)])
        near = sorted(
            {
                s
                for dx in (-1, 0, 1)
                for dy in (-1, 0, 1)
                for s in members.get((kx + dx, ky + dy), ())
            }
        )
        if len(near) > _MAX_SEGMENTS_NEAR_A_CELL:  # surely crossing; bound the work
            near = here = near[:_MAX_SEGMENTS_NEAR_A_CELL]
        i, j = (a.ravel() for a in np.meshgrid(np.array(here), np.array(near), indexing="ij"))
        keep = (j > i + 1) & ~(closed & (i == 0) & (j == n - 1))  # adjacent strips overlap anyway
        i, j = i[keep], j[keep]
        if not i.size:
            continue
        gaps = segment_gaps(starts[i], ends[i], starts[j], ends[j])
        bad = np.nonzero(gaps < width)[0]
        if bad.size:
            k = bad[np.lexsort((j[bad], i[bad]))[0]]
            if worst is None or (i[k], j[k]) < worst[:2]:
                worst = (int(i[k]), int(j[k]), float(gaps[k]))
    if worst is not None:
        a, b, gap = worst
        raise _fail(
            source,
            f"self-intersecting strips: segments {a} and {b} come within {gap:.3f} m"
            f" (< width {width} m)",
        )


def parse_track(
    data: dict[str, Any], source: Path | str
) -> tuple[str, np.ndarray, bool, float, dict[str, int]]:
    """Validate a track table; return (name, vertices (V, 2), closed, width_m, label→vertex)."""
    unknown = sorted(set(data) - _TRACK_KEYS)
    if unknown:
        raise _fail(
            source, f"unknown key '{unknown[0]}' (allowed: {', '.join(sorted(_TRACK_KEYS))})"
        )
    name = data.get("name", Path(str(source)).stem)
    if not isinstance(name, str) or not name or len(name) > _MAX_LABEL_CHARS:
        raise _fail(source, f"'name' must be a string of 1..{_MAX_LABEL_CHARS} characters")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise _fail(source, "'description' must be a string")
    closed = data.get("closed", False)
    if not isinstance(closed, bool):
        raise _fail(source, "'closed' must be true or false")
    width = data.get("width_m", 0.30)
    if isinstance(width, bool) or not isinstance(width, (int, float)):
        raise _fail(source, f"'width_m' must be a finite number, got {width!r}")
    try:
        width = float(width)
    except OverflowError:
        width = math.inf
    if not math.isfinite(width):
        raise _fail(source, f"'width_m' must be a finite number, got {data.get('width_m')!r}")
    if width <= 0:
        raise _fail(source, f"'width_m' must be > 0, got {width}")
    if width < ROVER_WIDTH_M:
        raise _fail(source, f"'width_m' {width} m is narrower than the rover ({ROVER_WIDTH_M} m)")
    if width > MAX_WIDTH_M:
        raise _fail(source, f"'width_m' {width} m is wider than {MAX_WIDTH_M} m")
    raw = data.get("vertices")
    min_vertices = 3 if closed else 2
    kind = "a closed" if closed else "an open"
    if not isinstance(raw, list):
        raise _fail(source, "'vertices' must be a list of [x, y] pairs in metres")
    if len(raw) > MAX_VERTICES:
        raise _fail(source, f"{len(raw)} vertices, more than the {MAX_VERTICES} allowed")
    if len(raw) < min_vertices:
        raise _fail(source, f"{kind} track needs at least {min_vertices} vertices, got {len(raw)}")
    if not all(
        isinstance(v, list)
        and len(v) == 2
        and all(isinstance(c, (int, float)) and not isinstance(c, bool) for c in v)
        for v in raw
    ):
        raise _fail(source, "'vertices' must be a list of [x, y] pairs in metres")
    if any(abs(c) > MAX_COORDINATE_M for v in raw for c in v):  # before float(): huge ints
        raise _fail(source, f"'vertices' must lie within ±{MAX_COORDINATE_M:g} m of the origin")
    vertices = np.array(raw, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(vertices).all():
        raise _fail(source, "'vertices' contains NaN or infinity")
    size = vertices.max(axis=0) - vertices.min(axis=0) + 2.0 * width
    if size.max() > MAX_TRACK_SIZE_M:
        raise _fail(
            source,
            f"the felt spans {size[0]:.2f} m x {size[1]:.2f} m, more than the"
            f" {MAX_TRACK_SIZE_M:g} m x {MAX_TRACK_SIZE_M:g} m allowed",
        )
    if closed and np.allclose(vertices[0], vertices[-1]):
        raise _fail(source, "closed track: do not repeat the first vertex at the end")
    starts = vertices if closed else vertices[:-1]
    ends = np.roll(vertices, -1, axis=0) if closed else vertices[1:]
    lengths = np.linalg.norm(ends - starts, axis=1)
    if (lengths < 1e-6).any():
        raise _fail(source, f"segment {int(np.argmin(lengths))} has zero length (repeated vertex)")
    check_no_self_intersection(source, starts, ends, closed, width)
    # Adjacent strips folding back on themselves also intersect.
    n = len(starts)
    for i in range(n - (0 if closed else 1)):
        j = (i + 1) % n
        d1 = (ends[i] - starts[i]) / lengths[i]
        d2 = (ends[j] - starts[j]) / lengths[j]
        if np.dot(d1, d2) < math.cos(math.radians(170)):
            raise _fail(
                source,
                f"self-intersecting strips: the track folds back at vertex {(i + 1) % len(vertices)}",
            )
    corners = data.get("corners", {})
    if not isinstance(corners, dict):
        raise _fail(source, "'corners' must be a table of label = vertex index")
    label_to_vertex: dict[str, int] = {}
    for label, idx in corners.items():
        if not label or len(str(label)) > _MAX_LABEL_CHARS:
            raise _fail(source, f"corner labels must have 1..{_MAX_LABEL_CHARS} characters")
        if isinstance(idx, bool) or not isinstance(idx, int) or not 0 <= idx < len(vertices):
            raise _fail(
                source,
                f"corner '{label}' must name a vertex index 0..{len(vertices) - 1}, got {idx!r}",
            )
        if not closed and idx in (0, len(vertices) - 1):
            raise _fail(source, f"corner '{label}' is an end vertex of an open track")
        label_to_vertex[str(label)] = idx
    if len(set(label_to_vertex.values())) != len(label_to_vertex):
        raise _fail(source, "two corners name the same vertex")
    return name, vertices, closed, width, label_to_vertex
