"""Learning from demonstration: the imitation fitness (Algorithm 3) and the generational GA."""

from .fitness import imitation_fitness
from .ga import EvolutionResult, GAConfig, evolve

__all__ = ["EvolutionResult", "GAConfig", "evolve", "imitation_fitness"]
