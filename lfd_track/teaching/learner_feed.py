"""Learner feeds: observers that let a learner learn while teaching cases arrive — the GA
(ask/tell, :class:`GALearnerFeed`) or backprop warm-started from the current weights
(:class:`BCLearnerFeed`); each sets the policy commander's weights after every new case."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..learning.bc import BCConfig, adam_epoch
from ..learning.fitness import checked_cases, population_fitness
from ..learning.ga import GAConfig, GAState
from ..learning.learners import GALearner
from ..learning.result import check_int, initial_weights
from .commanders import PolicyCommander
from .observers import CaseBuffer
from .types import Step


class GALearnerFeed:
    """Learner feed: the GA in ask/tell form, running generations as teaching cases arrive.

    After each new case the population and the best-so-far are re-scored on all cases so far,
    then ``generations_per_case`` generations run (:meth:`GALearner.update
    <lfd_track.learning.learners.GALearner.update>`); the policy commander then drives with the
    best individual. :attr:`generation` and :attr:`best_fitness` are readable at any time.
    """

    def __init__(
        self,
        config: GAConfig,
        rng: np.random.Generator,
        generations_per_case: int,
        policy: PolicyCommander,
        n_inputs: int = 40,
        training_set: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
        | None = None,
    ) -> None:
        self.config = config
        self.rng = rng
        self.rng_state = rng.bit_generator.state
        self.generations_per_case = generations_per_case
        self.policy = policy
        self.cases = CaseBuffer(n_inputs)
        self.training_set = training_set or (lambda x, a: (x, a))
        """What the GA fits, made from all cases so far (e.g. with their mirror images)."""
        self.learner = GALearner(config, n_inputs)
        self.learner.begin(rng)

    @property
    def state(self) -> GAState:
        """The GA's current state (population, best so far, histories)."""
        assert self.learner.state is not None
        return self.learner.state

    @property
    def generation(self) -> int:
        return self.state.generation

    @property
    def best_fitness(self) -> float:
        return self.state.best_fitness

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        if not step.is_case:
            return
        self.cases.observe(step)
        x, a = self.training_set(*self.cases.arrays())
        self.policy.weights = self.learner.update(x, a, self.generations_per_case)


class BCLearnerFeed:
    """Learner feed: backprop (the ``bc`` learner's loss and Adam) as teaching cases arrive.

    After each new case, ``epochs_per_case`` full-batch Adam epochs run on all cases so far
    (through ``training_set``, e.g. with their mirror images), continuing from the current
    weights and Adam's running moments; the policy commander then drives with the new weights.
    The first weights are drawn from ``rng`` as :func:`~lfd_track.learning.bc.fit_bc` draws
    them. Every epoch is full-batch whatever ``config.batch_size`` says (a few hundred cases at
    most while a person teaches). The cost is bounded: ``epochs_per_case`` epochs over at most
    the cases so far, per case.

    :attr:`generation` (the Adam epochs run so far) and :attr:`best_fitness` (the Algorithm 3
    fitness of the current weights on the cases so far) are readable at any time, as a
    :class:`GALearnerFeed`'s are.
    """

    def __init__(
        self,
        config: BCConfig,
        rng: np.random.Generator,
        epochs_per_case: int,
        policy: PolicyCommander,
        n_inputs: int = 40,
        training_set: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray]]
        | None = None,
    ) -> None:
        if not isinstance(config, BCConfig):
            raise TypeError(f"BCLearnerFeed takes BCConfig settings, got {type(config).__name__}")
        if not isinstance(rng, np.random.Generator):
            raise TypeError("backprop needs a seeded np.random.Generator (rng)")
        check_int("epochs_per_case", epochs_per_case, 1, 1_000_000)
        self.config = config
        self.epochs_per_case = epochs_per_case
        self.policy = policy
        self.cases = CaseBuffer(n_inputs)
        self.training_set = training_set or (lambda x, a: (x, a))
        """What backprop fits, made from all cases so far (e.g. with their mirror images)."""
        self.weights = initial_weights(config.bias, config.init_range, rng, n_inputs, config.hidden)
        """The current weights, (W,) float64."""
        self._m = np.zeros_like(self.weights)
        self._v = np.zeros_like(self.weights)
        self.generation = 0
        """Adam epochs run so far."""
        self.best_fitness = float("nan")
        """Algorithm 3 fitness of the current weights on the cases so far (NaN before any)."""

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        if not step.is_case:
            return
        self.cases.observe(step)
        self.update(*self.training_set(*self.cases.arrays()))

    def update(self, inputs: np.ndarray, actions: np.ndarray) -> np.ndarray:
        """Run ``epochs_per_case`` epochs on ``inputs`` (N, n) and ``actions`` (N,) (all cases
        so far), hand the policy the new weights and return them."""
        cfg = self.config
        cases = checked_cases(inputs, actions)  # checked once for all the epochs
        weights, moments = self.weights, (self._m, self._v, self.generation)
        for _ in range(self.epochs_per_case):  # full-batch epochs, as fit_bc's default
            weights, moments = adam_epoch(weights, moments, cases, cfg, hidden=cfg.hidden)
        self._m, self._v, self.generation = moments
        self.weights = weights
        self.best_fitness = float(
            population_fitness(
                weights[None], cases, cfg.threshold, bias=cfg.bias, hidden=cfg.hidden
            )[0]
        )
        self.policy.weights = weights.copy()
        return weights
