"""Decision time per frame on one core: ``Controller.act(frame)`` for every policy input option.

One decision is the whole autonomous step of a trained controller: region histograms and road
values with a full road library (10 types x 10 examples, 32 bins), the regions' colour features
when the controller reads them (:mod:`lfd_track.policy.features`), the memory inputs
(:mod:`lfd_track.policy.memory`) and the MLP. Each policy kind is timed on the same frames
(rendered by the simulated camera when the renderer is installed, else synthetic), kinds in a
rotating order per round; the figure kept is the median over the rounds of the process's CPU
time per frame (the wall time is recorded too: on a loaded machine it mostly measures how long
other processes held the core). The colour features and the MLP are also timed alone on
stored histograms / inputs, to show their share.

OpenCV and the BLAS are pinned to one thread (``single_thread.pin_one_thread``).

Run: ``.venv/bin/python benchmarks/speed/bench_decision.py [--rounds 7]`` — prints a table and
writes ``benchmarks/speed/results/decision.json``.
"""

from __future__ import annotations

import argparse
import json
import statistics
import time
from pathlib import Path

import numpy as np
from bench_road_values import rendered_frames
from single_thread import load_average, machine, pin_one_thread, source_state

from lfd_track.policy.controller import Controller
from lfd_track.policy.elman import N_CONTEXT
from lfd_track.policy.features import colour_features
from lfd_track.policy.memory import FreshFeltConfig, memory_config, policy_inputs
from lfd_track.policy.mlp import mlp_forward, n_weights
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.synthetic import patch_library, synthetic_frames

RESULTS = Path(__file__).resolve().parent / "results" / "decision.json"
TARGET_MS = 5.0
KINDS = [  # (features, memory kind, policy kind)
    ("road_values", "none", "mlp-sigmoid"),
    ("road_values", "last_bend", "mlp-sigmoid"),
    ("road_values", "previous_command", "mlp-sigmoid"),
    ("road_values", "fresh_felt", "mlp-sigmoid"),
    ("none", "fresh_felt", "mlp-sigmoid"),
    ("none", "fresh_felt+strip", "mlp-sigmoid"),
    ("none", "fresh_felt+strip+blank_reach", "mlp-sigmoid"),
    ("road_values", "none", "elman-sigmoid"),
    ("road_values+colour", "none", "mlp-sigmoid"),
    ("road_values+colour", "previous_command", "mlp-sigmoid"),
    ("road_values+colour", "none", "elman-sigmoid"),
]


def controllers(library, rng: np.random.Generator) -> dict[str, Controller]:
    """One controller with random weights per policy kind."""
    out = {}
    for features, kind, policy in KINDS:
        if kind == "fresh_felt+strip":  # the goal's chosen map (round 17)
            memory = FreshFeltConfig.plain(
                strip_link_m=0.15,
                blank_bearing="last",
                bearing_range_deg=30.0,
                blank_reach_m=1.0,
                blank_distance="reach",
                visited_fade_m=0.3,
                strip_picture_links=True,
            )
        elif kind == "fresh_felt+strip+blank_reach":  # ... looking to 1 m while blank
            memory = FreshFeltConfig.plain(strip_link_m=0.15, blank_reach_m=1.0)
        else:
            memory = None if kind == "none" else memory_config({"kind": kind})
        n = policy_inputs(memory, features) + (N_CONTEXT if policy == "elman-sigmoid" else 0)
        weights = rng.uniform(-1, 1, n_weights(False, n))
        out[f"{policy} / {features} / {kind}"] = Controller(
            library, weights, memory=memory, features=features, policy_kind=policy
        )
    return out


def per_frame_ms(action, items, passes: int) -> tuple[float, float]:
    """(wall, CPU) milliseconds per item: the process's CPU time leaves out the time other
    processes held the core, which on a loaded machine is most of the wall time."""
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(passes):
        for item in items:
            action(item)
    count = passes * len(items)
    return 1e3 * (time.perf_counter() - t0) / count, 1e3 * (time.process_time() - c0) / count


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="rounds (median kept)")
    parser.add_argument("--passes", type=int, default=5, help="passes over the frames per round")
    args = parser.parse_args()
    if args.rounds < 1 or args.passes < 1:
        parser.error("--rounds and --passes must be >= 1")
    pin_one_thread()
    load_before = load_average()
    rng = np.random.default_rng(0)
    frames = rendered_frames(8, seed=1)
    source = "rendered (simulated camera, testing track)"
    if not frames:
        frames, source = synthetic_frames(rng, 8), "synthetic felt on carpet"
    library = patch_library(frames, 32, np.random.default_rng(1))
    policies = controllers(library, rng)
    histograms = [library.region_histograms(f) for f in frames]
    inputs_163 = [rng.uniform(0, 1, 163) for _ in frames]
    weights_163 = rng.uniform(-1, 1, n_weights(False, 163))
    for c in policies.values():  # warm up (thread pools, caches)
        [c.act(f) for f in frames]
    timings: dict[str, list[tuple[float, float]]] = {name: [] for name in policies}
    timings["colour features alone"] = []
    timings["MLP alone (163 inputs)"] = []
    names = list(policies)
    for r in range(args.rounds):
        order = names[r % len(names) :] + names[: r % len(names)]
        for name in order:
            controller = policies[name]
            controller.reset()
            timings[name].append(per_frame_ms(controller.act, frames, args.passes))
        timings["colour features alone"].append(
            per_frame_ms(colour_features, histograms, args.passes)
        )
        timings["MLP alone (163 inputs)"].append(
            per_frame_ms(lambda x: mlp_forward(weights_163, x[None]), inputs_163, args.passes)
        )
    load_after = load_average()
    rows = []
    for name, pairs in timings.items():
        wall, cpu = [w for w, _ in pairs], [c for _, c in pairs]
        rows.append(
            {
                "policy": name,
                "ms_per_frame": round(statistics.median(cpu), 3),
                "min_ms": round(min(cpu), 3),
                "max_ms": round(max(cpu), 3),
                "wall_ms_per_frame": round(statistics.median(wall), 3),
            }
        )
    print(f"{'policy':<56} {'CPU ms':>7} {'min..max of rounds':>19} {'wall ms':>8}")
    for row in rows:
        spread = f"{row['min_ms']:.2f}..{row['max_ms']:.2f}"
        print(
            f"{row['policy']:<56} {row['ms_per_frame']:>7.2f} {spread:>19}"
            f" {row['wall_ms_per_frame']:>8.2f}"
        )
    print(f"load average (1, 5, 15 min): before {load_before}, after {load_after}")
    decisions = [r for r in rows if r["policy"] in policies]
    result = {
        "benchmark": "decision_per_frame",
        "what": "Controller.act(frame): histograms, road values, colour features, memory, MLP",
        "library": "10 types x 10 examples, 32 bins",
        "frames": f"{len(frames)} x 640x480 RGB, {source}",
        "target": f"<= {TARGET_MS} ms per frame on one thread for every policy kind",
        "target_met": all(r["ms_per_frame"] <= TARGET_MS for r in decisions),
        "method": (
            "per round: --passes passes over the frames per policy kind, kinds in a rotating"
            " order; ms_per_frame is the median over rounds of the process's CPU time per frame"
            " (wall_ms_per_frame the wall time, which includes the time other processes held"
            " the core); OpenCV and BLAS pinned to one thread"
        ),
        "rounds": args.rounds,
        "passes": args.passes,
        "load_average_before": load_before,
        "load_average_after": load_after,
        "machine": machine(),
        "source": source_state(),
        "rows": rows,
    }
    atomic_write_text(RESULTS, json.dumps(result, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
