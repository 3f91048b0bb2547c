"""Where a decision's time goes, part by part, and what the slowest frames spend it on.

``bench_budget.py`` says whether a configuration decides within 5 ms on one core;
``bench_decision_tail.py`` times other registrations on the goal's recorded frames. This one
drives a study condition's first controller (study seed, repetition 0, as ``bench_budget.py``
learns it) on the testing track, each way in turn, until ``--frames`` frames were decided (as
``bench_budget.py`` drives it: ``drive``), and times each part of every decision with the
process's CPU clock:

* ``histograms`` — the road library's region histograms of the frame;
* ``road values`` — the frame's road values from them;
* ``balance`` — the colour balance's estimate (``colour_balance = "safe_box"``) and its scaling;
* ``floor view`` and ``registration`` — the measured motion (``motion = "visual"``): the frame's
  floor view and the ECC fits;
* ``map`` — the ``fresh_felt`` map's update from the road values;

and counts the garbage collector's runs within each frame. The rest of a decision (the network,
the bookkeeping) is the difference. It prints the parts' means and the slowest frames' parts:
whether one part makes the slowest frames, or every part slows at once (a shared machine).

Run: ``.venv/bin/python benchmarks/speed/bench_decision_parts.py --study FILE --condition NAME
[--frames 1500] --out FILE`` — e.g. ``--study benchmarks/experiments/goal/trials/goal_quick.toml
--condition paper_fast_quick --out benchmarks/speed/results/decision_parts_quick.json``.
"""

from __future__ import annotations

import argparse
import gc
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
from bench_budget import drive, first_repetition_config, percentiles, repetition_zero
from single_thread import load_average, pin_one_thread, run_facts, write_results

from lfd_track.benchmark.runner import learn_repetition
from lfd_track.policy.memory import FreshFeltMemory
from lfd_track.policy.odometry import FloorOdometry
from lfd_track.vision.colour_balance import SafeBoxBalance
from lfd_track.vision.road_library import RoadLibrary

REPO = Path(__file__).resolve().parents[2]
SLOWEST = 12  # frames listed part by part
#: (class, method, part): the parts timed; a part named twice adds up.
PARTS = (
    (RoadLibrary, "region_histograms", "histograms"),
    (RoadLibrary, "road_values_from_histograms", "road values"),
    (SafeBoxBalance, "update", "balance"),
    (SafeBoxBalance, "apply", "balance"),
    (FloorOdometry, "view", "floor view"),
    (FloorOdometry, "motion", "registration"),
    (FreshFeltMemory, "see", "map"),
)


def timed_parts(spent: dict[str, float]) -> list[tuple[Any, str, Any]]:
    """Wrap each part's method to add its CPU ms to ``spent``; the originals, to restore."""
    originals = []
    for cls, name, part in PARTS:
        method = getattr(cls, name)
        originals.append((cls, name, method))

        def timed(*args: Any, _method: Any = method, _part: str = part, **kwargs: Any) -> Any:
            t0 = time.process_time_ns()
            try:
                return _method(*args, **kwargs)
            finally:
                spent[_part] = spent.get(_part, 0.0) + (time.process_time_ns() - t0) / 1e6

        setattr(cls, name, timed)
    return originals


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--study", type=Path, required=True, help="the study of the condition")
    parser.add_argument("--condition", required=True, help="a condition of method bc")
    parser.add_argument("--frames", type=int, default=1500, help="frames decided (default 1500)")
    parser.add_argument("--out", type=Path, required=True, help="the JSON written")
    args = parser.parse_args()
    if args.frames < 20:
        parser.error("--frames must be >= 20")
    pin_one_thread()
    before = load_average()
    study = args.study.resolve()
    config = first_repetition_config(study, args.condition)
    demo_seed, ga_seed, trial_seed, preset, extra = repetition_zero(config)
    with tempfile.TemporaryDirectory() as tmp:
        controller = learn_repetition(
            config, Path(tmp), demo_seed=demo_seed, ga_seed=ga_seed, preset=preset, **extra
        ).controller
    collections = [0]

    def count(phase: str, info: dict[str, Any]) -> None:
        collections[0] += phase == "start"

    spent: dict[str, float] = {}
    names = list(dict.fromkeys(part for _, _, part in PARTS))
    rows: list[list[float]] = []  # per frame: decision ms, GC runs, each part's ms
    originals = timed_parts(spent)
    gc.callbacks.append(count)

    def timed_decision(decide: Any, timed: bool) -> Any:
        spent.clear()
        runs = collections[0]
        t0 = time.process_time_ns()
        command = decide()
        ms = (time.process_time_ns() - t0) / 1e6
        if timed:
            rows.append([ms, collections[0] - runs, *(spent.get(n, 0.0) for n in names)])
        return command

    try:
        drive(controller, preset, trial_seed, args.frames, timed_decision)
    finally:
        gc.callbacks.remove(count)
        for cls, name, method in originals:
            setattr(cls, name, method)
    data = np.array(rows)
    decision, gc_runs, parts = data[:, 0], data[:, 1], data[:, 2:]
    means = {n: round(float(parts[:, i].mean()), 3) for i, n in enumerate(names)}
    means["rest"] = round(float(decision.mean() - parts.sum(axis=1).mean()), 3)
    slowest = [
        {
            "decision_ms": round(float(decision[i]), 3),
            "gc_runs": int(gc_runs[i]),
            **{n: round(float(parts[i, j]), 3) for j, n in enumerate(names)},
        }
        for i in np.argsort(-decision)[:SLOWEST]
    ]
    print(f"{args.condition} ({args.study}), one core, {len(decision)} frames")
    d = percentiles(list(decision))
    print(
        f"decision ms median / p95 / p99 / max: {d['median_ms']:.2f} / {d['p95_ms']:.2f} /"
        f" {d['p99_ms']:.2f} / {d['max_ms']:.2f}; mean {decision.mean():.2f}"
    )
    print("mean ms per part:", ", ".join(f"{k} {v:.2f}" for k, v in means.items()))
    print(f"frames with a garbage collection: {int((gc_runs > 0).sum())}")
    print("slowest frames (decision ms: " + ", ".join(names) + "; GC runs):")
    for row in slowest:
        shown = " ".join(f"{row[n]:.2f}" for n in names)
        print(f"  {row['decision_ms']:.2f}: {shown}; {row['gc_runs']}")
    result = {
        "benchmark": "decision_parts",
        "configuration": f"{args.condition} of {args.study}, study seed"
        f" {config.seed}, repetition 0",
        "frames": int(len(decision)),
        "decision": d,
        "mean_ms_per_part": means,
        "part_max_ms": {n: round(float(parts[:, i].max()), 3) for i, n in enumerate(names)},
        "frames_with_gc": int((gc_runs > 0).sum()),
        "slowest_frames": slowest,
        **run_facts(before),
    }
    write_results(args.out, result, before)


if __name__ == "__main__":
    main()
