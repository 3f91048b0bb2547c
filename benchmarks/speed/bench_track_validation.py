"""Track-file validation: the grid broad phase of ``world/track_file.py`` against the wave-1
all-pairs loop (every non-adjacent segment pair tested in Python), measured in the same run on the
same valid tracks: circles of n vertices whose segments are one strip width and a bit long.

Run: ``.venv/bin/python benchmarks/speed/bench_track_validation.py`` — prints a table and writes
``benchmarks/speed/results/track_validation.json``. The peer is skipped above 2,000 vertices (it is
quadratic: minutes); our times are also given alone up to 10,000 vertices.
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import numpy as np

from lfd_track.utils.provenance import environment
from lfd_track.world.track_file import check_no_self_intersection

RESULTS = Path(__file__).resolve().parent / "results" / "track_validation.json"
WIDTH_M = 0.3


def circle(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Segment starts and ends (n, 2) of a closed n-gon with sides of 0.35 m (valid, big)."""
    radius = 0.35 / (2.0 * math.sin(math.pi / n))
    angles = 2.0 * math.pi * np.arange(n) / n
    vertices = radius * np.stack([np.cos(angles), np.sin(angles)], axis=1)
    return vertices, np.roll(vertices, -1, axis=0)


def wave1_check(starts: np.ndarray, ends: np.ndarray, closed: bool, width: float) -> None:
    """The wave-1 validation: every non-adjacent pair, one scalar distance at a time."""

    def point_seg(p, a, b):
        ab = b - a
        t = np.clip(np.dot(p - a, ab) / np.dot(ab, ab), 0.0, 1.0)
        return float(np.linalg.norm(p - (a + t * ab)))

    def cross(o, a, b):
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    n = len(starts)
    for i in range(n):
        for j in range(i + 1, n):
            if j == i + 1 or (closed and i == 0 and j == n - 1):
                continue
            p1, p2, q1, q2 = starts[i], ends[i], starts[j], ends[j]
            d1, d2 = cross(q1, q2, p1), cross(q1, q2, p2)
            d3, d4 = cross(p1, p2, q1), cross(p1, p2, q2)
            if d1 * d2 < 0 and d3 * d4 < 0:
                gap = 0.0
            else:
                gap = min(
                    point_seg(p1, q1, q2),
                    point_seg(p2, q1, q2),
                    point_seg(q1, p1, p2),
                    point_seg(q2, p1, p2),
                )
            if gap < width:
                raise ValueError(f"segments {i} and {j}")


def best_of(repeats: int, fn) -> float:
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sizes", type=int, nargs="*", default=[100, 300, 1000, 2000, 10_000])
    args = parser.parse_args()
    rows = []
    for n in args.sizes:
        starts, ends = circle(n)
        ours = best_of(
            3, lambda s=starts, e=ends: check_no_self_intersection("x", s, e, True, WIDTH_M)
        )
        peer = None
        if n <= 2000:
            peer = best_of(1, lambda s=starts, e=ends: wave1_check(s, e, True, WIDTH_M))
        rows.append(
            {
                "vertices": n,
                "grid_s": ours,
                "wave1_all_pairs_s": peer,
                "speedup": None if peer is None else peer / ours,
            }
        )
        shown = "-" if peer is None else f"{peer:8.3f} s  x{peer / ours:7.1f}"
        print(f"{n:6d} vertices: grid {ours:7.4f} s   all pairs {shown}", flush=True)
    RESULTS.write_text(
        json.dumps(
            {
                "benchmark": "track_validation",
                "method": "best of 3 (grid) / 1 (all pairs) in the same process; valid closed n-gons with 0.35 m sides, width 0.3 m",
                "machine": environment(),
                "rows": rows,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
