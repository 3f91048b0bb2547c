"""Training accuracy and Algorithm 3 fitness of the three learners on the same demonstrations.

For each seed s: record one demonstration on the training track with the scripted human
(``run_demonstration(seed=s)``), then learn the 40-5-3 network from its cases with the paper GA
(``GAConfig()``, Table 1), behaviour cloning (``BCConfig()``) and CMA-ES (``CMAESConfig()``, the
GA's 8000 evaluations), each with ``np.random.default_rng(s)``. Accuracy is the share of training
cases whose largest output is the demonstrated command; fitness is Algorithm 3's (lower is
better). Time is given as a ratio to the GA's, measured in the same process.

This measures fitting the demonstration only; how the learned controllers drive is what
``lfd-track study`` measures.

Run: ``.venv/bin/python benchmarks/experiments/learner_fit/learner_accuracy.py [--seeds 10]`` — prints a markdown table
and writes ``benchmarks/experiments/learner_fit/results/learner_accuracy.json``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.cmaes import CMAESConfig, fit_cmaes
from lfd_track.learning.fitness import training_accuracy
from lfd_track.learning.ga import GAConfig, evolve

RESULTS = Path(__file__).resolve().parent / "results" / "learner_accuracy.json"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=10, help="seeds 0..N-1 (default 10)")
    args = parser.parse_args()
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.seeds):
            path = Path(tmp) / f"demo{seed}.lfdemo"
            run_demonstration(path, seed=seed, fsync=False)
            demo = load_demonstration(path)
            x, a = demo.road_values, demo.commands.astype(np.intp)
            row = {"seed": seed, "cases": int(demo.n_cases)}
            t0 = time.perf_counter()
            ga = evolve(x, a, GAConfig(), np.random.default_rng(seed))
            t_ga = time.perf_counter() - t0
            row["ga"] = {
                "accuracy": training_accuracy(ga.best_weights, x, a),
                "fitness": ga.best_fitness,
                "time_vs_ga": 1.0,
            }
            for name, fit, config in (
                ("bc", fit_bc, BCConfig()),
                ("cma-es", fit_cmaes, CMAESConfig()),
            ):
                t0 = time.perf_counter()
                result = fit(x, a, config, np.random.default_rng(seed))
                elapsed = time.perf_counter() - t0
                row[name] = {
                    "accuracy": training_accuracy(result.weights, x, a),
                    "fitness": result.fitness,
                    "time_vs_ga": elapsed / t_ga,
                }
            rows.append(row)
            print(
                f"seed {seed}: {row['cases']} cases; accuracy GA {row['ga']['accuracy']:.3f}, "
                f"BC {row['bc']['accuracy']:.3f}, CMA-ES {row['cma-es']['accuracy']:.3f}",
                flush=True,
            )
    print("\n| learner | training accuracy mean (min–max) | fitness mean | time / GA time |")
    print("|---|---|---|---|")
    summary = {}
    for name in ("ga", "bc", "cma-es"):
        acc = [r[name]["accuracy"] for r in rows]
        fit = [r[name]["fitness"] for r in rows]
        ratio = [r[name]["time_vs_ga"] for r in rows]
        summary[name] = {
            "accuracy_mean": statistics.mean(acc),
            "accuracy_min": min(acc),
            "accuracy_max": max(acc),
            "fitness_mean": statistics.mean(fit),
            "time_vs_ga_median": statistics.median(ratio),
        }
        print(
            f"| {name} | {100 * statistics.mean(acc):.1f} % ({100 * min(acc):.1f}–"
            f"{100 * max(acc):.1f}) | {statistics.mean(fit):.3f} | {statistics.median(ratio):.1f}× |"
        )
    RESULTS.write_text(
        json.dumps(
            {
                "benchmark": "learner_training_accuracy",
                "demonstration": "run_demonstration(seed=s) on the training track, paper preset",
                "learner_seed": "np.random.default_rng(s)",
                "configs": {
                    "ga": GAConfig().to_dict(),
                    "bc": BCConfig().to_dict(),
                    "cma-es": CMAESConfig().to_dict(),
                },
                "machine": {"python": platform.python_version(), "processor": platform.machine()},
                "rows": rows,
                "summary": summary,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
