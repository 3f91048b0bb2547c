"""Closed-loop steps/s of this checkout against an older one, on one thread, same machine.

The closed loop is ``bench_env.ClosedLoop`` (frame → road values against a full library → MLP
→ command → env, random controllers, resets included), each side run from its own source tree
with that tree's own ``bench_env``, so each measures the code it had. The two sides alternate in
separate processes, ``--rounds`` times each, and the ratio is the median of the per-round ratios
(this checkout over the baseline). Used for the throughput target stated against the wave-2
renderer: make the baseline with ``git worktree add --detach /tmp/wave2 05b46a1`` (the last
commit before the mipmap filter and the floor benchmark). ``--preset`` runs both sides' closed
loop on the env of another preset (e.g. ``paper_fast``, the half-size camera).

Run: ``.venv/bin/python benchmarks/speed/bench_against_commit.py --baseline /tmp/wave2
[--rounds 5] [--seconds 3] [--preset paper]`` — prints each round and writes
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
tree, seconds, preset = sys.argv[1], float(sys.argv[2]), sys.argv[3]
sys.path[:0] = [tree, tree + "/benchmarks/speed"]
from single_thread import pin_one_thread
pin_one_thread()
import lfd_track
assert lfd_track.__file__.startswith(tree), lfd_track.__file__
from bench_env import ClosedLoop, full_library
loop = ClosedLoop(0, full_library(0))
if preset != "paper":
    import gymnasium as gym
    loop.env.close()
    loop.env = gym.make("LfDTrack-v0", preset=preset)
    loop.frame, _ = loop.env.reset(seed=0)
def rate(s):
    n, t0, c0 = 0, time.perf_counter(), time.process_time()
    while time.perf_counter() - t0 < s:
        if loop.step():
            loop.reset()
        n += 1
    return n / (time.perf_counter() - t0), n / (time.process_time() - c0)
rate(1.0)
print(*rate(seconds))
"""


def closed_loop_rate(tree: Path, seconds: float, preset: str = "paper") -> tuple[float, float]:
    """Steps per second of wall time and per second of the process's CPU time."""
    out = subprocess.run(
        [sys.executable, "-c", _CHILD, str(tree), str(seconds), preset],
        capture_output=True,
        text=True,
        check=True,
    )
    wall, cpu = out.stdout.split()[-2:]
    return float(wall), float(cpu)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--baseline", type=Path, required=True, help="older checkout's root")
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=3.0, help="per side per round")
    parser.add_argument("--preset", default="paper", help="env preset of both sides")
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
        measured = {name: closed_loop_rate(tree, args.seconds, args.preset) for name, tree in sides}
        rates = {name: wall for name, (wall, _) in measured.items()}
        rates |= {f"{name}_per_cpu_s": cpu for name, (_, cpu) in measured.items()}
        rates["ratio"] = rates["current"] / rates["baseline"]
        rates["ratio_cpu"] = rates["current_per_cpu_s"] / rates["baseline_per_cpu_s"]
        rates["load_average"] = load_average()
        rounds.append(rates)
        print(
            f"round {r + 1}: baseline {rates['baseline']:.0f}, current {rates['current']:.0f}"
            f" steps/s, {rates['ratio']:.2f}x (per CPU s {rates['ratio_cpu']:.2f}x),"
            f" load {rates['load_average'][0]}",
            flush=True,
        )
    summary = {
        "baseline_steps_per_s": statistics.median(r["baseline"] for r in rounds),
        "current_steps_per_s": statistics.median(r["current"] for r in rounds),
        "ratio": statistics.median(r["ratio"] for r in rounds),
        "baseline_steps_per_cpu_s": statistics.median(r["baseline_per_cpu_s"] for r in rounds),
        "current_steps_per_cpu_s": statistics.median(r["current_per_cpu_s"] for r in rounds),
        "ratio_cpu": statistics.median(r["ratio_cpu"] for r in rounds),
    }
    result = {
        "benchmark": "closed loop against an older checkout",
        "command": "benchmarks/speed/bench_against_commit.py "
        + " ".join(sys.argv[1:] if argv is None else argv),
        "baseline_commit": source_state(baseline)["commit"],
        "seconds_per_side": args.seconds,
        "preset": args.preset,
        **run_facts(load_before),
        "summary": summary,
        "rounds": rounds,
    }
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(
        f"closed loop: current {summary['current_steps_per_s']:.0f} against baseline"
        f" {summary['baseline_steps_per_s']:.0f} steps/s, {summary['ratio']:.2f}x; per CPU second"
        f" {summary['current_steps_per_cpu_s']:.0f} against {summary['baseline_steps_per_cpu_s']:.0f},"
        f" {summary['ratio_cpu']:.2f}x"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
