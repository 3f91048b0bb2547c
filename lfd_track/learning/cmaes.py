"""CMA-ES baseline: the paper's network and Algorithm 3 fitness, optimised by CMA-ES (``cma``).

Only the optimiser differs from the paper's GA: same 40-5-3 network (weight order of
:mod:`lfd_track.policy.mlp`), same fitness (:func:`~lfd_track.learning.fitness.imitation_fitness`,
minimised), and by default the same budget of 40 x 200 = 8000 evaluations. Every generation's
population is scored in one batched fitness call. All of ``cma``'s random draws come from the
generator passed in (its ``randn`` option), never from numpy's global state.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from ..core.config import DictConfig
from ..policy.mlp import n_weights
from ..utils.extras import needs_extra
from .fitness import checked_cases, population_fitness
from .result import (
    LearnerFit,
    check_bool,
    check_config,
    check_int,
    check_positive,
    initial_weights,
)


@dataclass(frozen=True)
class CMAESConfig(DictConfig):
    """CMA-ES settings; the budget defaults to the paper GA's (Table 1: 40 x 200)."""

    settings_name = "CMA-ES"

    population_size: int = 40
    """Candidates sampled and evaluated per generation (CMA-ES lambda), 2..100 000."""
    generations: int = 200
    """Generations run (fewer only if CMA-ES stops on a numerical condition), 1..1 000 000."""
    sigma0: float = 0.5
    """Initial step size, in weight units (the GA's initial weights have std 0.58)."""
    init_range: float = 1.0
    """The start mean is uniform in [-init_range, init_range], drawn like a GA individual."""
    bias: bool = False
    """Give hidden and output nodes biases (223 weights instead of the paper's 215)."""
    threshold: float = 0.4
    """Output-difference threshold of the fitness (Algorithm 3)."""

    def __post_init__(self) -> None:
        check_int("population_size", self.population_size, 2, 100_000)
        check_int("generations", self.generations, 1, 1_000_000)
        check_positive("sigma0", self.sigma0)
        check_positive("init_range", self.init_range, allow_zero=True)
        check_bool("bias", self.bias)
        check_positive("threshold", self.threshold)


def fit_cmaes(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: CMAESConfig | None,
    rng: np.random.Generator,
) -> LearnerFit:
    """Minimise the imitation fitness of the 40-5-3 network with CMA-ES.

    ``inputs``: (N, 40) road values; ``actions``: (N,) commands 0/1/2; ``rng`` (required) draws
    the start mean and every sample, so the same seed gives the same bytes; ``config`` None means ``CMAESConfig()``. Returns the best
    network ever evaluated (the earliest on ties); ``history[g]`` is the best fitness among
    generation ``g + 1``'s samples.
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError("fit_cmaes needs a numpy Generator (rng) so that runs are reproducible")
    with warnings.catch_warnings(), needs_extra("cmaes"):
        # cma warns on import when matplotlib (only used by its own plotting) is absent.
        warnings.simplefilter("ignore")
        import cma  # imported here: only this learner needs it

    config = check_config(config, CMAESConfig, "fit_cmaes")
    cases = checked_cases(inputs, actions)  # checked once; every generation uses them
    start = initial_weights(config.bias, config.init_range, rng, cases.n_inputs)

    def randn(*shape: int) -> np.ndarray:
        return rng.standard_normal(shape)

    options = {
        "popsize": config.population_size,
        "maxiter": config.generations,
        "randn": randn,
        "seed": math.nan,  # no seeding of numpy's global state: samples come from randn
        "verbose": -9,
        "verb_disp": 0,
        "verb_log": 0,
        "verb_filenameprefix": "",
        # Run the whole budget: Algorithm 3 has flat stretches that would trip the
        # progress-based stops, which only exist to save evaluations.
        "tolfun": 0,
        "tolfunhist": 0,
        "tolfunrel": 0,
        "tolx": 0,
        "tolflatfitness": config.generations + 1,
        "tolstagnation": config.generations + 1,
    }
    strategy = cma.CMAEvolutionStrategy(start, config.sigma0, options)
    history: list[float] = []
    best_weights = start.copy()
    best_fitness = math.inf
    for _ in range(config.generations):
        if strategy.stop():
            break
        population = np.asarray(strategy.ask(), dtype=np.float64)
        fitness = population_fitness(population, cases, config.threshold, bias=config.bias)
        strategy.tell(list(population), fitness.tolist())
        i = int(np.argmin(fitness))
        history.append(float(fitness[i]))
        if fitness[i] < best_fitness:
            best_fitness = float(fitness[i])
            best_weights = population[i].copy()
    assert best_weights.shape == (n_weights(config.bias, cases.n_inputs),)
    # Scored alone, as any caller would score it (batched products can differ in the last bit).
    alone = population_fitness(best_weights[None], cases, config.threshold, bias=config.bias)
    return LearnerFit(
        weights=best_weights,
        fitness=float(alone[0]),
        history=np.asarray(history, dtype=np.float64),
        learner="cma-es",
        config=config.to_dict(),
    )
