"""Closed-loop steps/s of this checkout against an older one, on one thread, same machine.

The closed loop is ``bench_env.ClosedLoop`` (frame → road values against a full library → MLP
→ command → env, random controllers, resets included), each side run from its own source tree
with that tree's own ``bench_env``, so each measures the code it had. The two sides alternate in
separate processes, ``--rounds`` times each, and the ratio is the median of the per-round ratios
(this checkout over the baseline). Used for the throughput target stated against the wave-2
renderer: make the baseline with ``git worktree add --detach /tmp/wave2 05b46a1`` (the last
commit before the mipmap filter and the floor benchmark).

Run: ``.venv/bin/python benchmarks/speed/bench_against_commit.py --baseline /tmp/wave2
[--rounds 5] [--seconds 3]`` — prints each round and writes
``benchmarks/speed/results/against_commit.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

from single_thread import load_average, run_facts, source_state

from lfd_track.utils.atomic import atomic_write_text

HERE = Path(__file__).resolve().parent
REPO = HERE.parents[1]
RESULTS = HERE / "results" / "against_commit.json"

# Run in a fresh interpreter with the tree first on sys.path; prints steps/s.
_CHILD = """
import sys, time
tree, seconds = sys.argv[1], float(sys.argv[2])
sys.path[:0] = [tree, tree + "/benchmarks/speed"]
from single_thread import pin_one_thread
pin_one_thread()
import lfd_track
assert lfd_track.__file__.startswith(tree), lfd_track.__file__
from bench_env import ClosedLoop, full_library
loop = ClosedLoop(0, full_library(0))
def rate(s):
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < s:
        if loop.step():
            loop.reset()
        n += 1
    return n / (time.perf_counter() - t0)
rate(1.0)
print(rate(seconds))
"""


def closed_loop_rate(tree: Path, seconds: float) -> float:
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(tree), str(seconds)],
        capture_output=True,
        text=True,
        check=True,
    )
    return float(out.stdout.split()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True, help="older checkout's root")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=3.0, help="per side per round")
    parser.add_argument("--out", type=Path, default=RESULTS)
    args = parser.parse_args(argv)
    baseline = args.baseline.resolve()
    if not (baseline / "lfd_track").is_dir() or not (baseline / "benchmarks/speed").is_dir():
        parser.error(
            f"{baseline}: not a checkout of this project (no lfd_track/, benchmarks/speed/)"
        )
    if args.rounds < 1 or args.seconds <= 0:
        parser.error("--rounds must be >= 1 and --seconds > 0")
    load_before = load_average()
    rounds = []
    for r in range(args.rounds):
        sides = [("baseline", baseline), ("current", REPO)]
        if r % 2:
            sides.reverse()
        rates = {name: closed_loop_rate(tree, args.seconds) for name, tree in sides}
        rates["ratio"] = rates["current"] / rates["baseline"]
        rates["load_average"] = load_average()
        rounds.append(rates)
        print(
            f"round {r + 1}: baseline {rates['baseline']:.0f}, current {rates['current']:.0f}"
            f" steps/s, {rates['ratio']:.2f}x, load {rates['load_average'][0]}",
            flush=True,
        )
    summary = {
        "baseline_steps_per_s": statistics.median(r["baseline"] for r in rounds),
        "current_steps_per_s": statistics.median(r["current"] for r in rounds),
        "ratio": statistics.median(r["ratio"] for r in rounds),
    }
    result = {
        "benchmark": "closed loop against an older checkout",
        "command": "benchmarks/speed/bench_against_commit.py "
        + " ".join(sys.argv[1:] if argv is None else argv),
        "baseline_commit": source_state(baseline)["commit"],
        "seconds_per_side": args.seconds,
        **run_facts(load_before),
        "summary": summary,
        "rounds": rounds,
    }
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(
        f"closed loop: current {summary['current_steps_per_s']:.0f} against baseline"
        f" {summary['baseline_steps_per_s']:.0f} steps/s, {summary['ratio']:.2f}x"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
