"""The learner seam: what turns teaching cases into the weights of the paper's 40-5-3 network.

Every learner has a ``name`` (what a controller file records as its ``learner``), its settings
``config`` and ``fit(inputs, actions, rng) -> LearnerFit``: all cases at once, every random draw
from ``rng``. A learner that can also learn while cases arrive is an :class:`IncrementalLearner`:
``begin(rng)`` once, then ``update(inputs, actions, steps)`` with all cases so far whenever new
ones came in; ``update`` returns the best weights so far, which a policy can drive with at once.

Only the GA is incremental (ask/tell: the population is re-scored on the grown case set and a few
generations run). Backprop and CMA-ES are fitted from scratch; re-fitting them after each case
would cost a whole run per case (while a person teaches, the online method's backprop feed,
:class:`~lfd_track.teaching.learner_feed.BCLearnerFeed`, instead continues Adam for a few epochs
per case from the current weights).

The runtime side (``Controller``, the policy commander) never imports this module: a policy
does not need its trainer.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import numpy as np

from ..policy.mlp import N_INPUTS
from .bc import BCConfig, fit_bc
from .cmaes import CMAESConfig, fit_cmaes
from .fitness import population_fitness
from .ga import GAConfig, GAState, evolve, ga_ask, ga_cases, ga_init, ga_tell, rescore_cases
from .result import LearnerFit, check_config

__all__ = [
    "BCLearner",
    "CMAESLearner",
    "GALearner",
    "IncrementalLearner",
    "Learner",
    "learner_for",
]


@runtime_checkable
class Learner(Protocol):
    """Turns cases (road values, commands) into network weights."""

    name: str
    config: Any

    def fit(self, inputs: np.ndarray, actions: np.ndarray, rng: np.random.Generator) -> LearnerFit:
        """Learn from all cases at once."""
        ...


@runtime_checkable
class IncrementalLearner(Learner, Protocol):
    """A learner that keeps learning as cases arrive."""

    def begin(self, rng: np.random.Generator) -> None:
        """Start from nothing; every later draw comes from ``rng``."""
        ...

    def update(self, inputs: np.ndarray, actions: np.ndarray, steps: int) -> np.ndarray:
        """Learn ``steps`` more rounds on all cases so far; return the best weights so far."""
        ...


class GALearner:
    """The paper's GA (Algorithm 3 fitness, Table 1 settings by default).

    ``fit`` is :func:`~lfd_track.learning.ga.evolve`. Incrementally, ``update`` re-scores the
    population and the best-so-far on all cases (after the first call) and runs ``steps``
    generations: one ``update`` of G generations on all cases right after ``begin`` is exactly
    ``evolve`` with G generations and the same generator.
    """

    name = "ga"

    def __init__(self, config: GAConfig | None = None, n_inputs: int = N_INPUTS) -> None:
        self.config = check_config(config, GAConfig, "GALearner")
        self.n_inputs = int(n_inputs)
        """Inputs of the network ``begin`` draws (40 road values, plus any memory inputs)."""
        self.state: GAState | None = None
        self._rng: np.random.Generator | None = None

    def fit(self, inputs: np.ndarray, actions: np.ndarray, rng: np.random.Generator) -> LearnerFit:
        result = evolve(inputs, actions, self.config, rng)
        return LearnerFit(
            weights=np.array(result.best_weights),
            fitness=float(result.best_fitness),
            history=np.array(result.best_history, dtype=np.float64),
            learner=self.name,
            config=self.config.to_dict(),
        )

    def begin(self, rng: np.random.Generator) -> None:
        if not isinstance(rng, np.random.Generator):
            raise TypeError("the GA needs a seeded np.random.Generator (rng)")
        self._rng = rng
        self.state = ga_init(self.config, rng, self.n_inputs)

    def update(self, inputs: np.ndarray, actions: np.ndarray, steps: int) -> np.ndarray:
        if self.state is None or self._rng is None:
            raise RuntimeError("call begin(rng) before update()")
        if isinstance(steps, bool) or not isinstance(steps, int) or steps < 0:
            raise ValueError(f"steps must be an integer >= 0, got {steps!r}")
        cfg = self.config
        state = self.state
        cases = ga_cases(inputs, actions, cfg, state)  # checked once for all the steps
        if state.generation > 0:
            state = rescore_cases(state, cases, cfg)
        for _ in range(steps):
            children = ga_ask(state, cfg, self._rng)
            fitness = population_fitness(children, cases, cfg.threshold, bias=cfg.bias)
            state = ga_tell(state, children, fitness)
        self.state = state
        return np.array(state.best_weights)


class BCLearner:
    """Backprop on the same network (behaviour cloning), :func:`~lfd_track.learning.bc.fit_bc`."""

    name = "bc"

    def __init__(self, config: BCConfig | None = None) -> None:
        self.config = check_config(config, BCConfig, "BCLearner")

    def fit(self, inputs: np.ndarray, actions: np.ndarray, rng: np.random.Generator) -> LearnerFit:
        return fit_bc(inputs, actions, self.config, rng)


class CMAESLearner:
    """CMA-ES on the GA's fitness, :func:`~lfd_track.learning.cmaes.fit_cmaes`."""

    name = "cma-es"

    def __init__(self, config: CMAESConfig | None = None) -> None:
        self.config = check_config(config, CMAESConfig, "CMAESLearner")

    def fit(self, inputs: np.ndarray, actions: np.ndarray, rng: np.random.Generator) -> LearnerFit:
        return fit_cmaes(inputs, actions, self.config, rng)


def learner_for(config: GAConfig | BCConfig | CMAESConfig) -> Learner:
    """The learner whose settings ``config`` is."""
    if isinstance(config, GAConfig):
        return GALearner(config)
    if isinstance(config, BCConfig):
        return BCLearner(config)
    if isinstance(config, CMAESConfig):
        return CMAESLearner(config)
    raise TypeError(f"no learner takes {type(config).__name__} settings")
