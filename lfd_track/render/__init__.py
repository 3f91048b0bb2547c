"""Rendering: the procedural floor, the rover's camera frames, and the human-facing top-down view.

Physics never imports this package; rendering reads the world (tracks, poses) only. The camera's
geometry (``CameraConfig``, ``CameraModel``: which floor point each pixel sees) is
:mod:`lfd_track.core.camera_model`, which needs no renderer.
"""

from .camera import CameraRenderer, SensorConfig
from .texture import AppearanceConfig, GroundTexture, LightingConfig, ShadowBand, build_ground
from .topdown import TopDownView, draw_topdown, draw_trajectories

__all__ = [
    "AppearanceConfig",
    "CameraRenderer",
    "GroundTexture",
    "LightingConfig",
    "SensorConfig",
    "ShadowBand",
    "TopDownView",
    "build_ground",
    "draw_topdown",
    "draw_trajectories",
]
