"""Learning from demonstration: the imitation fitness (Algorithm 3), the paper's GA, and the
baseline learners (behaviour cloning by backprop, CMA-ES) on the same network and cases."""

from .bc import BCConfig, fit_bc
from .cmaes import CMAESConfig, fit_cmaes
from .fit import LearnerFit
from .fitness import imitation_fitness
from .ga import EvolutionResult, GAConfig, evolve

__all__ = [
    "BCConfig",
    "CMAESConfig",
    "EvolutionResult",
    "GAConfig",
    "LearnerFit",
    "evolve",
    "fit_bc",
    "fit_cmaes",
    "imitation_fitness",
]
