"""Success rates with Wilson score intervals."""

from __future__ import annotations

import math
from typing import Any

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
