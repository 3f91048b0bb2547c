"""Synthetic camera-like frames — light-blue felt strip on dark-brown carpet — for tests and demos.

Not a renderer: no camera geometry, just a plausible picture (perspective-narrowed strip, noise
texture, a light gradient and an optional shadow band) so vision code can be exercised without the
simulator.
"""

from __future__ import annotations

import cv2
import numpy as np

from .grid import FRAME_HEIGHT, FRAME_WIDTH

FELT_RGB = (120, 175, 215)
CARPET_RGB = (70, 48, 32)


def felt_on_carpet_frame(
    rng: np.random.Generator,
    *,
    heading_rad: float = 0.0,
    offset_px: float = 0.0,
    width_px: float = 260.0,
    shadow: bool = False,
    brightness: float = 1.0,
) -> np.ndarray:
    """An RGB uint8 (480, 640, 3) frame of a felt strip receding towards the top of the image.

    ``heading_rad`` bends the strip sideways with height, ``offset_px`` shifts it at the bottom
    edge, ``width_px`` is its width at the bottom edge (it narrows to 40 % at the top).
    """
    h, w = FRAME_HEIGHT, FRAME_WIDTH
    ys = np.arange(h, dtype=np.float64)[:, None]
    xs = np.arange(w, dtype=np.float64)[None, :]
    depth = (h - 1 - ys) / (h - 1)  # 0 at the bottom edge, 1 at the top
    centre = w / 2 + offset_px + np.tan(heading_rad) * depth * h
    half = 0.5 * width_px * (1.0 - 0.6 * depth)
    on_felt = np.abs(xs - centre) <= half

    carpet_texture = rng.normal(0.0, 14.0, (h, w, 1)) + rng.normal(0.0, 6.0, (h, w, 3))
    felt_texture = rng.normal(0.0, 7.0, (h, w, 1)) + rng.normal(0.0, 3.0, (h, w, 3))
    carpet = np.asarray(CARPET_RGB, dtype=np.float64) + carpet_texture
    felt = np.asarray(FELT_RGB, dtype=np.float64) + felt_texture
    image = np.where(on_felt[..., None], felt, carpet)

    light = brightness * (
        0.8 + 0.35 * np.exp(-(((xs - w * 0.6) / 300) ** 2 + ((ys - 120) / 260) ** 2))
    )
    if shadow:
        band = np.abs((ys - 0.6 * xs) - rng.uniform(60, 260)) < 40
        light = light * np.where(band, 0.55, 1.0)
    image = image * light[..., None]
    image = cv2.GaussianBlur(np.clip(image, 0, 255).astype(np.float32), (3, 3), 0)
    return np.clip(np.rint(image), 0, 255).astype(np.uint8)


def synthetic_frames(rng: np.random.Generator, n: int) -> list[np.ndarray]:
    """``n`` varied felt-on-carpet frames (headings, offsets, shadows, brightness) from ``rng``.

    The safe box always lies on the felt.
    """
    frames = []
    for _ in range(n):
        width = float(rng.uniform(180, 360))
        # Keep the safe box (50 px wide at the bottom centre) on the felt, as careful driving does.
        reach = width / 2 - 40
        frames.append(
            felt_on_carpet_frame(
                rng,
                heading_rad=float(rng.uniform(-0.6, 0.6)),
                offset_px=float(rng.uniform(-reach, reach)),
                width_px=width,
                shadow=bool(rng.random() < 0.4),
                brightness=float(rng.uniform(0.7, 1.2)),
            )
        )
    return frames


def patch_library(frames: list[np.ndarray], bins: int, rng: np.random.Generator):
    """A full road library (10 types x 10 examples) of random 50 x 50 patches of ``frames``.

    Not built by Algorithm 1: a fixed layout that exercises every model slot, for checking road
    values against a naive loop and for timing them with a full library.
    """
    from .histograms import patch_histograms
    from .road_library import RoadLibrary

    types = []
    for _ in range(10):
        examples = []
        for _ in range(10):
            frame = frames[int(rng.integers(len(frames)))]
            y = int(rng.integers(0, FRAME_HEIGHT - 50))
            x = int(rng.integers(0, FRAME_WIDTH - 50))
            model = patch_histograms(frame[y : y + 50, x : x + 50], bins)
            examples.append({"selections": 0, "comparisons": 0, "model": model.tolist()})
        types.append({"selections": 0, "comparisons": 0, "examples": examples})
    return RoadLibrary.from_dict(
        {
            "version": 1,
            "bins": bins,
            "similarity_threshold": 0.75,
            "max_types": 10,
            "max_examples": 10,
            "types": types,
        }
    )
