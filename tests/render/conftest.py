"""What the render tests share: the testing track and its floor, built once per module."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.render.texture import AppearanceConfig, GroundTexture, LightingConfig, build_ground
from lfd_track.world.track import Track, load_track


@pytest.fixture(scope="module")
def track() -> Track:
    """The testing track."""
    return load_track("testing")


@pytest.fixture(scope="module")
def ground(track: Track) -> GroundTexture:
    """The testing track's floor with the default appearance and lighting (texture seed 7)."""
    return build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(7))
