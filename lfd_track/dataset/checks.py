"""Value checks of a case, shared by the writer (before a record is written) and the reader.

Physically possible values only: road values in [-1, 1], histogram values in [0, 1], steps >= 0,
poses and progress finite (or all NaN when unknown) and within ``MAX_POSITION_M``.
Each ``*_problem`` function returns the problem in words, or "" when there is none.
"""

from __future__ import annotations

import math

import numpy as np

MAX_POSITION_M = 1e4
"""Largest |x|, |y| [m] and |progress| [m] a case may hold (tracks are far smaller)."""
MAX_MEMORY_INPUTS = 16
"""Most memory inputs a case may carry."""
_VALUE_TOLERANCE = 1e-6  # road values are correlations; allow float rounding past +-1


def _road_value_problem(values: np.ndarray) -> str:
    if not np.isfinite(values).all():
        return "road values contain NaN or infinity"
    worst = float(np.max(np.abs(values))) if values.size else 0.0
    if worst > 1.0 + _VALUE_TOLERANCE:
        return f"road value {worst:.6g} outside [-1, 1]"
    return ""


def _unit_interval_problem(a: np.ndarray, not_finite: str, outside: str) -> str:
    """``not_finite`` or ``outside`` when ``a`` has non-finite values or values outside [0, 1]."""
    if not np.isfinite(a).all():
        return not_finite
    if a.size and (a.min() < 0.0 or a.max() > 1.0):
        return outside
    return ""


def _memory_problem(memory: np.ndarray) -> str:
    return _unit_interval_problem(
        memory, "memory inputs contain NaN or infinity", "memory inputs must lie in [0, 1]"
    )


def _histogram_problem(hists: np.ndarray) -> str:
    return _unit_interval_problem(
        hists, "contain NaN or infinity", "values must lie in [0, 1] (normalised histograms)"
    )


def _pose_problem(xyt: tuple[float, ...], progress_m: float) -> str:
    unknown = [math.isnan(v) for v in xyt]
    if any(unknown) and not all(unknown):
        return f"pose must be three finite numbers or unknown (all NaN), got {xyt}"
    if not all(unknown):
        if not all(math.isfinite(v) for v in xyt):
            return f"pose must be three finite numbers or unknown (all NaN), got {xyt}"
        if max(abs(xyt[0]), abs(xyt[1])) > MAX_POSITION_M:
            return f"pose {xyt[:2]} is more than {MAX_POSITION_M:g} m from the origin"
        if abs(xyt[2]) > 1e6:
            return f"pose heading {xyt[2]} rad is not plausible"
    if not math.isnan(progress_m) and not abs(progress_m) <= MAX_POSITION_M:
        return f"progress {progress_m} m must be finite and within {MAX_POSITION_M:g} m"
    return ""


def _check_n_memory(n_memory: int) -> int:
    if isinstance(n_memory, bool) or int(n_memory) != n_memory:
        raise ValueError(f"n_memory must be an integer, got {n_memory!r}")
    if not 0 <= int(n_memory) <= MAX_MEMORY_INPUTS:
        raise ValueError(f"n_memory must be in 0..{MAX_MEMORY_INPUTS}, got {n_memory}")
    return int(n_memory)


def _check_bins(bins: int) -> int:
    if isinstance(bins, bool) or int(bins) != bins or not 1 <= int(bins) <= 256:
        raise ValueError(f"bins must be an integer in 1..256, got {bins!r}")
    return int(bins)
