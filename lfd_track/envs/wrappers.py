"""Gymnasium wrappers on top of the camera environments."""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np

from ..teaching.perception import Perception
from ..vision.grid import N_REGIONS
from ..vision.road_library import RoadLibrary


class RoadValueObservation(gym.ObservationWrapper):
    """Replaces each camera frame by its 40 road values (paper Algorithm 2).

    The wrapped env's observation must be the RGB uint8 (480, 640, 3) camera frame. The new
    observation space is ``Box(-1, 1, (40,), float32)``, row-major regions from the top-left.

    Args:
        env: env whose observations are camera frames.
        library: the road library (shared, not copied).
        learn: also run Algorithm 1 on every frame (safe box) before computing its road values
            (learning rule ``always``); otherwise the library is ``frozen`` (not even its
            selection counts change).
    """

    def __init__(self, env: gym.Env, library: RoadLibrary, learn: bool = False) -> None:
        if not isinstance(library, RoadLibrary):
            raise TypeError(f"library must be a RoadLibrary, got {type(library).__name__}")
        super().__init__(env)
        self.library = library
        self.learn = bool(learn)
        self.perception = Perception(library, "always" if learn else "frozen")
        self.observation_space = gym.spaces.Box(-1.0, 1.0, (N_REGIONS,), dtype=np.float32)

    def observation(self, observation: Any) -> np.ndarray:
        """Road values (40,) float32 of one frame."""
        values = self.perception.perceive(np.asarray(observation)).values
        # Correlations can exceed 1 by a rounding error; keep observations inside the space.
        return np.clip(values, -1.0, 1.0).astype(np.float32)
