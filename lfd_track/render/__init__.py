"""Rendering: the procedural floor, the rover's camera, and the human-facing top-down view.

Physics never imports this package; rendering reads the world (tracks, poses) only.
"""

from .camera import (
    CameraConfig,
    CameraModel,
    CameraRenderer,
    SensorConfig,
    safe_box_floor_polygon,
)
from .texture import AppearanceConfig, GroundTexture, LightingConfig, ShadowBand, build_ground
from .topdown import TopDownView, draw_topdown, draw_trajectories

__all__ = [
    "AppearanceConfig",
    "CameraConfig",
    "CameraModel",
    "CameraRenderer",
    "GroundTexture",
    "LightingConfig",
    "SensorConfig",
    "ShadowBand",
    "TopDownView",
    "build_ground",
    "draw_topdown",
    "draw_trajectories",
    "safe_box_floor_polygon",
]
