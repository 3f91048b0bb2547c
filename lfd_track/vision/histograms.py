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

import weakref
from concurrent.futures import ThreadPoolExecutor
from typing import Any

import cv2
import numpy as np

from .grid import (
    FRAME_HEIGHT,
    FRAME_WIDTH,
    GRID_COLUMNS,
    GRID_ROWS,
    N_REGIONS,
    grid_fits,
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
    """Raise ``ValueError`` unless ``frame`` is an RGB uint8 (480, 640, 3) array, or an (H, W, 3)
    one the 8 x 5 grid divides evenly (a camera with ``scale``: (240, 320, 3) at half size)."""
    if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8:
        raise ValueError("frame must be a uint8 numpy array")
    if frame.shape != (FRAME_HEIGHT, FRAME_WIDTH, 3) and not (
        frame.ndim == 3 and frame.shape[2] == 3 and grid_fits(frame.shape[1], frame.shape[0])
    ):
        raise ValueError(
            f"frame must have shape ({FRAME_HEIGHT}, {FRAME_WIDTH}, 3) (or a smaller camera's"
            f" (H, W, 3) with H a multiple of {GRID_ROWS} and W of {GRID_COLUMNS}),"
            f" got {frame.shape}"
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
    # Extremes of each histogram, reduced across histograms in a transposed copy: numpy reduces
    # many short rows slowly, and a minimum or maximum is exact in any order.
    by_bin = np.ascontiguousarray(counts.reshape(-1, counts.shape[-1]).T)
    keep = (*counts.shape[:-1], 1)
    lo = np.minimum.reduce(by_bin, axis=0).reshape(keep)
    hi = np.maximum.reduce(by_bin, axis=0).reshape(keep)
    span = hi - lo
    # OpenCV: scale = 1 / (max - min) if the span exceeds DBL_EPSILON, else 0; shift = -min * scale.
    scale = np.divide(1.0, span, out=np.zeros_like(span), where=span > DBL_EPSILON)
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

    Regions are an eighth of the frame's width and a fifth of its height (80 x 96 px of the
    paper's 640 x 480 frame, 40 x 48 px of a half-size camera's); the buffers follow the size of
    the frames given.

    Of a 640 x 480 frame: one ``cv2.calcHist`` per region and channel, straight on views of the
    RGB frame and of its HSV conversion, letting OpenCV do the binning: nothing is copied, split or re-coded, and every
    call's arguments, including a view of the output array to write into, are built once.
    Measured against packing several regions into one call through bin-index codes, this was
    faster at every bin count: raw 8-bit values are spread over many counters, whereas bin codes
    of a near-uniform region hit the same counter back to back and stall on that dependency.
    Of a smaller frame (a camera with ``scale``), whose 200 regions are too small to be worth a
    call each: one call per row of regions and channel on bin codes (``_count_codes``), or one
    joint call per channel over a region-label image where the codes do not fit in a byte.

    With ``threads`` = 2 a worker thread counts half of the regions (OpenCV releases the GIL) of
    a 640 x 480 frame (a smaller frame is counted in one thread);
    None follows ``cv2.getNumThreads()``, so a process that pins OpenCV to one thread stays
    single-threaded here too. The HSV and output buffers are reused, so one instance must not be
    used from two threads at once.
    """

    def __init__(self, bins: int, threads: int | None = None) -> None:
        self.bins = check_bins(bins)
        if threads is not None and (isinstance(threads, bool) or threads not in (1, 2)):
            raise ValueError(f"threads must be 1, 2 or None, got {threads!r}")
        self._threads = threads
        self._out = np.empty((N_REGIONS, N_CHANNELS, self.bins), dtype=np.float32)
        self._layout(FRAME_HEIGHT, FRAME_WIDTH)
        self._executor: ThreadPoolExecutor | None = None

    def __getstate__(self) -> dict[str, Any]:
        """Only the settings and the frame size: the buffers are views into one another, which a
        pickle or copy would turn into separate arrays that no longer receive the counts."""
        return {"bins": self.bins, "threads": self._threads, "shape": self._shape}

    def __setstate__(self, state: dict[str, Any]) -> None:
        # A pickle written before this method holds the whole instance dictionary.
        threads = state["threads"] if "threads" in state else state["_threads"]
        self.__init__(state["bins"], threads)  # type: ignore[misc]
        height, width = (state["shape"] if "shape" in state else state["_shape"])[:2]
        if (height, width) != (FRAME_HEIGHT, FRAME_WIDTH):
            self._layout(height, width)

    def _layout(self, height: int, width: int) -> None:
        """Buffers and region views for frames of ``height`` x ``width`` (the grid keeps its 8 x
        5 regions, each ``width / 8`` x ``height / 5`` px)."""
        self._shape = (height, width, 3)
        self._hsv = np.empty(self._shape, dtype=np.uint8)
        region_h, region_w = height // GRID_ROWS, width // GRID_COLUMNS
        # Per region: its pixel rows and columns, its HSV block (the buffer is fixed, so the view
        # is built once), and the output view of each channel.
        self._regions = []
        for region in range(N_REGIONS):
            row, col = divmod(region, GRID_COLUMNS)
            rows = slice(row * region_h, (row + 1) * region_h)
            cols = slice(col * region_w, (col + 1) * region_w)
            outs = [self._out[region, c].reshape(self.bins, 1) for c in range(N_CHANNELS)]
            self._regions.append((rows, cols, [self._hsv[rows, cols]], outs))
        # Frames smaller than the paper's (a camera with ``scale``): with regions of a quarter of
        # the pixels the cost of 200 calls outweighs the counting (measured: one joint call per
        # channel over a region-label image 0.6 against 0.9 ms at 320 x 240; at 640 x 480 the
        # per-region calls stay faster, 1.9 against 2.4 ms). Bin codes counted per row of
        # regions are faster still where they fit in a byte (at 320 x 240, 32 bins: 0.68 against
        # 0.80 ms alone, 0.78 against 0.83 inside the closed loop): 1-D calls count a pixel
        # faster than joint ones.
        self._labels: np.ndarray | None = None
        self._shift = 0
        self._codes: tuple[np.ndarray, np.ndarray, np.ndarray, list, np.ndarray] | None = None
        if height * width < FRAME_HEIGHT * FRAME_WIDTH:
            row_of = np.arange(height) // region_h
            col_of = np.arange(width) // region_w
            self._labels = (row_of[:, None] * GRID_COLUMNS + col_of[None, :]).astype(np.uint8)
            shift = 8 - (self.bins.bit_length() - 1)
            n_codes = self.bins * GRID_COLUMNS
            if self.bins == 1 << (8 - shift) and n_codes <= 256:
                # Bin codes of one row of regions fit in a byte: column x bins + the value's bin,
                # the bin of a value of a 256-level channel being the value shifted right (the
                # same bin as calcHist's floor(v * bins / 256) when bins is a power of two).
                column = (col_of * self.bins).astype(np.uint8)
                base = np.ascontiguousarray(np.broadcast_to(column[None, :, None], self._shape))
                rgb_codes, hsv_codes = np.empty_like(base), np.empty_like(base)
                bands = [
                    ([rgb_codes[r : r + region_h]], [hsv_codes[r : r + region_h]])
                    for r in range(0, height, region_h)
                ]
                per_band = np.empty((GRID_ROWS, N_CHANNELS, n_codes, 1), dtype=np.float32)
                self._codes = (base, rgb_codes, hsv_codes, bands, per_band)
                self._shift = shift

    def _count(self, frame: np.ndarray, first: int, stop: int) -> None:
        """Fill the output rows of regions ``first`` .. ``stop - 1``."""
        size = [self.bins]
        rgb_range, h_range = [0, CHANNEL_UPPER[0]], [0, CHANNEL_UPPER[3]]
        for rows, cols, hsv_block, (r, g, b, h, s) in self._regions[first:stop]:
            rgb_block = [frame[rows, cols]]
            self._calc(rgb_block, [0], size, rgb_range, r)
            self._calc(rgb_block, [1], size, rgb_range, g)
            self._calc(rgb_block, [2], size, rgb_range, b)
            self._calc(hsv_block, [0], size, h_range, h)
            self._calc(hsv_block, [1], size, rgb_range, s)

    @staticmethod
    def _calc(images: list, channel: list, size: list, ranges: list, hist: np.ndarray) -> None:
        result = cv2.calcHist(images, channel, None, size, ranges, hist=hist)
        if result is not hist and not np.shares_memory(result, hist):
            hist[...] = result  # OpenCV allocated its own output after all

    def _count_joint(self, frame: np.ndarray) -> None:
        """Fill every region's counts with one joint ``cv2.calcHist`` per channel: (region label,
        channel value), 40 x bins. The label's bins are the labels themselves and the value's the
        same arithmetic as one call per region, so the counts are the same numbers."""
        assert self._labels is not None
        size = [N_REGIONS, self.bins]
        for c in range(N_CHANNELS):
            image = frame if c < 3 else self._hsv
            result = cv2.calcHist(
                [self._labels, image],
                [0, 1 + (c if c < 3 else c - 3)],
                None,
                size,
                [0, N_REGIONS, 0, CHANNEL_UPPER[c]],
            )
            self._out[:, c] = result

    def _count_codes(self, frame: np.ndarray) -> None:
        """Fill every region's counts from bin codes: per row of regions and channel, one 1-D
        ``cv2.calcHist`` of the codes (column x bins + bin) gives the row's eight regions at
        once, each code one region's bin, so the counts are the same numbers. R, G, B and S this
        way, whose bins are the values shifted right; H (180 levels) by one joint call."""
        assert self._codes is not None and self._labels is not None
        base, rgb_codes, hsv_codes, bands, per_band = self._codes
        np.right_shift(frame, self._shift, out=rgb_codes)
        cv2.bitwise_or(rgb_codes, base, dst=rgb_codes)
        np.right_shift(self._hsv, self._shift, out=hsv_codes)
        cv2.bitwise_or(hsv_codes, base, dst=hsv_codes)
        n_codes = per_band.shape[2]
        size, codes = [n_codes], [0, n_codes]
        for (rgb_band, hsv_band), out in zip(bands, per_band, strict=True):
            self._calc(rgb_band, [0], size, codes, out[0])
            self._calc(rgb_band, [1], size, codes, out[1])
            self._calc(rgb_band, [2], size, codes, out[2])
            self._calc(hsv_band, [1], size, codes, out[4])
        by_region = per_band.reshape(GRID_ROWS, N_CHANNELS, GRID_COLUMNS, self.bins)
        self._out.reshape(GRID_ROWS, GRID_COLUMNS, N_CHANNELS, self.bins)[...] = (
            by_region.transpose(0, 2, 1, 3)
        )
        self._out[:, 3] = cv2.calcHist(
            [self._labels, self._hsv],
            [0, 1],
            None,
            [N_REGIONS, self.bins],
            [0, N_REGIONS, 0, CHANNEL_UPPER[3]],
        )

    def _thread_count(self) -> int:
        if self._threads is not None:
            return self._threads
        return 2 if cv2.getNumThreads() >= 2 else 1

    def counts(self, frame: np.ndarray) -> np.ndarray:
        """Raw pixel counts per region, channel and bin, (40, 5, bins) float32."""
        check_frame(frame)
        if frame.shape != self._shape:
            self._layout(frame.shape[0], frame.shape[1])
        cv2.cvtColor(frame, cv2.COLOR_RGB2HSV, dst=self._hsv)
        if self._codes is not None:
            self._count_codes(frame)
        elif self._labels is not None:
            self._count_joint(frame)
        elif self._thread_count() > 1:
            if self._executor is None:
                self._executor = ThreadPoolExecutor(1, thread_name_prefix="grid-histogram")
                weakref.finalize(self, self._executor.shutdown, wait=False)
            half = N_REGIONS // 2
            other = self._executor.submit(self._count, frame, half, N_REGIONS)
            self._count(frame, 0, half)
            other.result()
        else:
            self._count(frame, 0, N_REGIONS)
        return self._out.copy()

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
    # The mean as ``ndarray.mean`` takes it (the sum, then divided by the count), without the
    # Python wrapper around it.
    centred = h - np.add.reduce(h, axis=2, keepdims=True) / h.shape[2]
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
    # A flat pair exists in channel c only if the two smallest sums of squares multiply to at most
    # DBL_EPSILON (all are >= 0); checking that first skips the (5, M, K) mask in the usual case.
    if ss_a.size and ss_b.size:
        smallest = np.minimum.reduce(ss_a, axis=1) * np.minimum.reduce(ss_b, axis=1)
        if (smallest <= DBL_EPSILON).any():
            flat = ss_a[:, :, None] * ss_b[:, None, :] <= DBL_EPSILON
            corr[flat] = 1.0
    # The mean over the channels as ``ndarray.mean`` takes it, without its Python wrapper.
    return np.add.reduce(corr, axis=0) / corr.shape[0]


def histogram_means(hists: np.ndarray) -> np.ndarray:
    """Mean level of the R, G, B histograms of models, (..., 5, bins) -> (..., 3) float64 in
    [0, 256): each bin at its centre, weighted by its (normalised) height."""
    h = np.asarray(hists, dtype=np.float64)[..., :3, :]
    bins = h.shape[-1]
    centres = (np.arange(bins) + 0.5) * (256.0 / bins)
    total = h.sum(axis=-1)
    # An element-wise product and sum, not a matrix product: the same bits on every processor.
    return np.asarray((h * centres).sum(axis=-1) / np.where(total > 0, total, 1.0))
