"""The phone-screen view of the paper's Fig. 2: regions tinted by road value, plus the safe box."""

from __future__ import annotations

import cv2
import numpy as np

from .grid import GRID_COLUMNS, GRID_ROWS, N_REGIONS, region_bounds
from .grid import safe_box as safe_box_rect
from .histograms import check_frame


def road_value_colour(value: float) -> tuple[int, int, int]:
    """RGB colour of a road value: red at -1 and below 0, through yellow, to green at 1."""
    t = float(np.clip(value, 0.0, 1.0))
    if t < 0.5:
        return (255, int(round(510 * t)), 0)
    return (int(round(510 * (1.0 - t))), 255, 0)


def draw_road_values(
    frame: np.ndarray, values: np.ndarray, safe_box: bool = True, alpha: float = 0.4
) -> np.ndarray:
    """Copy of ``frame`` with the 8 x 5 grid tinted by road value and each value written in.

    ``frame``: RGB uint8 (480, 640, 3) (or a smaller camera's, its grid and safe box scaled);
    ``values``: (40,) road values, row-major from the
    top-left. ``alpha`` is the tint's opacity. The safe box is outlined in white.
    """
    check_frame(frame)
    values = np.asarray(values, dtype=np.float64).reshape(-1)
    if values.shape != (N_REGIONS,):
        raise ValueError(f"values must have {N_REGIONS} entries, got {values.shape}")
    tint = np.empty_like(frame)
    size = (frame.shape[1], frame.shape[0])
    for i in range(N_REGIONS):
        x0, y0, x1, y1 = region_bounds(i, *size)
        tint[y0:y1, x0:x1] = road_value_colour(values[i])
    out = cv2.addWeighted(frame, 1.0 - alpha, tint, alpha, 0.0)
    for c in range(1, GRID_COLUMNS):
        x = region_bounds(c, *size)[0]
        cv2.line(out, (x, 0), (x, out.shape[0] - 1), (0, 0, 0), 1)
    for r in range(1, GRID_ROWS):
        y = region_bounds(r * GRID_COLUMNS, *size)[1]
        cv2.line(out, (0, y), (out.shape[1] - 1, y), (0, 0, 0), 1)
    for i in range(N_REGIONS):
        x0, y0, _, _ = region_bounds(i, *size)
        cv2.putText(
            out,
            f"{values[i]:.2f}",
            (x0 + 6, y0 + 20),
            cv2.FONT_HERSHEY_SIMPLEX,
            0.5,
            (255, 255, 255),
            1,
            cv2.LINE_AA,
        )
    if safe_box:
        x, y, w, h = safe_box_rect(*size)
        cv2.rectangle(out, (x, y), (x + w - 1, y + h - 1), (255, 255, 255), 2)
    return out
