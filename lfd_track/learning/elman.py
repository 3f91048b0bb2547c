"""The paper's GA for an Elman network (:mod:`lfd_track.policy.elman`): Algorithm 3 scored over
each recorded episode run in order.

An Elman network's context (its previous hidden activations) depends on its own weights, so its
fitness cannot be taken case by case as the MLP's is: every individual runs over each episode's
cases in recorded order, its context starting at 0 with each episode, and Algorithm 3 scores the
outputs it produced. The run is vectorised over the population (one matrix product per episode
for the inputs, a (P, 5) x (5, 5) product per step for the context). Selection, crossover and
mutation are the paper GA's own (:func:`~lfd_track.learning.ga.ga_ask` / ``ga_tell``), on the
Elman network's longer weight vectors.

The cases of a recording are the steps the human drove as teaching cases; the few steps that are
not (the library-only commands before the first case) are not part of the sequence, whereas
when driving the context runs over every frame.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..policy.elman import N_CONTEXT, elman_sequence
from .fitness import _OTHERS, _category_weights, _check_threshold
from .ga import EvolutionResult, GAConfig, ga_ask, ga_init, ga_result, ga_tell
from .result import check_cases, check_config


def episode_starts(n_cases: int, episodes: list[int] | None = None) -> np.ndarray:
    """(N,) bool, True at the first case of each episode; ``episodes``: the episodes' case counts
    in order (None: one episode of all the cases). Raises ``ValueError`` if they do not sum to N."""
    starts = np.zeros(n_cases, dtype=bool)
    if episodes is None:
        episodes = [n_cases]
    if any(isinstance(e, bool) or int(e) != e or e < 1 for e in episodes):
        raise ValueError("episodes must be positive case counts")
    if sum(episodes) != n_cases:
        raise ValueError(f"episodes hold {sum(episodes)} cases, the inputs {n_cases}")
    starts[np.cumsum([0, *episodes[:-1]])] = True
    return starts


def sequence_fitness(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    starts: np.ndarray,
    threshold: float,
    *,
    bias: bool,
) -> np.ndarray:
    """Algorithm 3 for every Elman network, each run over the episodes in order; (P,) float64,
    lower is better (see :func:`~lfd_track.learning.fitness.imitation_fitness` for the rule)."""
    outputs = elman_sequence(weights, inputs, bias=bias, starts=starts)  # (P, N, 3)
    a = np.asarray(actions, dtype=np.intp)
    n = a.shape[0]
    winning = outputs[:, np.arange(n), a]  # (P, N)
    others = outputs[:, np.arange(n)[:, None], _OTHERS[a]]  # (P, N, 2)
    diff = winning[:, :, None] - others
    score = np.where(diff >= threshold, 0.5, 0.5 * diff / threshold).sum(axis=2)
    return 1.0 - (score @ _category_weights(a)) / 3.0


def evolve_elman(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: GAConfig | None,
    rng: np.random.Generator,
    *,
    episodes: list[int] | None = None,
    progress: Callable[[int, float, float], None] | None = None,
) -> EvolutionResult:
    """Evolve an Elman network that imitates ``actions`` from ``inputs`` (N, n) (the per-region
    features and any memory inputs, as for the MLP), the cases in recorded order; ``episodes``
    as for :func:`episode_starts`. The paper's GA (``config`` None: Table 1), the same random
    stream order as :func:`~lfd_track.learning.ga.evolve`; the result's weights are
    :func:`~lfd_track.policy.elman.elman_weights` long."""
    config = check_config(config, GAConfig, "evolve_elman")
    if not isinstance(rng, np.random.Generator):
        raise TypeError("evolve_elman needs a seeded np.random.Generator (rng)")
    _check_threshold(config.threshold)
    rng_state = rng.bit_generator.state
    x, a = check_cases(inputs, actions)
    starts = episode_starts(len(a), episodes)
    state = ga_init(config, rng, x.shape[1] + N_CONTEXT)
    for _ in range(config.generations):
        children = ga_ask(state, config, rng)
        fitness = sequence_fitness(children, x, a, starts, config.threshold, bias=config.bias)
        state = ga_tell(state, children, fitness)
        if progress is not None:
            progress(state.generation, state.best_history[-1], state.mean_history[-1])
    return ga_result(state, config, rng_state)
