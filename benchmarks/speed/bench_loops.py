"""Procedural loops: how long drawing one loop takes (``lfd_track.world.loops.generate_loop``),
how many draws the rejection needs, and, as the peer measured in the same run, how long the
track-file check (``parse_track``) of the finished loop takes alone.

Run: ``.venv/bin/python benchmarks/speed/bench_loops.py [--loops 1000]`` — prints mean and
maximum milliseconds per loop over the first N loops of each split, the rejection rate, and writes
``benchmarks/speed/results/loops.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

from lfd_track.utils.provenance import environment
from lfd_track.world.loops import DEFAULT_LOOPS, SPLITS, draw_loop, loop_seed
from lfd_track.world.track_file import parse_track

RESULTS = Path(__file__).resolve().parent / "results" / "loops.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--loops", type=int, default=1000, help="loops per split (default 1000)")
    args = parser.parse_args()
    rows = []
    for split in SPLITS:
        times, checks, draws, parsed = [], [], [], []
        for index in range(args.loops):
            start = time.perf_counter()
            drawn = draw_loop(loop_seed(split, index), DEFAULT_LOOPS)
            vertices, width, corners = drawn.vertices, drawn.width_m, drawn.corners
            attempts, to_parse = drawn.draws, drawn.checked
            times.append(time.perf_counter() - start)
            table = {"closed": True, "width_m": width, "vertices": vertices.tolist()}
            start = time.perf_counter()
            parse_track({**table, "corners": corners}, "bench")
            checks.append(time.perf_counter() - start)
            draws.append(attempts)
            parsed.append(to_parse)
        row = {
            "split": split,
            "loops": args.loops,
            "mean_ms": 1e3 * statistics.fmean(times),
            "median_ms": 1e3 * statistics.median(times),
            "max_ms": 1e3 * max(times),
            "parse_track_mean_ms": 1e3 * statistics.fmean(checks),
            "generate_over_parse_track": statistics.fmean(times) / statistics.fmean(checks),
            "draws_per_loop": statistics.fmean(draws),
            "draws_rejected": 1.0 - len(draws) / sum(draws),
            "parse_track_calls_per_loop": statistics.fmean(parsed),
            "refused_by_parse_track": 1.0 - len(parsed) / sum(parsed),
        }
        rows.append(row)
        print(
            f"{split:>10}: {row['mean_ms']:6.2f} ms mean, {row['median_ms']:6.2f} median,"
            f" {row['max_ms']:7.1f} max per loop ({row['generate_over_parse_track']:.1f} x one"
            f" parse_track); {row['draws_per_loop']:.2f} draws per loop"
            f" ({100 * row['draws_rejected']:.0f} % rejected),"
            f" {100 * row['refused_by_parse_track']:.0f} % of parse_track calls refused",
            flush=True,
        )
    RESULTS.write_text(
        json.dumps(
            {
                "benchmark": "loops",
                "method": "wall time of each generate_loop in one process, first N loops of each"
                " split; the peer is one parse_track of the finished loop",
                "machine": environment(),
                "rows": rows,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
