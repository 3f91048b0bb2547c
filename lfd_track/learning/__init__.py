"""Learning from demonstration: the imitation fitness (Algorithm 3), the paper's GA, and the
baseline learners (behaviour cloning by backprop, CMA-ES) on the same network and cases, all
behind one seam (:mod:`lfd_track.learning.learners`)."""

from .bc import BCConfig, fit_bc
from .cmaes import CMAESConfig, fit_cmaes
from .fitness import imitation_fitness
from .ga import EvolutionResult, GAConfig, evolve
from .learners import (
    BCLearner,
    CMAESLearner,
    GALearner,
    IncrementalLearner,
    Learner,
    learner_for,
)
from .result import LearnerFit

__all__ = [
    "BCConfig",
    "BCLearner",
    "CMAESConfig",
    "CMAESLearner",
    "EvolutionResult",
    "GAConfig",
    "GALearner",
    "IncrementalLearner",
    "Learner",
    "LearnerFit",
    "evolve",
    "fit_bc",
    "fit_cmaes",
    "imitation_fitness",
    "learner_for",
]
