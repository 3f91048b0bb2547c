"""A 200-generation GA run (population 40, ~150 cases): ``lfd_track.learning.evolve`` against
the same GA written with DEAP, measured in the same run.

Identical semantics on both sides: initial weights uniform in [-1, 1] and every fitness 0 before
the first breeding; each child from two tournament-of-3 winners (with replacement, lowest
fitness wins, first drawn on ties), uniform crossover (p = 0.5 per gene, one child kept), then
each gene mutated with probability 0.2 by a uniform step in [-0.1, 0.1]; generational
replacement; fitness is Algorithm 3 (the same ``imitation_fitness``, called per individual as
DEAP's ``toolbox.evaluate`` does). The random streams differ, so final fitnesses agree only
statistically.

Run: ``.venv/bin/python benchmarks/bench_ga.py`` — prints a table and writes
``benchmarks/results/bench_ga.json``.
"""

from __future__ import annotations

import json
import platform
import random
import time
from pathlib import Path

import numpy as np
from deap import base, creator, tools

from lfd_track.learning.fitness import imitation_fitness
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import felt_on_carpet_frame

RESULTS = Path(__file__).resolve().parent / "results" / "bench_ga.json"
N_CASES = 150


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


def evolve_deap(inputs: np.ndarray, actions: np.ndarray, config: GAConfig, seed: int):
    """The same generational GA with DEAP's toolbox; returns (best fitness, history)."""
    random.seed(seed)
    if not hasattr(creator, "FitnessMin"):
        creator.create("FitnessMin", base.Fitness, weights=(-1.0,))
        creator.create("Individual", list, fitness=creator.FitnessMin)
    n = 215
    toolbox = base.Toolbox()
    toolbox.register("attr", random.uniform, -config.init_range, config.init_range)
    toolbox.register("individual", tools.initRepeat, creator.Individual, toolbox.attr, n)
    toolbox.register("population", tools.initRepeat, list, toolbox.individual)

    def evaluate(ind):
        w = np.asarray(ind, dtype=np.float64)[None]
        return (float(imitation_fitness(w, inputs, actions, config.threshold)[0]),)

    def mutate(ind):
        for i in range(len(ind)):
            if random.random() < config.mutation_rate:
                ind[i] += random.uniform(-config.mutation_delta, config.mutation_delta)
        return (ind,)

    toolbox.register("evaluate", evaluate)
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
            child, _ = toolbox.mate(toolbox.clone(a), toolbox.clone(b))
            (child,) = toolbox.mutate(child)
            del child.fitness.values
            children.append(child)
        for child, fit in zip(children, map(toolbox.evaluate, children), strict=True):
            child.fitness.values = fit
        population = children
        gen_best = min(ind.fitness.values[0] for ind in population)
        history.append(gen_best)
        best = min(best, gen_best)
    return best, history


def main() -> None:
    inputs, actions = demonstration_cases(np.random.default_rng(0))
    config = GAConfig()
    runs = 3
    ours_s, deap_s, ours_fit, deap_fit = [], [], [], []
    for seed in range(runs):
        t0 = time.perf_counter()
        result = evolve(inputs, actions, config, np.random.default_rng(seed))
        ours_s.append(time.perf_counter() - t0)
        ours_fit.append(result.best_fitness)
        t0 = time.perf_counter()
        best, _ = evolve_deap(inputs, actions, config, seed)
        deap_s.append(time.perf_counter() - t0)
        deap_fit.append(best)
    row = {
        "cases": int(len(actions)),
        "actions_forward_left_right": np.bincount(actions, minlength=3).tolist(),
        "population": config.population_size,
        "generations": config.generations,
        "runs": runs,
        "ours_s_per_run": min(ours_s),
        "deap_s_per_run": min(deap_s),
        "speedup": min(deap_s) / min(ours_s),
        "ours_best_fitness_mean": float(np.mean(ours_fit)),
        "deap_best_fitness_mean": float(np.mean(deap_fit)),
    }
    print(f"{'impl':>6} {'s/run':>8} {'best fitness (mean of runs)':>28}")
    print(f"{'ours':>6} {row['ours_s_per_run']:>8.3f} {row['ours_best_fitness_mean']:>28.4f}")
    print(f"{'DEAP':>6} {row['deap_s_per_run']:>8.3f} {row['deap_best_fitness_mean']:>28.4f}")
    print(f"speedup {row['speedup']:.1f}x")
    result = {
        "benchmark": "ga_200_generations",
        "target": "speedup >= 5 with identical GA semantics",
        "machine": {
            "python": platform.python_version(),
            "processor": platform.machine(),
            "numpy": np.__version__,
        },
        "rows": [row],
    }
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    RESULTS.write_text(json.dumps(result, indent=2) + "\n")
    print(f"wrote {RESULTS}")


if __name__ == "__main__":
    main()
