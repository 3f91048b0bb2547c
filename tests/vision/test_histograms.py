import cv2
import numpy as np
import pytest

from lfd_track.vision.histograms import (
    CHANNEL_UPPER,
    GridHistogrammer,
    bin_lookup_tables,
    centred_unit,
    normalize_minmax,
    patch_histograms,
    similarity_matrix,
)


@pytest.mark.parametrize("bins", [1, 7, 16, 32, 100, 180, 256])
def test_bin_tables_match_calchist(bins):
    tables = bin_lookup_tables(bins)
    for c, upper in enumerate(CHANNEL_UPPER):
        for v in range(upper):
            pixel = np.full((1, 1), v, np.uint8)
            hist = cv2.calcHist([pixel], [0], None, [bins], [0, upper]).ravel()
            assert hist[tables[c, v]] == 1, (bins, c, v)


def test_normalize_matches_cv2_including_flat():
    rng = np.random.default_rng(0)
    hists = rng.integers(0, 500, (20, 32)).astype(np.float32)
    hists[3] = 17.0  # flat: OpenCV turns it into zeros
    ours = normalize_minmax(hists)
    for h, o in zip(hists, ours, strict=True):
        ref = cv2.normalize(h.reshape(-1, 1), None, 0, 1, cv2.NORM_MINMAX).ravel()
        np.testing.assert_allclose(o, ref, atol=1e-7)
    assert not ours[3].any()


def test_similarity_matches_comparehist_including_flat():
    rng = np.random.default_rng(1)
    a = normalize_minmax(rng.integers(0, 50, (6, 5, 32)))
    b = normalize_minmax(rng.integers(0, 50, (4, 5, 32)))
    a[2, 1] = 0.0  # flat histograms correlate 1.0 with anything
    b[0, 4] = 0.0
    sims = similarity_matrix(centred_unit(a), centred_unit(b))
    for i in range(6):
        for k in range(4):
            per_channel = [
                cv2.compareHist(a[i, c].reshape(-1, 1), b[k, c].reshape(-1, 1), cv2.HISTCMP_CORREL)
                for c in range(5)
            ]
            assert sims[i, k] == pytest.approx(np.mean(per_channel), abs=1e-9)
    assert cv2.compareHist(a[2, 1], b[1, 1], cv2.HISTCMP_CORREL) == 1.0


@pytest.mark.parametrize("bins", [8, 16, 32, 64, 256])
def test_grid_counts_equal_per_region_calchist(frames, bins):
    frame = frames[3]
    counts = GridHistogrammer(bins).counts(frame)
    hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV)
    planes = [(frame, 0), (frame, 1), (frame, 2), (hsv, 0), (hsv, 1)]
    for region in (0, 5, 13, 27, 39):
        row, col = divmod(region, 8)
        for c, (img, ch) in enumerate(planes):
            patch = img[row * 96 : (row + 1) * 96, col * 80 : (col + 1) * 80]
            ref = cv2.calcHist([patch], [ch], None, [bins], [0, CHANNEL_UPPER[c]]).ravel()
            np.testing.assert_array_equal(counts[region, c], ref)


def test_patch_histograms_shape_and_range(frames):
    model = patch_histograms(frames[0][430:480, 295:345], 32)
    assert model.shape == (5, 32) and model.dtype == np.float32
    assert model.min() == 0.0 and model.max() == 1.0


def test_bad_bins_rejected():
    with pytest.raises(ValueError, match="bins"):
        GridHistogrammer(0)
    with pytest.raises(ValueError, match="bins"):
        GridHistogrammer(257)


@pytest.mark.parametrize("size", [(480, 640), (240, 320)])
@pytest.mark.parametrize("threads", [1, 2])
def test_a_pickled_or_copied_grid_counts_what_the_original_counts(frames, size, threads):
    """The counting buffers are views into one another; a pickle (a controller sent to a worker
    process) or a deep copy must not cut them apart, or the counts stop reaching the output."""
    import copy
    import pickle

    shaped = [cv2.resize(f, size[::-1], interpolation=cv2.INTER_AREA) for f in frames[:3]]
    grid = GridHistogrammer(32, threads=threads)
    grid.counts(shaped[0])  # laid out for this frame size before it is copied
    for twin in (pickle.loads(pickle.dumps(grid)), copy.deepcopy(grid)):
        for frame in shaped:
            np.testing.assert_array_equal(twin.counts(frame), grid.counts(frame))
