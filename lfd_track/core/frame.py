"""Pixel geometry every part agrees on: frame size, the 8 x 5 region grid and the safe box.

A leaf module (imports nothing from the package): vision, rendering, overlays and the teaching
loop all take these constants from here, so each has exactly one owner.
"""

from __future__ import annotations

FRAME_HEIGHT = 480  # [px]
FRAME_WIDTH = 640  # [px]
GRID_COLUMNS = 8
GRID_ROWS = 5
N_REGIONS = GRID_COLUMNS * GRID_ROWS  # 40, one road value (and one MLP input) each
REGION_WIDTH = FRAME_WIDTH // GRID_COLUMNS  # 80 [px]
REGION_HEIGHT = FRAME_HEIGHT // GRID_ROWS  # 96 [px]

SAFE_BOX = (295, 430, 50, 50)
"""The safe box as an OpenCV rectangle ``(x, y, width, height)`` in pixels: columns 295-344 and
rows 430-479 inclusive, the 50 x 50 patch at the bottom centre that the road library learns from."""


def region_bounds(index: int) -> tuple[int, int, int, int]:
    """Pixel rectangle ``(x0, y0, x1, y1)`` (end-exclusive) of region ``index``.

    Regions are numbered row-major from the top-left: index = row * 8 + column.
    """
    if not 0 <= index < N_REGIONS:
        raise IndexError(f"region index {index} outside 0..{N_REGIONS - 1}")
    row, col = divmod(index, GRID_COLUMNS)
    x0, y0 = col * REGION_WIDTH, row * REGION_HEIGHT
    return x0, y0, x0 + REGION_WIDTH, y0 + REGION_HEIGHT


def safe_box_slices() -> tuple[slice, slice]:
    """Row and column slices selecting the safe box from an (H, W, ...) frame."""
    x, y, w, h = SAFE_BOX
    return slice(y, y + h), slice(x, x + w)
