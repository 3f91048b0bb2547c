"""Pixel geometry of the vision code, re-exported from its one owner, :mod:`lfd_track.core.frame`."""

from __future__ import annotations

from ..core.frame import (
    FRAME_HEIGHT,
    FRAME_WIDTH,
    GRID_COLUMNS,
    GRID_ROWS,
    N_REGIONS,
    REGION_HEIGHT,
    REGION_WIDTH,
    SAFE_BOX,
    grid_fits,
    region_bounds,
    safe_box,
    safe_box_slices,
)

__all__ = [
    "FRAME_HEIGHT",
    "FRAME_WIDTH",
    "GRID_COLUMNS",
    "GRID_ROWS",
    "N_REGIONS",
    "REGION_HEIGHT",
    "REGION_WIDTH",
    "SAFE_BOX",
    "grid_fits",
    "region_bounds",
    "safe_box",
    "safe_box_slices",
]
