"""Road-value observations from a road library given as data: the wrapper a saved env spec names.

:class:`~lfd_track.envs.wrappers.RoadValueObservation` takes a live
:class:`~lfd_track.vision.road_library.RoadLibrary`, which an env spec cannot hold. This wrapper
takes the library as its dictionary (``RoadLibrary.to_dict()``, plain JSON) and records it as its
constructor argument, so ``env.spec`` of a wrapped env carries the library and ``gym.make(spec)``
builds the same observation again (a Minari dataset's ``recover_environment``, see
:mod:`lfd_track.dataset.minari`).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ..vision.grid import N_REGIONS
from ..vision.road_library import RoadLibrary
from .wrappers import RoadValueObservation


class LibraryRoadValueObservation(RoadValueObservation, gym.utils.RecordConstructorArgs):
    """Replaces each camera frame by its 40 road values against a frozen road library.

    The observation space is ``Box(-1, 1, (40,), float64)``: the values as a recording stores them
    (float64), clipped into the space. The library never learns and its selection counts never
    change (learning rule ``frozen``).

    Args:
        env: env whose observations are RGB uint8 (480, 640, 3) camera frames.
        road_library: the library as ``RoadLibrary.to_dict()`` gives it.
    """

    def __init__(self, env: gym.Env, road_library: dict[str, Any]) -> None:
        gym.utils.RecordConstructorArgs.__init__(self, road_library=road_library)
        RoadValueObservation.__init__(self, env, RoadLibrary.from_dict(road_library))
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (N_REGIONS,), dtype=np.float64)

    def observation(self, observation: Any) -> np.ndarray:
        """Road values (40,) float64 of one frame."""
        values = self.perception.perceive(np.asarray(observation)).values
        return np.clip(values, -1.0, 1.0).astype(np.float64)
