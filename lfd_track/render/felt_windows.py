"""The felt's windows of the floor: where :func:`~lfd_track.render.texture.build_ground` paints
the felt's per-texel fields (edge, fray, fibres, pilling) and how it mixes the colour planes.

The felt covers a few per cent of a floor, so its fields are computed only in windows around the
strips (bands of :data:`_BAND_ROWS` rows, cells of :data:`_FELT_CELL` texels, each cut with room
for its blurs), which gives every texel the value the whole-floor computation gives it: outside the
windows the felt's coverage is exactly 0.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

#: Felt windows (``_felt_windows``) are unions of square cells this wide [texels] ...
_FELT_CELL = 16
#: ... taken in bands of this many rows [texels].
_BAND_ROWS = 64
#: Rows per chunk of the colour pass (small enough for its temporaries to stay in cache).
_CHUNK_ROWS = 64


def _gauss_reach(sigma: float) -> int:
    """Texels a ``cv2.GaussianBlur`` of a float image with ``sigma`` (kernel size left to OpenCV:
    ``round(8·sigma + 1) | 1``) reaches from its centre, rounded up with room to spare."""
    return int(math.ceil(4.0 * sigma)) + 2


def _felt_windows(mask: np.ndarray, reach: int) -> list[list[tuple[int, int]]]:
    """Column runs ``(c0, c1)`` per band of ``_BAND_ROWS`` rows: together they hold every texel
    within ``reach`` texels (along rows and columns) of a nonzero ``mask`` texel.

    ``mask`` is (H, W) with H and W multiples of ``_FELT_CELL``. A cell holding a mask texel marks
    every cell within ``ceil(reach / cell)`` cells of it; a band's runs are its marked columns.
    """
    cell = _FELT_CELL
    hc, wc = mask.shape[0] // cell, mask.shape[1] // cell
    occupied = mask.reshape(hc, cell, wc * cell).max(axis=1).reshape(hc, wc, cell).max(axis=2)
    k = -(-reach // cell)
    if k > 0:
        occupied = cv2.dilate(occupied, np.ones((2 * k + 1, 2 * k + 1), np.uint8))
    per_band = _BAND_ROWS // cell
    runs: list[list[tuple[int, int]]] = []
    for b0 in range(0, hc, per_band):
        marked = np.flatnonzero(occupied[b0 : b0 + per_band].max(axis=0))
        band: list[tuple[int, int]] = []
        if marked.size:
            breaks = np.flatnonzero(np.diff(marked) > 1)
            starts = np.concatenate([marked[:1], marked[breaks + 1]])
            ends = np.concatenate([marked[breaks], marked[-1:]]) + 1
            band = [(int(s) * cell, int(e) * cell) for s, e in zip(starts, ends, strict=True)]
        runs.append(band)
    return runs


def _window(
    image: np.ndarray, rows: tuple[int, int], cols: tuple[int, int], halo: int
) -> tuple[np.ndarray, tuple[slice, slice]]:
    """``image``'s rows × cols grown by ``halo`` on each side (clipped to the image), and the slices
    that cut the requested rows × cols back out of it."""
    h, w = image.shape[:2]
    r0, c0 = max(rows[0] - halo, 0), max(cols[0] - halo, 0)
    r1, c1 = min(rows[1] + halo, h), min(cols[1] + halo, w)
    inner = (slice(rows[0] - r0, rows[1] - r0), slice(cols[0] - c0, cols[1] - c0))
    return image[r0:r1, c0:c1], inner


@dataclass
class _FeltWindow:
    """The felt side of one window of the floor: its place and its per-texel fields."""

    rows: slice
    cols: slice
    coverage: np.ndarray  # final felt coverage in 0..1
    shade: np.ndarray  # felt brightness factor; lit and weighted by coverage in place later


def _rgb(planes: list[np.ndarray], colour: np.ndarray) -> list[np.ndarray]:
    """R, G and B (uint8, rounded and saturated) of ``colour`` (3 × n float32) applied per texel
    to the first n of the planes (carpet, carpet·flecks, felt, felt·tint).

    The arithmetic is OpenCV's ``cv2.transform`` of the planes merged into one image (how the
    floor's colours were defined): per channel the first product, then each further term added
    with one multiply-add in order, ``cv2.scaleAdd`` (fused where the CPU has FMA, as the
    transform is: both are compiled in OpenCV's same per-CPU unit), on whole planes.
    """
    out = []
    for row in colour:
        acc = planes[0] * row[0]
        for plane, m in zip(planes[1:], row[1:], strict=False):
            cv2.scaleAdd(plane, float(m), acc, dst=acc)
        out.append(cv2.convertScaleAbs(acc))
    return out


def _felt_window(
    mask: np.ndarray,
    fine: np.ndarray,
    flipped: np.ndarray,
    rows: tuple[int, int],
    cols: tuple[int, int],
    fuzz_px: float,
    fuzzy: bool,
    fibre_px: int,
    k_fibre: float,
) -> _FeltWindow:
    """The felt's coverage and unlit shade (fibres and pilling) in rows × cols of the floor."""
    if fuzzy:
        cut, inner = _window(mask, rows, cols, _gauss_reach(fuzz_px))
        coverage: np.ndarray = cut.astype(np.float32)
        coverage *= np.float32(1.0 / 255.0)
        coverage = cv2.GaussianBlur(coverage, (0, 0), sigmaX=fuzz_px)[inner]
        # Stray fibres: noise (std ≈ 0.3) moves the 50 % line in and out by about the fuzz width.
        # It is weighted to vanish away from the edge, or rare peaks would speckle the carpet.
        cut, inner = _window(fine, rows, cols, _gauss_reach(1.0))
        fray = cv2.GaussianBlur(cut, (0, 0), sigmaX=1.0)[inner]
        fray *= 4.0 * coverage * (1.0 - coverage)
        coverage = cv2.addWeighted(coverage, 2.5, fray, 1.1, -0.75)
        np.clip(coverage, 0.0, 1.0, out=coverage)
    else:
        coverage = mask[rows[0] : rows[1], cols[0] : cols[1]].astype(np.float32)
        coverage *= np.float32(1.0 / 255.0)
    # Horizontal streaks along whole rows of the window; vertical ones in the flipped field.
    cut, inner = _window(fine, rows, cols, fibre_px)
    across = cv2.blur(cut[inner[0]], (fibre_px, 1))[:, inner[1]]
    cut, inner = _window(flipped, rows, cols, fibre_px)
    down = cv2.blur(np.ascontiguousarray(cut[:, inner[1]]), (1, fibre_px))[inner[0]]
    streaks = np.maximum(across, down)
    cut, inner = _window(fine, rows, cols, _gauss_reach(0.7))
    shade = cv2.addWeighted(
        streaks,
        0.6 * k_fibre * math.sqrt(fibre_px),
        cv2.GaussianBlur(cut, (0, 0), 0.7)[inner],
        0.5 * k_fibre,
        1.0,
    )
    return _FeltWindow(slice(*rows), slice(*cols), coverage, shade)
