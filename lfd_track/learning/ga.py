"""The paper's generational GA (§4.2.4, Table 1) evolving MLP weights on the imitation fitness.

Fitness is minimised (lower is better, 0 perfect; see :func:`imitation_fitness`). The operators
are pure functions vectorised over the population; all randomness comes from the generator
passed in, so the same seed gives the same bytes.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.config import DictConfig
from ..policy.mlp import N_INPUTS, n_weights
from .fitness import Cases, checked_cases, population_fitness
from .result import check_bool, check_config, check_int, check_positive

MAX_POPULATION = 100_000
"""Largest population (and tournament) size accepted: far above any useful run, low enough that a
typo fails at once instead of exhausting memory."""
MAX_GENERATIONS = 1_000_000
"""Most generations accepted (5000 x the paper's 200; about two hours at its population)."""


@dataclass(frozen=True)
class GAConfig(DictConfig):
    """GA settings; defaults are the paper's Table 1.

    Limits: ``population_size`` and ``tournament_size`` 1..100 000, ``generations``
    1..1 000 000, ``elitism`` 0..population_size-1; anything else is refused in one line.
    """

    settings_name = "GA"

    population_size: int = 40
    """Individuals per generation."""
    generations: int = 200
    """Number of generations bred and evaluated."""
    tournament_size: int = 3
    """Contestants per tournament (drawn with replacement); the lowest fitness wins."""
    mutation_rate: float = 0.2
    """Probability that each weight of a child is mutated."""
    mutation_delta: float = 0.1
    """A mutated weight moves by a uniform draw from [-delta, delta]."""
    init_range: float = 1.0
    """Initial weights are uniform in [-init_range, init_range]."""
    elitism: int = 0
    """Best individuals copied unchanged into the next generation (0 in the paper)."""
    bias: bool = False
    """Give hidden and output nodes biases (223 weights instead of the paper's 215)."""
    threshold: float = 0.4
    """Output-difference threshold of the fitness (Algorithm 3)."""

    def __post_init__(self) -> None:
        check_int("population_size", self.population_size, 1, MAX_POPULATION)
        check_int("generations", self.generations, 1, MAX_GENERATIONS)
        check_int("tournament_size", self.tournament_size, 1, MAX_POPULATION)
        check_int("elitism", self.elitism, 0)
        if not 0 <= self.elitism < self.population_size:
            raise ValueError("elitism must be in 0..population_size-1")
        check_positive("mutation_rate", self.mutation_rate, allow_zero=True)
        if not self.mutation_rate <= 1.0:
            raise ValueError(f"mutation_rate must be in [0, 1], got {self.mutation_rate!r}")
        check_positive("mutation_delta", self.mutation_delta, allow_zero=True)
        check_positive("init_range", self.init_range, allow_zero=True)
        check_bool("bias", self.bias)
        check_positive("threshold", self.threshold)


@dataclass(frozen=True)
class EvolutionResult:
    """Outcome of :func:`evolve`."""

    best_weights: np.ndarray
    """The best individual ever evaluated, (W,) float64."""
    best_fitness: float
    """Its fitness (lower is better)."""
    best_generation: int
    """Generation (1-based) in which it was evaluated."""
    best_history: np.ndarray
    """Best fitness of each generation, (generations,) float64."""
    mean_history: np.ndarray
    """Mean fitness of each generation, (generations,) float64."""
    config: GAConfig
    """The settings used."""
    rng_state: dict[str, Any]
    """``rng.bit_generator.state`` when the run started: restoring it repeats the run."""


# ------------------------------------------------------------------------------------ operators
def tournament_select(
    fitness: np.ndarray, n: int, tournament_size: int, rng: np.random.Generator
) -> np.ndarray:
    """Indices of ``n`` tournament winners, (n,) intp.

    Each tournament draws ``tournament_size`` contestants uniformly with replacement; the lowest
    fitness wins and a tie goes to the contestant drawn first (so equal fitnesses, as in the
    first generation, make selection uniformly random). ``fitness``: (P,).
    """
    fitness = np.asarray(fitness, dtype=np.float64)
    contestants = rng.integers(0, fitness.shape[0], size=(n, tournament_size))
    winner = np.argmin(fitness[contestants], axis=1)  # first minimum = first drawn
    return contestants[np.arange(n), winner]


def uniform_crossover(
    first: np.ndarray, second: np.ndarray, rng: np.random.Generator
) -> np.ndarray:
    """One child per parent pair, each gene from either parent with probability 1/2.

    ``first``, ``second``: (n, W). Returns (n, W).
    """
    take_first = rng.random(first.shape) < 0.5
    return np.where(take_first, first, second)


def mutate(
    population: np.ndarray, rate: float, delta: float, rng: np.random.Generator
) -> np.ndarray:
    """Add a uniform [-delta, delta] step to each gene with probability ``rate``; shape (n, W)."""
    hit = rng.random(population.shape) < rate
    step = rng.uniform(-delta, delta, size=population.shape)
    return population + np.where(hit, step, 0.0)


def initial_population(
    config: GAConfig, rng: np.random.Generator, n_inputs: int = N_INPUTS
) -> np.ndarray:
    """Uniform random weights in [-init_range, init_range], (population_size, W) float64, for a
    network with ``n_inputs`` inputs (the 40 road values, plus any memory inputs)."""
    shape = (config.population_size, n_weights(config.bias, n_inputs))
    return rng.uniform(-config.init_range, config.init_range, size=shape)


def next_generation(
    population: np.ndarray, fitness: np.ndarray, config: GAConfig, rng: np.random.Generator
) -> np.ndarray:
    """Breed a full replacement generation, (P, W) → (P, W).

    The ``elitism`` best (lowest fitness, earliest index on ties) are copied first; every other
    slot gets one child of two tournament winners: uniform crossover, then mutation.
    """
    p = population.shape[0]
    n_children = p - config.elitism
    first = tournament_select(fitness, n_children, config.tournament_size, rng)
    second = tournament_select(fitness, n_children, config.tournament_size, rng)
    children = uniform_crossover(population[first], population[second], rng)
    children = mutate(children, config.mutation_rate, config.mutation_delta, rng)
    if config.elitism == 0:
        return children
    elite = np.argsort(fitness, kind="stable")[: config.elitism]
    return np.concatenate([population[elite], children])


# ------------------------------------------------------------------------------------ ask/tell
@dataclass(frozen=True)
class GAState:
    """Everything the GA remembers between generations (immutable; ``tell`` returns a new one).

    Arrays are read-only. ``fitness`` is Algorithm 3 on the cases the state was last scored on
    (lower is better); in generation 0 it is all zeros (nothing evaluated yet, so the first
    tournaments are uniformly random, as in the paper).
    """

    population: np.ndarray
    """Current generation, (P, W) float64."""
    fitness: np.ndarray
    """Fitness of ``population``, (P,) float64."""
    generation: int
    """Generations evaluated so far (0 after :func:`ga_init`)."""
    best_weights: np.ndarray
    """Best individual evaluated so far, (W,) float64 (the first initial one before any)."""
    best_fitness: float
    """Its fitness (``inf`` before any evaluation)."""
    best_generation: int
    """Generation in which it was evaluated (0 before any)."""
    best_history: tuple[float, ...] = ()
    """Best fitness of each generation told so far."""
    mean_history: tuple[float, ...] = ()
    """Mean fitness of each generation told so far."""


def _frozen(array: np.ndarray) -> np.ndarray:
    out = np.array(array, dtype=np.float64, copy=True)
    out.flags.writeable = False
    return out


def ga_init(config: GAConfig, rng: np.random.Generator, n_inputs: int = N_INPUTS) -> GAState:
    """Initial state: a random population (see :func:`initial_population`), nothing evaluated."""
    population = _frozen(initial_population(config, rng, n_inputs))
    return GAState(
        population=population,
        fitness=_frozen(np.zeros(config.population_size)),
        generation=0,
        best_weights=_frozen(population[0]),
        best_fitness=float("inf"),
        best_generation=0,
    )


def ga_ask(state: GAState, config: GAConfig, rng: np.random.Generator) -> np.ndarray:
    """The next generation to evaluate, (P, W) float64 (see :func:`next_generation`)."""
    return next_generation(state.population, state.fitness, config, rng)


def ga_tell(state: GAState, population: np.ndarray, fitness: np.ndarray) -> GAState:
    """State after evaluating ``population`` (P, W) with ``fitness`` (P,) (lower is better).

    The population replaces the old one (generational replacement); the best individual ever
    evaluated is kept, the earliest on ties.
    """
    fitness = np.asarray(fitness, dtype=np.float64)
    i = int(np.argmin(fitness))
    best = (state.best_weights, state.best_fitness, state.best_generation)
    generation = state.generation + 1
    if fitness[i] < state.best_fitness:
        best = (_frozen(population[i]), float(fitness[i]), generation)
    return GAState(
        population=_frozen(population),
        fitness=_frozen(fitness),
        generation=generation,
        best_weights=best[0],
        best_fitness=best[1],
        best_generation=best[2],
        best_history=(*state.best_history, float(fitness[i])),
        mean_history=(*state.mean_history, float(fitness.mean())),
    )


def ga_cases(inputs: np.ndarray, actions: np.ndarray, config: GAConfig, state: GAState) -> Cases:
    """Cases checked once for the GA's inner loop (see
    :func:`~lfd_track.learning.fitness.checked_cases`), with as many inputs as ``state``'s
    networks have; raises ``ValueError`` otherwise."""
    cases = checked_cases(inputs, actions)
    width = state.population.shape[1]
    if width != n_weights(config.bias, cases.n_inputs):
        raise ValueError(
            f"inputs have {cases.n_inputs} columns, but the GA's networks have {width} weights"
            f" ({n_weights(config.bias, cases.n_inputs)} would fit {cases.n_inputs} inputs"
            f" {'with' if config.bias else 'without'} biases)"
        )
    return cases


def ga_rescore(
    state: GAState, inputs: np.ndarray, actions: np.ndarray, config: GAConfig
) -> GAState:
    """Re-evaluate the population and the best-so-far on new cases (e.g. after some arrived).

    ``inputs`` (N, 40) (plus memory inputs), ``actions`` (N,). Fitness values from different
    case sets are not comparable, so both the population's fitness and the best individual's
    are recomputed; the best becomes whichever of the old best and the current population now
    scores lowest (the old best on ties). Histories and the generation count are kept.
    """
    return rescore_cases(state, ga_cases(inputs, actions, config, state), config)


def rescore_cases(state: GAState, cases: Cases, config: GAConfig) -> GAState:
    """:func:`ga_rescore` on cases already checked by :func:`ga_cases`."""
    fitness = population_fitness(state.population, cases, config.threshold, bias=config.bias)
    best_fitness = float(
        population_fitness(state.best_weights[None], cases, config.threshold, bias=config.bias)[0]
    )
    best = (state.best_weights, best_fitness, state.best_generation)
    i = int(np.argmin(fitness))
    if state.generation > 0 and fitness[i] < best_fitness:
        best = (_frozen(state.population[i]), float(fitness[i]), state.generation)
    return dataclasses.replace(
        state,
        fitness=_frozen(fitness),
        best_weights=best[0],
        best_fitness=best[1],
        best_generation=best[2],
    )


def ga_result(state: GAState, config: GAConfig, rng_state: Mapping[str, Any]) -> EvolutionResult:
    """The :class:`EvolutionResult` of a state (``rng_state``: the generator's starting state,
    as ``rng.bit_generator.state`` gives it)."""
    return EvolutionResult(
        best_weights=np.array(state.best_weights),
        best_fitness=state.best_fitness,
        best_generation=state.best_generation,
        best_history=np.array(state.best_history, dtype=np.float64),
        mean_history=np.array(state.mean_history, dtype=np.float64),
        config=config,
        rng_state=dict(rng_state),
    )


# ------------------------------------------------------------------------------------ the GA
def evolve(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: GAConfig | None,
    rng: np.random.Generator,
    progress: Callable[[int, float, float], None] | None = None,
) -> EvolutionResult:
    """Evolve MLP weights that imitate ``actions`` from ``inputs`` (the paper's offline GA).

    ``inputs``: (N, 40) road values (or (N, 40 + m) with m memory inputs: the network then has
    as many inputs); ``actions``: (N,) commands 0/1/2; ``config`` None means the paper's Table 1. ``rng`` is required: every draw comes from it, so a seed repeats the run.
    ``progress(generation, best_fitness, mean_fitness)`` is called after each generation.

    Order of operations (as the paper describes), one :func:`ga_ask` / :func:`ga_tell` per
    generation after :func:`ga_init`:

    1. Draw the initial population; every fitness is 0 (not evaluated), so the first round of
       tournaments is uniformly random.
    2. For each of ``generations`` generations: draw all first-parent tournaments, then all
       second-parent tournaments, then the crossover masks, then the mutation masks and steps
       (see :func:`next_generation`); replace the whole population; evaluate it in one batch.
    3. Return the best individual ever evaluated (the earliest on ties).

    Raises ``TypeError`` if ``config`` is not a :class:`GAConfig` (or None) or ``rng`` not a
    Generator, and ``ValueError`` for bad cases (no case, NaN or infinite inputs, mismatched
    shapes, commands outside 0..2); the cases are checked once, before the first generation.
    """
    config = check_config(config, GAConfig, "evolve")
    if not isinstance(rng, np.random.Generator):
        raise TypeError("evolve needs a seeded np.random.Generator (rng)")
    rng_state = rng.bit_generator.state
    # Fail on bad data before spending any time; checked once, then every generation is scored
    # by the unchecked kernel.
    cases = checked_cases(inputs, actions)

    state = ga_init(config, rng, cases.n_inputs)
    for _ in range(config.generations):
        children = ga_ask(state, config, rng)
        fitness = population_fitness(children, cases, config.threshold, bias=config.bias)
        state = ga_tell(state, children, fitness)
        if progress is not None:
            progress(state.generation, state.best_history[-1], state.mean_history[-1])
    return ga_result(state, config, rng_state)
