"""Region histograms and road values of frames smaller than the paper's (a camera with scale)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from lfd_track.vision.grid import region_bounds
from lfd_track.vision.histograms import CHANNEL_UPPER, GridHistogrammer, split_channels
from lfd_track.vision.road_library import RoadLibrary


def _reference_counts(frame: np.ndarray, bins: int) -> np.ndarray:
    """One cv2.calcHist per region and channel, as the paper's code would."""
    height, width = frame.shape[:2]
    out = np.empty((40, 5, bins), np.float32)
    for region in range(40):
        x0, y0, x1, y1 = region_bounds(region, width, height)
        planes = split_channels(np.ascontiguousarray(frame[y0:y1, x0:x1]))
        for c, plane in enumerate(planes):
            out[region, c] = cv2.calcHist([plane], [0], None, [bins], [0, CHANNEL_UPPER[c]]).ravel()
    return out


@pytest.mark.parametrize(("height", "width"), [(240, 320), (120, 160), (480, 640)])
@pytest.mark.parametrize("bins", [16, 32, 256])
def test_counts_are_those_of_one_call_per_region(height, width, bins):
    frame = np.random.default_rng(bins).integers(0, 256, (height, width, 3), dtype=np.uint8)
    grid = GridHistogrammer(bins, threads=1)
    np.testing.assert_array_equal(grid.counts(frame), _reference_counts(frame, bins))


@pytest.mark.parametrize("bins", [1, 2, 8, 24, 32, 33, 64])
def test_small_frame_counts_by_bin_codes_or_joint_calls_are_exact(bins):
    # Powers of two up to 32 are counted by bin codes per row of regions, other bin counts by
    # joint calls; both give each region's own counts, flat regions and extreme values included.
    rng = np.random.default_rng(bins)
    frame = rng.integers(0, 256, (240, 320, 3), dtype=np.uint8)
    frame[:48, :40] = (255, 0, 255)  # hue 150, full saturation
    frame[48:96] = 0
    frame[96:144, 120:200] = (255, 255, 255)
    frame[200:, 300:] = (254, 1, 128)
    grid = GridHistogrammer(bins, threads=1)
    np.testing.assert_array_equal(grid.counts(frame), _reference_counts(frame, bins))
    # The buffers are reused: a second, different frame is counted afresh.
    other = np.ascontiguousarray(frame[::-1])
    np.testing.assert_array_equal(grid.counts(other), _reference_counts(other, bins))


def test_one_histogrammer_follows_the_frame_size():
    rng = np.random.default_rng(0)
    grid = GridHistogrammer(32)
    for shape in [(480, 640, 3), (240, 320, 3), (480, 640, 3)]:
        frame = rng.integers(0, 256, shape, dtype=np.uint8)
        np.testing.assert_array_equal(grid.counts(frame), _reference_counts(frame, 32))


def test_a_library_learns_from_the_safe_box_of_a_half_frame():
    frame = np.zeros((240, 320, 3), np.uint8)
    frame[215:240, 147:172] = (118, 176, 214)  # the half frame's safe box, felt blue
    library = RoadLibrary()
    library.learn(frame)
    values = library.road_values(frame, update_statistics=False)
    assert values.shape == (40,)
    # Only the bottom-centre regions hold the felt; their best similarity is the highest.
    assert values.argmax() in (35, 36)
