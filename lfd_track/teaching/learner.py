"""The learner feed: an observer that lets the GA (ask/tell) learn while cases arrive."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..learning.fitness import imitation_fitness
from ..learning.ga import GAConfig, ga_ask, ga_init, ga_rescore, ga_tell
from .commanders import PolicyCommander
from .loop import Step
from .observers import CaseBuffer


class GALearnerFeed:
    """Learner feed: the GA in ask/tell form, running generations as teaching cases arrive.

    After each new case the population and the best-so-far are re-scored on all cases so far,
    then ``generations_per_case`` generations run; the policy commander then drives with the best
    individual. :attr:`generation` and :attr:`best_fitness` are readable at any time.
    """

    def __init__(
        self,
        config: GAConfig,
        rng: np.random.Generator,
        generations_per_case: int,
        policy: PolicyCommander,
    ) -> None:
        self.config = config
        self.rng = rng
        self.rng_state = rng.bit_generator.state
        self.generations_per_case = generations_per_case
        self.policy = policy
        self.cases = CaseBuffer()
        self.state = ga_init(config, rng)

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
        x, a = self.cases.arrays()
        cfg = self.config
        state = self.state
        if state.generation > 0:
            state = ga_rescore(state, x, a, cfg)
        for _ in range(self.generations_per_case):
            children = ga_ask(state, cfg, self.rng)
            fitness = imitation_fitness(children, x, a, cfg.threshold, bias=cfg.bias)
            state = ga_tell(state, children, fitness)
        self.state = state
        self.policy.weights = np.array(state.best_weights)
