"""What if the half-size camera's floors were painted at the texel size it resolves?

A measurement for a decision, not a shipped option: ``paper_fast`` paints its floors at the
paper's 2 mm texels, and its bottom rows (pixels of about 4 mm of floor) still sample the full
floor's level 0, so those rows read as much texture memory as the full camera's, and every floor
costs as much to paint. This script runs ``paper_fast`` with ``[appearance] metres_per_px`` set
to 0.004 (twice the texel size, a quarter of the texels), which ``AppearanceConfig`` refuses
(it caps the texel size at 2 mm); the script sets it past that check on a copy of the preset.
Such a floor is a different floor (the carpet's loops, the felt's fibres and frayed edge are
painted at 4 mm), so its frames and road values differ from ``paper_fast``'s: adopting it would
need the half camera's validation against the full one made again.

Two measurements, on one thread in one process, both against the full camera (``paper``):

* the closed loop of ``bench_fast_camera.py`` (road values against a full 100-model library +
  MLP) with the full camera, the half camera and the half camera on the coarse floor,
  interleaved in ``--rounds`` rounds of ``--seconds`` each, medians of per-round ratios;
* with ``--job``: CPU seconds of one repetition (``--seed``) of the chosen configuration's study
  job (``bench_study_job.py``) with each, in the order half, coarse, full, coarse, half.

Run: ``.venv/bin/python benchmarks/speed/bench_coarse_floor.py [--rounds 5] [--seconds 1.5]
[--job] [--output FILE]`` — prints the ratios and writes
``benchmarks/speed/results/coarse_floor.json``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import statistics
import tempfile
import time
from pathlib import Path
from unittest import mock

import gymnasium as gym
import numpy as np
from bench_env import ClosedLoop, Sample, full_library, run_for, summarise
from single_thread import load_average, pin_one_thread, run_facts

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
import lfd_track.envs.track_env as track_env
from lfd_track.envs.presets import Preset, load_preset
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.road_library import RoadLibrary

REPO = Path(__file__).resolve().parents[2]
CHOSEN = REPO / "benchmarks" / "experiments" / "goal" / "distilled.toml"
RESULTS = Path(__file__).resolve().parent / "results" / "coarse_floor.json"
COARSE_METRES_PER_PX = 0.004


def coarse_preset(name: str = "paper_fast", metres_per_px: float = COARSE_METRES_PER_PX) -> Preset:
    """``name`` with its floor painted at ``metres_per_px``, set past the 2 mm check."""
    preset = load_preset(name)
    appearance = dataclasses.replace(preset.appearance)
    object.__setattr__(appearance, "metres_per_px", metres_per_px)
    coarse = dataclasses.replace(preset)
    object.__setattr__(coarse, "appearance", appearance)
    return coarse


class Loop(ClosedLoop):
    """``bench_env.ClosedLoop`` on the env of any preset."""

    def __init__(self, name: str, preset: str | Preset, seed: int, library: RoadLibrary) -> None:
        self.name = name
        self.env = gym.make("LfDTrack-v0", preset=preset)
        self.library = library
        self.rng = np.random.default_rng(seed)
        self.frame, _ = self.env.reset(seed=seed)
        self._new_controller()


def closed_loops(rounds: int, seconds: float, seed: int) -> dict:
    library = full_library(seed + 1)
    loops = [
        Loop("closed_loop", "paper", seed + 2, library),
        Loop("closed_loop_fast", "paper_fast", seed + 2, library),
        Loop("closed_loop_fast_coarse_floor", coarse_preset(), seed + 2, library),
    ]
    samples: dict[str, list[Sample]] = {w.name: [] for w in loops}
    for index in range(rounds + 1):
        for w in loops:
            sample = run_for(w, seconds)
            if index > 0:  # round 0 warms caches
                samples[w.name].append(sample)
        if index > 0:
            print("  ".join(f"{n} {s[-1].rate:6.1f}" for n, s in samples.items()), flush=True)
    for w in loops:
        w.close()

    def ratio(num: str) -> float:
        pairs = zip(samples[num], samples["closed_loop"], strict=True)
        return statistics.median(a.rate / b.rate for a, b in pairs)

    return {
        "ratios_to_full_camera": {
            "closed_loop_fast": ratio("closed_loop_fast"),
            "closed_loop_fast_coarse_floor": ratio("closed_loop_fast_coarse_floor"),
        },
        "results": {name: summarise(s) for name, s in samples.items()},
    }


def job_cpu_s(preset: str, coarse: bool, seed: int) -> float:
    """CPU seconds of one repetition of the chosen configuration's job."""
    from lfd_track.benchmark.runner import run_benchmark
    from lfd_track.study.spec import load_study

    study = load_study(CHOSEN)
    config = dataclasses.replace(
        study.conditions[0].config, seed=seed, repetitions=1, preset=preset
    )

    def load(name: str | Preset) -> Preset:
        return coarse_preset() if coarse and name == "paper_fast" else load_preset(name)

    with tempfile.TemporaryDirectory() as tmp, mock.patch.object(track_env, "load_preset", load):
        cpu = time.process_time()
        run_benchmark(config, tmp, workers=1)
        return round(time.process_time() - cpu, 2)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--seconds", type=float, default=1.5)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--job", action="store_true", help="also time one study repetition")
    parser.add_argument("--output", type=Path, default=RESULTS)
    args = parser.parse_args()
    pin_one_thread()
    before = load_average()
    out: dict = {
        "what_if": f"paper_fast with its floors painted at {COARSE_METRES_PER_PX} m per texel",
        "closed_loop": closed_loops(args.rounds, args.seconds, args.seed),
    }
    print(json.dumps(out["closed_loop"]["ratios_to_full_camera"]), flush=True)
    if args.job:
        order = [("paper_fast", False), ("paper_fast", True), ("paper", False)]
        order += [("paper_fast", True), ("paper_fast", False)]
        jobs: dict[str, list[float]] = {}
        for preset, coarse in order:
            label = preset + ("_coarse_floor" if coarse else "")
            jobs.setdefault(label, []).append(job_cpu_s(preset, coarse, args.seed))
            print(label, jobs[label][-1], "s CPU", flush=True)
        full = statistics.median(jobs["paper"])
        out["study_job_one_repetition_cpu_s"] = jobs
        out["study_job_speedup_cpu"] = {
            label: round(full / statistics.median(times), 3)
            for label, times in jobs.items()
            if label != "paper"
        }
        print(json.dumps(out["study_job_speedup_cpu"]), flush=True)
    out.update(run_facts(before))
    atomic_write_text(args.output, json.dumps(out, indent=1) + "\n")
    print(f"wrote {args.output}")


if __name__ == "__main__":
    main()
