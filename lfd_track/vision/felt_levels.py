"""Felt and carpet levels of road values, read from the road values a library gave in its world.

A road value is a region's best similarity to the library's models (Algorithm 2). Taught on the
felt, a library gives the felt values near 1 in any room; what the carpet gets depends on the
room's colours and light: in the paper world the carpet's values end near 0.3, in a room whose
carpet is greener or lit otherwise they reach 0.45. A fixed level that says "carpet below 0.3"
reads such a carpet as felt.

:class:`RoadValueLevels` keeps a fading histogram of the road values of the frames seen (each
frame's weight falls by :data:`FRAME_DECAY` per newer frame, so the histogram follows a library
that is still learning), splits it in two by Otsu's rule (the threshold that maximises the
variance between the two parts) and reads from the split:

* the *carpet level*: the :data:`CARPET_QUANTILE` quantile of the lower part, where this world's
  carpet values end (0.32 in the paper world, whose fixed level is 0.3);
* the *felt level*: the carpet level plus :data:`LEVEL_RAMP_WIDTH`, the fixed levels' own ramp
  (felt values sit near 1 in every world; it is the carpet that moves).

A split is clear when each part holds at least :data:`MIN_PART` of the weight, the parts'
medians lie at least :data:`MIN_MODE_GAP` apart and the upper part looks like felt (its median at
least :data:`MIN_FELT_MEDIAN`). Until :data:`MIN_FRAMES` frames are in and a split has been clear,
:meth:`RoadValueLevels.levels` gives None and the caller keeps its fixed levels. Once levels have
been read, an unclear split keeps the last clear levels: after some fifty frames of carpet alone
(a rover that has lost the strip and turns on the spot) the felt has faded from the histogram,
and the carpet's own spread would otherwise split in two, putting the felt level inside the
carpet's values and the map's felt on the carpet. Every step is element-wise or a running sum over 100 bins, so the same road values
give the same levels on every processor.
"""

from __future__ import annotations

import numpy as np

#: Histogram bins over the road values' range [-1, 1] (0.02 wide).
LEVEL_BINS = 100
#: A frame's weight in the histogram is multiplied by this at every newer frame (about the last
#: 50 frames count).
FRAME_DECAY = 0.98
#: Frames needed before the levels are read from the histogram.
MIN_FRAMES = 5
#: The carpet level is this quantile of the lower part of the split.
CARPET_QUANTILE = 0.9
#: [road value] the felt level lies this far above the carpet level (the fixed levels' ramp).
LEVEL_RAMP_WIDTH = 0.2
#: Each part of the split must hold at least this share of the histogram's weight.
MIN_PART = 0.05
#: [road value] the two parts' medians must lie at least this far apart.
MIN_MODE_GAP = 0.3
#: [road value] the upper part's median must reach this: a library taught on the felt gives the
#: felt values near 1 in every world, so an upper part centred lower is the carpet's own spread.
MIN_FELT_MEDIAN = 0.7

_EDGES = np.linspace(-1.0, 1.0, LEVEL_BINS + 1)
_CENTRES = 0.5 * (_EDGES[1:] + _EDGES[:-1])


class RoadValueLevels:
    """A fading histogram of road values and the felt and carpet levels it implies (see the
    module docstring). Looking (:meth:`levels`) never changes it; :meth:`add` does."""

    def __init__(self) -> None:
        self._weights = np.zeros(LEVEL_BINS)
        self.frames = 0
        """Frames added so far."""
        self._levels: tuple[float, float] | None = None
        self._fresh = True  # _levels is up to date

    def add(self, values: np.ndarray) -> None:
        """Add one frame's road values (40,) float64 (any length; values outside [-1, 1] count
        in the end bins)."""
        v = np.asarray(values, dtype=np.float64).ravel()
        bins = np.clip(np.floor((v + 1.0) * (LEVEL_BINS / 2.0)), 0, LEVEL_BINS - 1).astype(np.intp)
        self._weights = FRAME_DECAY * self._weights + np.bincount(bins, minlength=LEVEL_BINS)
        self.frames += 1
        self._fresh = False

    def levels(self) -> tuple[float, float] | None:
        """``(carpet, felt)`` road-value levels, carpet < felt: the last clear split's, or None
        while no split has been clear (fewer than :data:`MIN_FRAMES` frames, or a view of felt
        or of carpet alone so far)."""
        if not self._fresh:
            clear = self._compute() if self.frames >= MIN_FRAMES else None
            if clear is not None:  # an unclear split keeps the last clear levels
                self._levels = clear
            self._fresh = True
        return self._levels

    def split(self) -> float | None:
        """The Otsu threshold [road value] between the lower and upper parts (None: empty)."""
        k = _otsu(self._weights)
        return None if k is None else float(_EDGES[k])

    def _compute(self) -> tuple[float, float] | None:
        w = self._weights
        total = float(w.sum())
        k = _otsu(w)
        if k is None or total <= 0.0:
            return None
        lower, upper = w.copy(), w.copy()
        lower[k:] = 0.0
        upper[:k] = 0.0
        if min(float(lower.sum()), float(upper.sum())) < MIN_PART * total:
            return None
        felt_median = _quantile(upper, 0.5)
        if felt_median < MIN_FELT_MEDIAN or felt_median - _quantile(lower, 0.5) < MIN_MODE_GAP:
            return None
        carpet = _quantile(lower, CARPET_QUANTILE)
        return carpet, carpet + LEVEL_RAMP_WIDTH


def _otsu(weights: np.ndarray) -> int | None:
    """Index k of the bin edge that splits ``weights`` (bins below k, bins from k) with the
    largest variance between the parts; None when no split leaves weight on both sides."""
    below = np.cumsum(weights)[:-1]
    total = float(weights.sum())
    above = total - below
    moment = np.cumsum(weights * _CENTRES)[:-1]
    both = (below > 0.0) & (above > 0.0)
    if not both.any():
        return None
    between = np.zeros(len(below))
    b, a, m = below[both], above[both], moment[both]
    mean_total = float((weights * _CENTRES).sum())
    between[both] = b * a * (m / b - (mean_total - m) / a) ** 2
    return int(np.argmax(between)) + 1


def _quantile(weights: np.ndarray, q: float) -> float:
    """The ``q`` quantile of a histogram over :data:`_EDGES`, linear within a bin."""
    cumulative = np.cumsum(weights)
    target = q * float(cumulative[-1])
    i = int(np.searchsorted(cumulative, target))
    i = min(i, LEVEL_BINS - 1)
    before = float(cumulative[i - 1]) if i else 0.0
    inside = float(weights[i])
    share = (target - before) / inside if inside > 0.0 else 0.0
    return float(_EDGES[i] + share * (_EDGES[i + 1] - _EDGES[i]))
