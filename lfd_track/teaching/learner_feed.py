"""The learner feed: an observer that lets the GA (ask/tell) learn while cases arrive."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from ..learning.ga import GAConfig, GAState
from ..learning.learners import GALearner
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
