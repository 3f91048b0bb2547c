"""Pixel geometry every part agrees on: frame size, the 8 x 5 region grid and the safe box.

A leaf module (imports nothing from the package): vision, rendering, overlays and the teaching
loop all take these constants from here, so each has exactly one owner.

The constants are the paper's 640 x 480 frame. A camera with ``scale`` (``[camera] scale =
0.5``: 320 x 240 frames of the same view) keeps the grid of 8 x 5 regions, each a fifth of the
frame's height and an eighth of its width (40 x 48 px at half size), and the safe box at the
same place on the floor: the functions take the frame's ``width`` and ``height`` (the paper's by
default).
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


def grid_fits(width: int, height: int) -> bool:
    """Whether a ``width`` x ``height`` frame splits into the 8 x 5 grid of equal regions."""
    return (
        width >= GRID_COLUMNS
        and height >= GRID_ROWS
        and not (width % GRID_COLUMNS or height % GRID_ROWS)
    )


def _check_size(width: int, height: int) -> None:
    if not grid_fits(width, height):
        raise ValueError(
            f"a {width} x {height} frame does not split into {GRID_COLUMNS} x {GRID_ROWS}"
            " equal regions"
        )


def region_bounds(
    index: int, width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT
) -> tuple[int, int, int, int]:
    """Pixel rectangle ``(x0, y0, x1, y1)`` (end-exclusive) of region ``index`` of a ``width`` x
    ``height`` frame (the paper's 640 x 480 by default: 80 x 96 px regions).

    Regions are numbered row-major from the top-left: index = row * 8 + column.
    """
    if not 0 <= index < N_REGIONS:
        raise IndexError(f"region index {index} outside 0..{N_REGIONS - 1}")
    _check_size(width, height)
    region_w, region_h = width // GRID_COLUMNS, height // GRID_ROWS
    row, col = divmod(index, GRID_COLUMNS)
    x0, y0 = col * region_w, row * region_h
    return x0, y0, x0 + region_w, y0 + region_h


def safe_box(width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT) -> tuple[int, int, int, int]:
    """The safe box ``(x, y, width, height)`` of a ``width`` x ``height`` frame: :data:`SAFE_BOX`
    for the paper's 640 x 480, else its sides scaled with the frame (rounded to whole pixels, at
    least 1), on the bottom row and centred (the left one of the two middle columns
    when the centre falls between pixels; at 320 x 240 columns 147-171, rows 215-239: the paper's
    box one full-size pixel to the left)."""
    if (width, height) == (FRAME_WIDTH, FRAME_HEIGHT):
        return SAFE_BOX
    side = max(1, round(SAFE_BOX[3] * height / FRAME_HEIGHT))
    side_w = max(1, round(SAFE_BOX[2] * width / FRAME_WIDTH))
    return (width - side_w) // 2, height - side, side_w, side


def safe_box_slices(width: int = FRAME_WIDTH, height: int = FRAME_HEIGHT) -> tuple[slice, slice]:
    """Row and column slices selecting the safe box from an (H, W, ...) frame of ``width`` x
    ``height`` (the paper's 640 x 480 by default)."""
    x, y, w, h = safe_box(width, height)
    return slice(y, y + h), slice(x, x + w)
