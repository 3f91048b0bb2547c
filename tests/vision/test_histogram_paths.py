"""The histogram arithmetic against the plain numpy formulas it was written from.

``normalize_minmax`` and ``centred_unit`` take no BLAS, so they must give the very same bits;
``similarity_matrix`` multiplies through the BLAS, so its values are compared within 1e-12 and
the choices made from them (the best model of each region) exactly.
"""

from __future__ import annotations

import numpy as np

from lfd_track.vision.histograms import (
    DBL_EPSILON,
    centred_unit,
    normalize_minmax,
    similarity_matrix,
)


def _normalize_reference(counts: np.ndarray) -> np.ndarray:
    counts = np.asarray(counts, dtype=np.float64)
    lo = counts.min(axis=-1, keepdims=True)
    hi = counts.max(axis=-1, keepdims=True)
    span = hi - lo
    scale = np.where(span > DBL_EPSILON, 1.0 / np.where(span > 0, span, 1.0), 0.0)
    return (counts * scale - lo * scale).astype(np.float32)


def _centred_reference(hists: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    h = np.asarray(hists, dtype=np.float64)
    centred = h - h.mean(axis=2, keepdims=True)
    sumsq = np.einsum("mcb,mcb->cm", centred, centred)
    norm = np.sqrt(sumsq)
    unit = centred.transpose(1, 0, 2) / np.where(norm > 0, norm, 1.0)[:, :, None]
    return unit, sumsq


def _similarity_reference(a: tuple, b: tuple) -> np.ndarray:
    (unit_a, ss_a), (unit_b, ss_b) = a, b
    corr = np.matmul(unit_a, unit_b.transpose(0, 2, 1))
    corr[ss_a[:, :, None] * ss_b[:, None, :] <= DBL_EPSILON] = 1.0
    return corr.mean(axis=0)


def _counts(rng: np.random.Generator, n: int, bins: int) -> np.ndarray:
    counts = rng.poisson(rng.uniform(0.0, 60.0, (n, 5, 1)), (n, 5, bins)).astype(np.float32)
    counts[rng.random(n) < 0.1, 2] = 7.0  # flat histograms (OpenCV's rule: correlation 1)
    counts[rng.random(n) < 0.05, 4] = 0.0
    return counts


def test_normalize_and_centre_give_the_same_bits() -> None:
    rng = np.random.default_rng(0)
    for bins in (1, 8, 32, 33):
        counts = _counts(rng, 40, bins)
        normalized = normalize_minmax(counts)
        assert normalized.dtype == np.float32
        np.testing.assert_array_equal(normalized, _normalize_reference(counts))
        unit, sumsq = centred_unit(normalized)
        unit_ref, sumsq_ref = _centred_reference(normalized)
        np.testing.assert_array_equal(unit, unit_ref)
        np.testing.assert_array_equal(sumsq, sumsq_ref)


def test_normalize_leaves_float64_input_alone() -> None:
    counts = _counts(np.random.default_rng(1), 10, 32).astype(np.float64)
    before = counts.copy()
    normalize_minmax(counts)
    np.testing.assert_array_equal(counts, before)


def test_similarity_agrees_and_picks_the_same_models() -> None:
    rng = np.random.default_rng(2)
    for n_models in (1, 7, 100):
        regions = centred_unit(normalize_minmax(_counts(rng, 40, 32)))
        models = centred_unit(normalize_minmax(_counts(rng, n_models, 32)))
        sims = similarity_matrix(regions, models)
        reference = _similarity_reference(regions, models)
        np.testing.assert_allclose(sims, reference, rtol=0.0, atol=1e-12)
        np.testing.assert_array_equal(np.argmax(sims, axis=1), np.argmax(reference, axis=1))
