"""End to end: one study job of the chosen configuration with the full camera and with the
half-size one (preset ``paper_fast``), on one thread in one process, one after the other.

The job is what ``benchmarks/experiments/goal/distilled.toml`` runs per seed: one seed
(``--seed``, default 0) x 10 repetitions (a demonstration by the picture-steering human, the
network fitted by backprop, then 3 runs each way on the training track and 3 laps each way on the
testing track and the five unseen loops), run by ``run_benchmark`` with one worker in this
process, so the times are the job's CPU work on one core. The two jobs alternate in order over
``--rounds`` (full first in odd rounds) so load from other processes falls on both alike.

Target: the half camera's job >= 2.5x faster than the full camera's.

Run: ``.venv/bin/python benchmarks/speed/bench_study_job.py [--seed 0] [--repetitions 10]
[--rounds 1] [--output FILE]`` — prints the times and writes
``benchmarks/speed/results/study_job.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

from single_thread import load_average, pin_one_thread, run_facts

from lfd_track.benchmark.runner import run_benchmark
from lfd_track.study.spec import load_study

REPO = Path(__file__).resolve().parents[2]
CHOSEN = REPO / "benchmarks" / "experiments" / "goal" / "distilled.toml"
RESULTS = Path(__file__).resolve().parent / "results" / "study_job.json"


def time_job(preset: str, seed: int, repetitions: int) -> dict[str, float]:
    """Wall and CPU seconds of one chosen-configuration job with ``preset``."""
    study = load_study(CHOSEN)
    config = dataclasses.replace(
        study.conditions[0].config, seed=seed, repetitions=repetitions, preset=preset
    )
    with tempfile.TemporaryDirectory() as tmp:
        wall, cpu = time.perf_counter(), time.process_time()
        reps = run_benchmark(config, tmp, workers=1)
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    laps = sum(len(r.outcomes) for r in reps)
    return {"wall_s": round(wall, 2), "cpu_s": round(cpu, 2), "trials": laps}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repetitions", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=1)
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    pin_one_thread()
    before = load_average()
    rounds = []
    for index in range(args.rounds):
        order = ("paper", "paper_fast") if index % 2 == 0 else ("paper_fast", "paper")
        timed = {preset: time_job(preset, args.seed, args.repetitions) for preset in order}
        timed["speedup_wall"] = round(timed["paper"]["wall_s"] / timed["paper_fast"]["wall_s"], 3)
        timed["speedup_cpu"] = round(timed["paper"]["cpu_s"] / timed["paper_fast"]["cpu_s"], 3)
        rounds.append(timed)
        print(json.dumps(timed), flush=True)
    out = {
        "job": f"chosen.toml, seed {args.seed} x {args.repetitions} repetitions, one worker",
        "rounds": rounds,
        "target": "speedup >= 2.5",
        **run_facts(before),
    }
    args.output.parent.mkdir(parents=True, exist_ok=True)
    args.output.write_text(json.dumps(out, indent=1) + "\n", encoding="utf-8")


if __name__ == "__main__":
    main()
