"""Grid counts at any bin count, with one or two threads, and with reused buffers."""

import cv2
import numpy as np
import pytest

from lfd_track.vision.histograms import CHANNEL_UPPER, GridHistogrammer


def per_region_calchist(frame: np.ndarray, bins: int) -> np.ndarray:
    """(40, 5, bins) counts from one cv2.calcHist per region and channel."""
    hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV)
    planes = [(frame, 0), (frame, 1), (frame, 2), (hsv, 0), (hsv, 1)]
    out = np.empty((40, 5, bins), np.float32)
    for region in range(40):
        row, col = divmod(region, 8)
        for c, (img, ch) in enumerate(planes):
            patch = img[row * 96 : (row + 1) * 96, col * 80 : (col + 1) * 80]
            hist = cv2.calcHist([patch], [ch], None, [bins], [0, CHANNEL_UPPER[c]])
            out[region, c] = hist.ravel()
    return out


def noise_frame(seed: int) -> np.ndarray:
    return np.random.default_rng(seed).integers(0, 256, (480, 640, 3), dtype=np.uint8)


@pytest.mark.parametrize("bins", [1, 2, 7, 10, 100, 128, 129, 180, 255])
def test_counts_equal_per_region_calchist_any_bins(frames, bins):
    grid = GridHistogrammer(bins, threads=1)
    for frame in (frames[0], noise_frame(bins)):
        np.testing.assert_array_equal(grid.counts(frame), per_region_calchist(frame, bins))


@pytest.mark.parametrize("bins", [7, 32])
def test_two_threads_give_the_same_counts(frames, bins):
    one, two = GridHistogrammer(bins, threads=1), GridHistogrammer(bins, threads=2)
    for frame in (frames[1], frames[3], noise_frame(3)):
        np.testing.assert_array_equal(two.counts(frame), one.counts(frame))


def test_reused_buffers_do_not_leak_between_frames(frames):
    grid = GridHistogrammer(32)
    first = grid.counts(frames[0])
    kept = first.copy()
    second = grid.counts(frames[1])
    np.testing.assert_array_equal(first, kept)  # the returned array is not a buffer view
    np.testing.assert_array_equal(second, per_region_calchist(frames[1], 32))
    assert second.shape == (40, 5, 32) and second.dtype == np.float32
    assert second.sum() == 5 * 480 * 640


def test_bad_thread_count_rejected():
    for bad in (0, 3, True):
        with pytest.raises(ValueError, match="threads"):
            GridHistogrammer(32, threads=bad)
