"""Frames for the vision tests: synthetic felt-on-carpet frames and, when the renderer exists,
frames rendered from the simulated camera."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.vision.synthetic import synthetic_frames


def flat_rgb_region(frame: np.ndarray, region: int) -> np.ndarray:
    """Overwrite one 80 x 96 region so R, G and B each take every value 0..255 exactly 30 times.

    Their histograms are then flat for any bin count dividing 256, which triggers OpenCV's
    flat-histogram rule in ``compareHist``.
    """
    out = frame.copy()
    row, col = divmod(region, 8)
    values = np.arange(96 * 80) % 256
    rng = np.random.default_rng(region)
    planes = [rng.permutation(values) for _ in range(3)]
    out[row * 96 : (row + 1) * 96, col * 80 : (col + 1) * 80] = (
        np.stack(planes, -1).reshape(96, 80, 3).astype(np.uint8)
    )
    return out


def rendered_frames(n: int, seed: int) -> list[np.ndarray]:
    """Frames from the simulated camera on straights of the testing track."""
    from lfd_track.render.camera import CameraRenderer
    from lfd_track.render.texture import AppearanceConfig, LightingConfig, build_ground
    from lfd_track.world.track import load_track

    rng = np.random.default_rng(seed)
    ground = build_ground(load_track("testing"), AppearanceConfig(), LightingConfig(), rng)
    renderer = CameraRenderer()
    renderer.reset(rng)
    poses = [
        (0.3 + 0.5 * i, float(rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.4, 0.4)))
        for i in range(n)
    ]
    return [renderer.render(ground, np.array(p), rng) for p in poses]


@pytest.fixture(scope="session")
def frames() -> list[np.ndarray]:
    """Twelve synthetic frames, one with a flat-RGB region, plus four rendered by the simulator."""
    out = synthetic_frames(np.random.default_rng(7), 12)
    out[3] = flat_rgb_region(out[3], 5)
    return out + rendered_frames(4, seed=3)
