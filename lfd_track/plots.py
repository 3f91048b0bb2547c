"""Pictures for reports: fitness curves and trajectory maps, drawn with OpenCV (no matplotlib)."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np

from .render.topdown import draw_trajectories
from .world.track import Track

SUCCESS_RGB = (40, 170, 60)
FAILURE_RGB = (215, 40, 40)
TIMEOUT_RGB = (240, 160, 20)


def outcome_colour(success: bool, failure: str | None) -> tuple[int, int, int]:
    """Green for a success, orange for a timeout, red for a failure."""
    if success:
        return SUCCESS_RGB
    return TIMEOUT_RGB if failure == "timeout" else FAILURE_RGB


def fitness_plot(
    curves: Sequence[tuple[str, np.ndarray, tuple[int, int, int]]],
    *,
    size_px: tuple[int, int] = (720, 420),
    title: str = "fitness per generation (lower is better)",
) -> np.ndarray:
    """Line plot of fitness curves; ``curves`` holds (label, values (G,), RGB). Returns RGB uint8."""
    width, height = size_px
    img = np.full((height, width, 3), 255, np.uint8)
    left, right, top, bottom = 60, 20, 40, 40
    plot_w, plot_h = width - left - right, height - top - bottom
    values = [np.asarray(v, dtype=float) for _, v, _ in curves if len(v)]
    if not values:
        return img
    lo = min(float(np.nanmin(v)) for v in values)
    hi = max(float(np.nanmax(v)) for v in values)
    lo, hi = min(lo, 0.0), max(hi, lo + 1e-6)
    n = max(len(v) for v in values)
    cv2.rectangle(img, (left, top), (left + plot_w, top + plot_h), (0, 0, 0), 1)
    for k in range(5):
        y_val = lo + (hi - lo) * k / 4
        y = int(top + plot_h - (y_val - lo) / (hi - lo) * plot_h)
        cv2.line(img, (left - 4, y), (left, y), (0, 0, 0), 1)
        cv2.putText(img, f"{y_val:.2f}", (5, y + 4), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1)
    cv2.putText(img, title, (left, 25), cv2.FONT_HERSHEY_SIMPLEX, 0.5, (0, 0, 0), 1)
    cv2.putText(
        img,
        f"generation (0..{n})",
        (left + plot_w // 2 - 60, height - 12),
        cv2.FONT_HERSHEY_SIMPLEX,
        0.4,
        (0, 0, 0),
        1,
    )
    for label_row, (label, curve, colour) in enumerate(curves):
        curve = np.asarray(curve, dtype=float)
        if len(curve) < 2:
            continue
        xs = left + np.arange(len(curve)) / max(n - 1, 1) * plot_w
        ys = top + plot_h - (curve - lo) / (hi - lo) * plot_h
        pts = np.stack([xs, ys], axis=1).round().astype(np.int32)
        cv2.polylines(img, [pts], False, colour, 1, cv2.LINE_AA)
        if label:
            y = top + 15 + 15 * label_row
            cv2.line(img, (left + plot_w - 150, y - 4), (left + plot_w - 130, y - 4), colour, 2)
            cv2.putText(
                img, label, (left + plot_w - 125, y), cv2.FONT_HERSHEY_SIMPLEX, 0.4, (0, 0, 0), 1
            )
    return img


def trajectory_map(
    track: Track,
    trajectories: Sequence[np.ndarray],
    outcomes: Sequence[tuple[bool, str | None]],
    *,
    title: str = "",
    size_px: int = 800,
) -> np.ndarray:
    """Top-down picture of ``trajectories`` (N, 2) on ``track`` coloured by outcome."""
    colours = [outcome_colour(success, failure) for success, failure in outcomes]
    img = draw_trajectories(track, list(trajectories), colours, size_px=size_px)
    if title:
        cv2.putText(
            img, title, (10, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6, (255, 255, 255), 1, cv2.LINE_AA
        )
    return img


def stack_images(images: Sequence[np.ndarray], *, vertical: bool = False) -> np.ndarray:
    """Place RGB images side by side (or stacked), padding with white to a common size."""
    if vertical:
        width = max(i.shape[1] for i in images)
        padded = [
            np.pad(i, ((0, 0), (0, width - i.shape[1]), (0, 0)), constant_values=255)
            for i in images
        ]
        return np.concatenate(padded, axis=0)
    height = max(i.shape[0] for i in images)
    padded = [
        np.pad(i, ((0, height - i.shape[0]), (0, 0), (0, 0)), constant_values=255) for i in images
    ]
    return np.concatenate(padded, axis=1)


def write_png(path: str, rgb: np.ndarray) -> None:
    """Write an RGB image as PNG atomically."""
    from .atomic import atomic_write_bytes

    ok, buf = cv2.imencode(".png", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR))
    if not ok:
        raise OSError(f"{path}: PNG encoding failed")
    atomic_write_bytes(path, buf.tobytes())
