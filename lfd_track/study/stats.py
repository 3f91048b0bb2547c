"""Success rates with Wilson score intervals, and an interval that resamples controllers."""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

Z95 = 1.959963984540054
"""Two-sided 95 % quantile of the standard normal distribution."""


def wilson_interval(successes: int, trials: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion, ``(low, high)`` within [0, 1].

    With no trials nothing is known: ``(0.0, 1.0)``. Raises ``ValueError`` unless
    ``0 <= successes <= trials``.
    """
    if not 0 <= successes <= trials:
        raise ValueError(f"need 0 <= successes <= trials, got {successes} of {trials}")
    if trials == 0:
        return 0.0, 1.0
    p = successes / trials
    z2 = z * z
    centre = (p + z2 / (2 * trials)) / (1 + z2 / trials)
    half = z / (1 + z2 / trials) * math.sqrt(p * (1 - p) / trials + z2 / (4 * trials * trials))
    low = 0.0 if successes == 0 else max(0.0, centre - half)
    high = 1.0 if successes == trials else min(1.0, centre + half)
    return low, high


def rate_summary(successes: int, trials: int) -> dict[str, Any]:
    """``{"successes", "trials", "rate", "ci95": [low, high]}``; ``rate`` is None with no trials."""
    low, high = wilson_interval(successes, trials)
    return {
        "successes": int(successes),
        "trials": int(trials),
        "rate": successes / trials if trials else None,
        "ci95": [low, high],
    }


#: Resamples drawn by ``controller_interval``; with its fixed generator seed the interval is a
#: pure function of the counts (a re-aggregated study writes the same numbers).
BOOTSTRAP_RESAMPLES = 10_000
BOOTSTRAP_SEED = 0


def controller_interval(
    groups: Sequence[tuple[int, int]], *, resamples: int = BOOTSTRAP_RESAMPLES
) -> list[float] | None:
    """Percentile-bootstrap 95 % interval of a pooled rate whose trials come in groups.

    ``groups``: ``(successes, trials)`` per learned controller (one repetition of one seed).
    Trials that share a controller are not independent — a controller that misses a corner
    tends to miss it every lap — so this interval resamples whole controllers with replacement
    and takes the 2.5 and 97.5 percentiles of the pooled rate. It is at least as honest as the
    Wilson interval about how much the result depends on which controllers were learned, and
    usually a little wider. Deterministic (fixed generator seed). ``None`` when there are no
    trials; groups without trials are ignored. Raises ``ValueError`` on impossible counts.
    """
    counts = [(int(k), int(n)) for k, n in groups]
    for k, n in counts:
        if not 0 <= k <= n:
            raise ValueError(f"need 0 <= successes <= trials, got {k} of {n}")
    counts = [(k, n) for k, n in counts if n > 0]
    if not counts:
        return None
    successes = np.array([c[0] for c in counts], dtype=np.float64)
    trials = np.array([c[1] for c in counts], dtype=np.float64)
    rng = np.random.default_rng(BOOTSTRAP_SEED)
    pick = rng.integers(len(counts), size=(resamples, len(counts)))
    rates = successes[pick].sum(axis=1) / trials[pick].sum(axis=1)
    low, high = np.percentile(rates, [2.5, 97.5])
    return [float(low), float(high)]
