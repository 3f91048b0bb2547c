"""Acceptance: vectorised road values equal a naive calcHist + compareHist loop (to 1e-6)."""

import cv2
import numpy as np
import pytest

from lfd_track.vision.histograms import patch_histograms
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import patch_library

CHANNELS = [(0, 256), (1, 256), (2, 256), (0, 180), (1, 256)]  # (plane index, range) R G B H S


def naive_region_model(frame, region, bins):
    hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV)
    row, col = divmod(region, 8)
    sl = (slice(row * 96, (row + 1) * 96), slice(col * 80, (col + 1) * 80))
    model = []
    for c, (plane, upper) in enumerate(CHANNELS):
        image = frame if c < 3 else hsv
        hist = cv2.calcHist([image[sl]], [plane], None, [bins], [0, upper])
        model.append(cv2.normalize(hist, None, 0, 1, cv2.NORM_MINMAX))
    return model


def naive_road_values(frame, library_models, bins):
    """Algorithm 2 literally: per region, per type, per example, strict '>' keeps the best."""
    values, chosen = [], []
    for region in range(40):
        region_model = naive_region_model(frame, region, bins)
        best, best_at = -np.inf, None
        for t, examples in enumerate(library_models):
            for e, example in enumerate(examples):
                corr = np.mean(
                    [
                        cv2.compareHist(
                            region_model[c], np.ascontiguousarray(example[c]), cv2.HISTCMP_CORREL
                        )
                        for c in range(5)
                    ]
                )
                if corr > best:
                    best, best_at = corr, (t, e)
        values.append(best)
        chosen.append(best_at)
    return np.array(values), chosen


def full_library(frames, bins, seed=0):
    """10 types x 10 examples of 50 x 50 patches from the frames (felt, carpet, edges, shade)."""
    return patch_library(frames, bins, np.random.default_rng(seed))


@pytest.mark.parametrize("bins", [16, 32, 256])
def test_road_values_equal_naive_loop_full_library(frames, bins):
    library = full_library(frames, bins)
    assert library.n_types == 10 and library.n_models == 100
    models = [
        [np.asarray(e["model"], np.float32) for e in t["examples"]]
        for t in library.to_dict()["types"]
    ]
    test_frames = [frames[0], frames[3], frames[-1]]  # frames[3] has a flat-RGB region
    for frame in test_frames:
        expected, chosen = naive_road_values(frame, models, bins)
        ours = library.road_values(frame)
        assert ours.shape == (40,) and ours.dtype == np.float64
        np.testing.assert_allclose(ours, expected, atol=1e-6, rtol=0)
    # The selection counts follow the naive loop's choices (first in order on a tie).
    selected = {}
    for frame in test_frames:
        for t_e in naive_road_values(frame, models, bins)[1]:
            selected[t_e] = selected.get(t_e, 0) + 1
    for t in range(10):
        stats = library.example_statistics(t)
        for e, (sel, comp) in enumerate(stats):
            assert comp == 40 * len(test_frames)
            assert sel == selected.get((t, e), 0)
        assert library.type_statistics()[t][0] == sum(s for s, _ in stats)


def test_flat_region_engages_opencv_rule(frames):
    """The flat-RGB region's R, G, B histograms are flat, so compareHist returns exactly 1."""
    region_model = naive_region_model(frames[3], 5, 32)
    for c in range(3):
        assert not region_model[c].any()
        other = patch_histograms(frames[0][430:480, 295:345], 32)[c].copy()
        assert cv2.compareHist(region_model[c], other, cv2.HISTCMP_CORREL) == 1.0
    library = RoadLibrary()
    library.learn(frames[0])
    value = library.road_values(frames[3])[5]
    hs = [
        cv2.compareHist(region_model[c], library.models()[0][c].copy(), cv2.HISTCMP_CORREL)
        for c in (3, 4)
    ]
    assert value == pytest.approx((3.0 + sum(hs)) / 5.0, abs=1e-6)


def test_rendered_frames_equal_naive_loop(frames):
    rendered = frames[12:]
    assert len(rendered) == 4
    library = RoadLibrary()
    for frame in rendered:
        library.learn(frame)
    models = [
        [np.asarray(e["model"], np.float32) for e in t["examples"]]
        for t in library.to_dict()["types"]
    ]
    for frame in rendered:
        expected, _ = naive_road_values(frame, models, 32)
        np.testing.assert_allclose(library.road_values(frame), expected, atol=1e-6, rtol=0)
