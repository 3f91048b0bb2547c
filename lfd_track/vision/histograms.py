"""Colour histograms and their OpenCV-compatible correlation, vectorised over regions and models.

A *model* is five histograms of a patch — R, G, B, H, S in OpenCV's 8-bit conventions (H in
[0, 180), the others in [0, 256); H and S from ``cv2.cvtColor(rgb, cv2.COLOR_RGB2HSV)``) — each
normalised like ``cv2.normalize(hist, hist, 0, 1, cv2.NORM_MINMAX)``: the smallest bin maps to 0 and
the largest to 1, a flat histogram becomes all zeros. (The paper does not say which norm it used;
this one is OpenCV's own histogram-comparison tutorial's, and correlation ignores scale anyway.)

Similarity of two models is the mean over the five channels of ``cv2.compareHist(...,
HISTCMP_CORREL)``. OpenCV returns exactly 1.0 when the product of the two histograms' sums of
squared deviations is not above ``DBL_EPSILON`` — i.e. when either histogram is flat — and this
module reproduces that rule.

Everything here agrees with per-region ``cv2.calcHist`` + ``cv2.normalize`` + per-pair
``cv2.compareHist`` to ~1e-7; the tests hold it to that.
"""

from __future__ import annotations

import cv2
import numpy as np

from .grid import (
    FRAME_HEIGHT,
    FRAME_WIDTH,
    GRID_COLUMNS,
    GRID_ROWS,
    N_REGIONS,
    REGION_HEIGHT,
    REGION_WIDTH,
)

CHANNEL_NAMES = ("R", "G", "B", "H", "S")
CHANNEL_UPPER = (256, 256, 256, 180, 256)
"""Exclusive upper end of each channel's histogram range (all start at 0)."""
N_CHANNELS = len(CHANNEL_NAMES)
DBL_EPSILON = float(np.finfo(np.float64).eps)


def check_bins(bins: int) -> int:
    """Validate a per-channel bin count (1..256 for 8-bit channels) and return it."""
    if isinstance(bins, bool) or not isinstance(bins, (int, np.integer)) or not 1 <= bins <= 256:
        raise ValueError(f"bins must be an integer in 1..256, got {bins!r}")
    return int(bins)


def check_frame(frame: np.ndarray) -> np.ndarray:
    """Raise ``ValueError`` unless ``frame`` is an RGB uint8 (480, 640, 3) array."""
    if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8:
        raise ValueError("frame must be a uint8 numpy array")
    if frame.shape != (FRAME_HEIGHT, FRAME_WIDTH, 3):
        raise ValueError(
            f"frame must have shape ({FRAME_HEIGHT}, {FRAME_WIDTH}, 3), got {frame.shape}"
        )
    return frame


def bin_lookup_tables(bins: int) -> np.ndarray:
    """Bin index of every 8-bit value for each channel, (5, 256) uint8.

    Same arithmetic as ``cv2.calcHist`` with uniform ranges: ``floor(v * bins / upper)`` in double
    precision, clamped to the last bin. Values at or above the upper end (H >= 180, which
    ``cvtColor`` never produces) are clamped too; they cannot occur in real input.
    """
    bins = check_bins(bins)
    values = np.arange(256, dtype=np.float64)
    tables = np.empty((N_CHANNELS, 256), dtype=np.uint8)
    for c, upper in enumerate(CHANNEL_UPPER):
        scale = bins / float(upper)
        tables[c] = np.clip(np.floor(values * scale), 0, bins - 1).astype(np.uint8)
    return tables


def split_channels(rgb: np.ndarray) -> list[np.ndarray]:
    """The five 8-bit planes R, G, B, H, S of an RGB uint8 (H, W, 3) image."""
    hsv = cv2.cvtColor(np.ascontiguousarray(rgb), cv2.COLOR_RGB2HSV)
    r, g, b = cv2.split(rgb)
    h, s, _ = cv2.split(hsv)
    return [r, g, b, h, s]


def normalize_minmax(counts: np.ndarray) -> np.ndarray:
    """Min-max normalise histograms along the last axis to [0, 1], like ``cv2.normalize``.

    ``counts``: (..., bins) any real dtype. Returns float32 of the same shape; a flat histogram
    (max == min) becomes all zeros, as OpenCV does.
    """
    counts = np.asarray(counts, dtype=np.float64)
    lo = counts.min(axis=-1, keepdims=True)
    hi = counts.max(axis=-1, keepdims=True)
    span = hi - lo
    # OpenCV: scale = 1 / (max - min) if the span exceeds DBL_EPSILON, else 0; shift = -min * scale.
    scale = np.where(span > DBL_EPSILON, 1.0 / np.where(span > 0, span, 1.0), 0.0)
    return (counts * scale - lo * scale).astype(np.float32)


def patch_histograms(rgb: np.ndarray, bins: int) -> np.ndarray:
    """Normalised R, G, B, H, S histograms of an RGB uint8 patch, (5, bins) float32."""
    bins = check_bins(bins)
    planes = split_channels(rgb)
    counts = np.empty((N_CHANNELS, bins), dtype=np.float32)
    for c, plane in enumerate(planes):
        counts[c] = cv2.calcHist([plane], [0], None, [bins], [0, CHANNEL_UPPER[c]]).ravel()
    return normalize_minmax(counts)


class GridHistogrammer:
    """Computes the normalised histograms of all 40 regions of a frame at once.

    Each channel is mapped to bin indices through a lookup table, then several regions of a grid
    row are packed into one 8-bit code (``column_in_group * bins + bin``) so that a single 1-D
    ``cv2.calcHist`` over a band of rows counts up to eight regions together (all eight when
    bins <= 32). Counts are exact integers, so the result equals per-region ``calcHist``.
    """

    def __init__(self, bins: int) -> None:
        self.bins = check_bins(bins)
        self._tables = bin_lookup_tables(self.bins)
        per_group = max(1, min(GRID_COLUMNS, 256 // self.bins))
        self._groups = [
            (g, min(g + per_group, GRID_COLUMNS)) for g in range(0, GRID_COLUMNS, per_group)
        ]
        column = np.arange(FRAME_WIDTH) // REGION_WIDTH
        offset = ((column % per_group) * self.bins).astype(np.uint8)
        self._offsets = np.ascontiguousarray(np.broadcast_to(offset, (FRAME_HEIGHT, FRAME_WIDTH)))

    def counts(self, frame: np.ndarray) -> np.ndarray:
        """Raw pixel counts per region, channel and bin, (40, 5, bins) float32."""
        check_frame(frame)
        bins = self.bins
        out = np.empty((GRID_ROWS, GRID_COLUMNS, N_CHANNELS, bins), dtype=np.float32)
        for c, plane in enumerate(split_channels(frame)):
            codes = cv2.add(cv2.LUT(plane, self._tables[c]), self._offsets)
            for row in range(GRID_ROWS):
                band = codes[row * REGION_HEIGHT : (row + 1) * REGION_HEIGHT]
                for g0, g1 in self._groups:
                    n = (g1 - g0) * bins
                    block = band[:, g0 * REGION_WIDTH : g1 * REGION_WIDTH]
                    hist = cv2.calcHist([block], [0], None, [n], [0, n])
                    out[row, g0:g1, c] = hist.reshape(g1 - g0, bins)
        return out.reshape(N_REGIONS, N_CHANNELS, bins)

    def histograms(self, frame: np.ndarray) -> np.ndarray:
        """Normalised histograms of the 40 regions, (40, 5, bins) float32, row-major regions."""
        return normalize_minmax(self.counts(frame))


def centred_unit(hists: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Prepare histograms for correlation.

    ``hists``: (M, 5, bins). Returns ``unit`` (5, M, bins) float64 — each histogram minus its mean,
    divided by its norm (zeros for a flat histogram) — and ``sumsq`` (5, M) float64, the sums of
    squared deviations that OpenCV's flat-histogram rule looks at.
    """
    h = np.asarray(hists, dtype=np.float64)
    if h.ndim != 3 or h.shape[1] != N_CHANNELS:
        raise ValueError(f"histograms must have shape (M, {N_CHANNELS}, bins), got {h.shape}")
    centred = h - h.mean(axis=2, keepdims=True)
    sumsq = np.einsum("mcb,mcb->cm", centred, centred)
    norm = np.sqrt(sumsq)
    unit = centred.transpose(1, 0, 2) / np.where(norm > 0, norm, 1.0)[:, :, None]
    return unit, sumsq


def similarity_matrix(
    a: tuple[np.ndarray, np.ndarray], b: tuple[np.ndarray, np.ndarray]
) -> np.ndarray:
    """Mean-over-channels ``HISTCMP_CORREL`` between every pair, (M, K) float64.

    ``a`` and ``b`` come from :func:`centred_unit` for M and K models. One batched matrix product
    per call; a channel pair whose sums of squared deviations multiply to at most ``DBL_EPSILON``
    scores 1.0, as ``cv2.compareHist`` does.
    """
    unit_a, ss_a = a
    unit_b, ss_b = b
    corr = np.matmul(unit_a, unit_b.transpose(0, 2, 1))  # (5, M, K)
    flat = ss_a[:, :, None] * ss_b[:, None, :] <= DBL_EPSILON
    corr[flat] = 1.0
    return corr.mean(axis=0)
