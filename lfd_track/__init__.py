"""lfd-track: learning from demonstration with encapsulated evolution on a felt-track rover.

Importing the package registers the Gymnasium environments ``LfDTrack-v0`` and
``LfDTrack-Hardware-v0``. The learning API (``RoadLibrary``, ``evolve``, ``Controller`` …) and
``evaluate`` (any policy scored with the corner-success protocol) are importable from here and
loaded on first use.
"""

from __future__ import annotations

import importlib
from typing import Any

from .envs.registration import register_envs

__version__ = "0.1.0"

# Public name -> module that defines it (imported lazily to keep `import lfd_track` light).
_LAZY = {
    "Command": "lfd_track.core.commands",
    "Track": "lfd_track.world.track",
    "load_track": "lfd_track.world.track",
    "LfDTrackEnv": "lfd_track.envs.track_env",
    "RoadLibrary": "lfd_track.vision.road_library",
    "draw_road_values": "lfd_track.vision.overlay",
    "mlp_forward": "lfd_track.policy.mlp",
    "imitation_fitness": "lfd_track.learning.fitness",
    "GAConfig": "lfd_track.learning.ga",
    "EvolutionResult": "lfd_track.learning.ga",
    "evolve": "lfd_track.learning.ga",
    "Controller": "lfd_track.policy.controller",
    "RoadValueObservation": "lfd_track.envs.wrappers",
    "Demonstration": "lfd_track.dataset",
    "load_demonstration": "lfd_track.dataset",
    "run_demonstration": "lfd_track.demo.demonstrator",
    "HumanConfig": "lfd_track.demo.demonstrator",
    "Preset": "lfd_track.envs.presets",
    "load_preset": "lfd_track.envs.presets",
    "training_accuracy": "lfd_track.learning.fitness",
    "evaluate": "lfd_track.benchmark.evaluation",
}

__all__ = sorted([*_LAZY, "register_envs", "__version__"])


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'lfd_track' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


register_envs()
