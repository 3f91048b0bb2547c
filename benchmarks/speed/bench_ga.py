"""A 200-generation GA run (population 40, 150 cases): ``lfd_track.learning.evolve`` against
the same GA written with DEAP (two peers: parents copied with ``toolbox.clone``, and by
slicing their gene lists), measured in the same run on one thread.

Identical semantics on both sides: initial weights uniform in [-1, 1] and every fitness 0 before
the first breeding; each child from two tournament-of-3 winners (with replacement, lowest
fitness wins, first drawn on ties), uniform crossover (p = 0.5 per gene, one child kept), then
each gene mutated with probability 0.2 by a uniform step in [-0.1, 0.1]; generational
replacement. Fitness is Algorithm 3 scored for the whole population with one call of the same
vectorised ``imitation_fitness`` on both sides, so the ratio measures the GA machinery and not
the fitness. The random streams differ, so final fitnesses agree only statistically.

Rounds alternate which side runs first; the ratio is the median of per-round ratios. OpenCV and
the BLAS are pinned to one thread (``single_thread.pin_one_thread``). The fitness kernel is also
timed alone and compared, in multiply-adds per second, with one plain numpy matrix product of
the same number of multiply-adds (what numpy's BLAS can do at best on this core).

Run: ``.venv/bin/python benchmarks/speed/bench_ga.py [--rounds 7]`` — prints a table and writes
``benchmarks/speed/results/bench_ga.json``.
"""

from __future__ import annotations

import argparse
import json
import random
import statistics
import time
from pathlib import Path

import numpy as np
from deap import base, creator, tools
from single_thread import load_average, machine, pin_one_thread, source_state

from lfd_track.learning import fitness
from lfd_track.learning.fitness import imitation_fitness
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.mlp import N_HIDDEN, N_INPUTS, N_OUTPUTS, n_weights
from lfd_track.utils.atomic import atomic_write_text
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import felt_on_carpet_frame

RESULTS = Path(__file__).resolve().parent / "results" / "bench_ga.json"
N_CASES = 150
TARGET = 5.0


def demonstration_cases(rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Road values of synthetic frames, labelled by where the strip bends (10:1:1-ish)."""
    library = RoadLibrary()
    inputs, actions = [], []
    for i in range(10 + N_CASES):
        heading = float(rng.choice([0.0, 0.5, -0.5], p=[0.7, 0.15, 0.15]))
        frame = felt_on_carpet_frame(rng, heading_rad=heading + rng.normal(0, 0.05))
        library.learn(frame)
        if i >= 10:  # the first ten only build the library, as in the paper
            inputs.append(library.road_values(frame))
            actions.append(0 if heading == 0 else (1 if heading < 0 else 2))
    return np.array(inputs), np.array(actions)


def evolve_deap(
    inputs: np.ndarray, actions: np.ndarray, config: GAConfig, seed: int, *, clone: bool = True
):
    """The same generational GA with DEAP's toolbox; returns (best fitness, history).

    ``clone=True`` copies each parent with ``toolbox.clone`` (a deep copy, DEAP's idiom);
    ``clone=False`` copies the parents' gene lists by slice into fresh individuals (the genes are
    floats, so nothing deeper needs copying) — the same GA without the deep copies.
    """
    random.seed(seed)
    if not hasattr(creator, "FitnessMin"):
        creator.create("FitnessMin", base.Fitness, weights=(-1.0,))
        creator.create("Individual", list, fitness=creator.FitnessMin)
    n = n_weights(config.bias)
    toolbox = base.Toolbox()
    toolbox.register("attr", random.uniform, -config.init_range, config.init_range)
    toolbox.register("individual", tools.initRepeat, creator.Individual, toolbox.attr, n)
    toolbox.register("population", tools.initRepeat, list, toolbox.individual)

    def evaluate_population(individuals):
        """One vectorised call for the whole population, as ``evolve`` does."""
        weights = np.array(individuals, dtype=np.float64)
        return imitation_fitness(weights, inputs, actions, config.threshold, bias=config.bias)

    def mutate(ind):
        for i in range(len(ind)):
            if random.random() < config.mutation_rate:
                ind[i] += random.uniform(-config.mutation_delta, config.mutation_delta)
        return (ind,)

    toolbox.register("select", tools.selTournament, tournsize=config.tournament_size)
    toolbox.register("mate", tools.cxUniform, indpb=0.5)
    toolbox.register("mutate", mutate)

    population = toolbox.population(n=config.population_size)
    for ind in population:
        ind.fitness.values = (0.0,)  # the paper: unevaluated, so the first selection is random
    best = np.inf
    history = []
    for _ in range(config.generations):
        first = toolbox.select(population, config.population_size)
        second = toolbox.select(population, config.population_size)
        children = []
        for a, b in zip(first, second, strict=True):
            if clone:
                child, _ = toolbox.mate(toolbox.clone(a), toolbox.clone(b))
            else:
                child, _ = toolbox.mate(creator.Individual(a[:]), creator.Individual(b[:]))
            (child,) = toolbox.mutate(child)
            del child.fitness.values
            children.append(child)
        for child, fit in zip(children, evaluate_population(children), strict=True):
            child.fitness.values = (float(fit),)
        population = children
        gen_best = min(ind.fitness.values[0] for ind in population)
        history.append(gen_best)
        best = min(best, gen_best)
    return best, history


def kernel_timing(inputs: np.ndarray, actions: np.ndarray, population: int, calls: int) -> dict:
    """Median time of one ``imitation_fitness`` call and of a plain GEMM of equal work.

    Both are timed in alternating batches of ``calls``. The plain product is
    (N, 215) @ (215, P): exactly the fitness' N * P * 215 multiply-adds in one call.
    """
    rng = np.random.default_rng(1)
    weights = rng.uniform(-1.0, 1.0, (population, n_weights()))
    n = inputs.shape[0]
    a = rng.uniform(-1.0, 1.0, (n, n_weights()))
    b = rng.uniform(-1.0, 1.0, (n_weights(), population))
    out = np.empty((n, population))
    macs = n * population * (N_INPUTS * N_HIDDEN + N_HIDDEN * N_OUTPUTS)
    fit_s, gemm_s = [], []
    for _ in range(15):
        t0 = time.perf_counter()
        for _ in range(calls):
            imitation_fitness(weights, inputs, actions)
        fit_s.append((time.perf_counter() - t0) / calls)
        t0 = time.perf_counter()
        for _ in range(calls):
            np.matmul(a, b, out=out)
        gemm_s.append((time.perf_counter() - t0) / calls)
    fit, gemm = statistics.median(fit_s), statistics.median(gemm_s)
    return {
        # False would mean this BLAS rounds the stacked products differently from mlp_forward,
        # so the fitness falls back to one product per network (see population_outputs).
        "stacked_form_used": fitness.stacked_form_matches(),
        "population": population,
        "cases": n,
        "multiply_adds": macs,
        "fitness_us_per_call": 1e6 * fit,
        "fitness_multiply_adds_per_s": macs / fit,
        "plain_matmul_shape": f"({n}, {n_weights()}) @ ({n_weights()}, {population})",
        "plain_matmul_us_per_call": 1e6 * gemm,
        "plain_matmul_multiply_adds_per_s": macs / gemm,
        "fitness_over_plain_matmul_time": fit / gemm,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=7, help="interleaved rounds (median kept)")
    parser.add_argument("--out", type=Path, default=RESULTS, help="results file")
    args = parser.parse_args()
    if args.rounds < 1:
        parser.error("--rounds must be >= 1")
    pin_one_thread()
    load_before = load_average()
    inputs, actions = demonstration_cases(np.random.default_rng(0))
    config = GAConfig()
    evolve(inputs, actions, GAConfig(generations=5), np.random.default_rng(99))  # warm-up
    rounds = []
    for seed in range(args.rounds):
        times: dict[str, float] = {}
        fits: dict[str, float] = {}
        order = ("ours", "deap", "deap_slices")
        for side in order if seed % 2 == 0 else order[::-1]:
            t0 = time.perf_counter()
            if side == "ours":
                fits[side] = evolve(
                    inputs, actions, config, np.random.default_rng(seed)
                ).best_fitness
            else:
                fits[side], _ = evolve_deap(inputs, actions, config, seed, clone=side == "deap")
            times[side] = time.perf_counter() - t0
        rounds.append(
            {
                "seed": seed,
                "ours_s": times["ours"],
                "deap_s": times["deap"],
                "deap_slices_s": times["deap_slices"],
                "ratio": times["deap"] / times["ours"],
                "ratio_slices": times["deap_slices"] / times["ours"],
                "ours_best_fitness": fits["ours"],
                "deap_best_fitness": fits["deap"],
                "deap_slices_best_fitness": fits["deap_slices"],
            }
        )
        print(
            f"round {seed + 1}/{args.rounds}: {rounds[-1]['ratio']:.1f}x (DEAP with clone),"
            f" {rounds[-1]['ratio_slices']:.1f}x (DEAP with slice copies)"
        )
    kernel = kernel_timing(inputs, actions, config.population_size, calls=200)
    load_after = load_average()
    ratio = statistics.median(r["ratio"] for r in rounds)
    ratio_slices = statistics.median(r["ratio_slices"] for r in rounds)
    row = {
        "cases": int(len(actions)),
        "actions_forward_left_right": np.bincount(actions, minlength=3).tolist(),
        "population": config.population_size,
        "generations": config.generations,
        "rounds": len(rounds),
        "ours_s_per_run_median": statistics.median(r["ours_s"] for r in rounds),
        "deap_s_per_run_median": statistics.median(r["deap_s"] for r in rounds),
        "deap_slices_s_per_run_median": statistics.median(r["deap_slices_s"] for r in rounds),
        "speedup": ratio,
        "speedup_rounds": [r["ratio"] for r in rounds],
        "speedup_vs_deap_slices": ratio_slices,
        "speedup_vs_deap_slices_rounds": [r["ratio_slices"] for r in rounds],
        "ours_best_fitness_mean": float(np.mean([r["ours_best_fitness"] for r in rounds])),
        "deap_best_fitness_mean": float(np.mean([r["deap_best_fitness"] for r in rounds])),
        "deap_slices_best_fitness_mean": float(
            np.mean([r["deap_slices_best_fitness"] for r in rounds])
        ),
    }
    print(f"{'impl':>6} {'s/run':>8} {'best fitness (mean of runs)':>28}")
    print(
        f"{'ours':>6} {row['ours_s_per_run_median']:>8.3f} {row['ours_best_fitness_mean']:>28.4f}"
    )
    print(
        f"{'DEAP':>6} {row['deap_s_per_run_median']:>8.3f} {row['deap_best_fitness_mean']:>28.4f}"
    )
    print(
        f"{'DEAP, slice copies':>6} {row['deap_slices_s_per_run_median']:>8.3f}"
        f" {row['deap_slices_best_fitness_mean']:>28.4f}"
    )
    print(
        f"speedup {ratio:.1f}x against DEAP with clone, {ratio_slices:.1f}x against DEAP with"
        f" slice copies (medians of rounds; target >= {TARGET:g}x against both:"
        f" {'met' if min(ratio, ratio_slices) >= TARGET else 'NOT met'})"
    )
    print(
        f"fitness kernel {kernel['fitness_us_per_call']:.0f} us per call,"
        f" {kernel['fitness_multiply_adds_per_s'] / 1e9:.2f} G multiply-adds/s;"
        f" plain matmul {kernel['plain_matmul_us_per_call']:.0f} us,"
        f" {kernel['plain_matmul_multiply_adds_per_s'] / 1e9:.2f} G multiply-adds/s"
    )
    print(f"load average (1, 5, 15 min): before {load_before}, after {load_after}")
    result = {
        "benchmark": "ga_200_generations",
        "target": f"speedup >= {TARGET:g} against DEAP with the same vectorised fitness",
        "target_met": min(ratio, ratio_slices) >= TARGET,
        "method": (
            "interleaved rounds (order alternating), one GA run per side per round, median of"
            " per-round ratios; OpenCV and BLAS pinned to one thread; the DEAP peers score each"
            " generation with one imitation_fitness call; one peer copies parents with"
            " toolbox.clone, the other by slicing their gene lists"
        ),
        "load_average_before": load_before,
        "load_average_after": load_after,
        "machine": machine(),
        "source": source_state(),
        "rows": [row],
        "fitness_kernel": kernel,
    }
    atomic_write_text(args.out, json.dumps(result, indent=2) + "\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
