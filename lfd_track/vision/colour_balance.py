"""A camera session's colour balance, matched to the road library's felt.

A phone sets its white balance anew in every camera session: the same felt comes out a few per
cent redder in one session and bluer in the next (the simulated camera's ``white_balance_cast``,
:mod:`lfd_track.render.camera`). A road library taught in one session reads the felt of another
session with a shifted colour, and its road values drop or, on a carpet of a near colour, rise.

:class:`SafeBoxBalance` estimates the session's channel gains from the picture alone, anchored on
what the library already knows: the library's models are histograms of the safe box on the felt
(Algorithm 1), so the safe box of a frame that shows felt should have the colour of the model it
matches best. Each frame:

1. the safe box of the frame as the camera gave it is compared with the model nearest it in
   brightness (the felt in a light pool or in a shadow): the mean R, G and B of the two
   histograms (normalised the same way, so their binning and scaling cancel), as log ratios with
   the brightness removed (their mean over the channels). The model is not picked by its
   histogram's similarity: that favours models whose colour happens to be shifted as this
   session's is, and would leave part of the cast in place;
2. the frame is a sample of the felt if no channel differs by more than :data:`MAX_LOG_GAIN`
   and, once :data:`SETTLE_SAMPLES` samples are in, none lies further than
   :data:`MAX_LOG_SPREAD` from their median (a safe box on the carpet differs by more, and
   differently from frame to frame; a run starts with its safe box on the felt);
3. the gains are the inverse of the samples' median ratio: they bring the session's felt to the
   library's colour. Only the colour is corrected, not the brightness (the camera's exposure
   already follows the scene, and a darker model may be felt in a shadow).

Frames are then scaled per channel by the gains (a lookup table) before the library reads them.
The balance works for a finished library only (a perception whose rule is ``frozen``): while a
library learns, the session it learns in is its reference. Nothing is stored, the reference is
the library itself, so a controller file needs no new data, and each driving session (a new
:class:`~lfd_track.teaching.perception.Perception`) starts from gains 1.

Measured across camera sessions of the paper world and ten rooms drawn from the ``randomized``
ranges: ``benchmarks/experiments/human_goal/round26/cross_session.py``.
"""

from __future__ import annotations

import cv2
import numpy as np

from .histograms import histogram_means
from .road_library import RoadLibrary

__all__ = ["SafeBoxBalance", "histogram_means"]

#: Largest colour difference [natural log of a channel's ratio, brightness removed] a sample may
#: show from its model: about 35 % in one channel, beyond any camera session's cast (a safe box
#: on the carpet usually differs more).
MAX_LOG_GAIN = 0.3
#: Once :data:`SETTLE_SAMPLES` samples are in, a sample must also lie this close [log ratio, each
#: channel] to their median: felt samples of one session agree within a few hundredths, a safe
#: box on the carpet or half on it does not.
MAX_LOG_SPREAD = 0.08
#: Samples after which :data:`MAX_LOG_SPREAD` applies (a run starts with its safe box on the felt).
SETTLE_SAMPLES = 5
#: Samples kept for the median (the most recent; a session's cast does not change).
MAX_SAMPLES = 2000
#: Every level in every channel at several places along rows of a frame's width, and along an
#: odd width (a vectorised kernel treats a row's pixels in blocks and its tail on its own).
_LEVELS = [
    np.repeat(
        ((np.arange(width) + 37 * np.arange(rows)[:, None]) % 256).astype(np.uint8), 3
    ).reshape(rows, width, 3)
    for rows, width in ((8, 640), (1, 263))
]


class SafeBoxBalance:
    """The colour gains of one camera session (see the module docstring)."""

    def __init__(self) -> None:
        self._samples: list[np.ndarray] = []
        self._log_gains = np.zeros(3)
        # The library's model colours and their logs (recomputed only when the library changes).
        self._models: tuple[np.ndarray, np.ndarray] | None = None
        self._table: np.ndarray | None = None  # (1, 256, 3) uint8 levels; None: identity
        self._scale: np.ndarray | None = None  # (3, 3) diagonal: the table as a scale, if exact

    @property
    def gains(self) -> np.ndarray:
        """The channel gains applied to frames, (3,) float64 (ones until a sample is in)."""
        return np.exp(self._log_gains)

    @property
    def samples(self) -> int:
        """Frames counted as felt samples so far."""
        return len(self._samples)

    def update(self, frame: np.ndarray, library: RoadLibrary) -> None:
        """Count ``frame`` (RGB uint8, as the camera gave it) as a sample if its safe box shows
        felt the library knows; the gains follow the samples' median."""
        if not library.n_models:
            return
        box = library.safe_box_model(frame)
        box_log = np.log(np.maximum(histogram_means(box), 1.0))
        models_log = self._models_log(library)
        best = int(np.argmin(np.abs(models_log.mean(axis=1) - box_log.mean())))
        ratio = box_log - models_log[best]
        ratio -= ratio.mean()
        if np.max(np.abs(ratio)) > MAX_LOG_GAIN:
            return
        if (
            len(self._samples) >= SETTLE_SAMPLES
            and np.max(np.abs(ratio + self._log_gains)) > MAX_LOG_SPREAD
        ):
            return
        self._samples.append(ratio)
        if len(self._samples) > MAX_SAMPLES:
            del self._samples[0]
        log_gains = -np.median(np.asarray(self._samples), axis=0)
        self._use(log_gains - log_gains.mean())

    def _use(self, log_gains: np.ndarray) -> None:
        """Scale frames by ``exp(log_gains)`` from now on."""
        self._log_gains = np.asarray(log_gains, dtype=np.float64)
        levels = np.arange(256, dtype=np.float64)[:, None] * np.exp(self._log_gains)[None, :]
        table = np.clip(np.rint(levels), 0, 255).astype(np.uint8).reshape(1, 256, 3)
        if self._table is not None and np.array_equal(table, self._table):
            return  # the same levels: the same table and scale
        self._table = table
        # The same table as a per-channel scale, which OpenCV applies several times faster than a
        # three-channel lookup; used only where it gives every level exactly as the table does.
        scale = np.diag(np.exp(self._log_gains))
        exact = all(
            np.array_equal(cv2.transform(probe, scale), self._table[0, probe[..., 0]])
            for probe in _LEVELS
        )
        self._scale = scale if exact else None

    def _models_log(self, library: RoadLibrary) -> np.ndarray:
        """Log mean R, G, B of the library's models, (n_models, 3)."""
        means = library.model_means()  # the same array while the models are the same
        if self._models is None or self._models[0] is not means:
            self._models = (means, np.log(np.maximum(means, 1.0)))
        return self._models[1]

    def apply(self, frame: np.ndarray) -> np.ndarray:
        """``frame`` (RGB uint8, (H, W, 3)) scaled per channel by :attr:`gains` (the frame
        itself while the gains are all 1)."""
        if self._table is None:
            return frame
        if self._scale is not None:
            return np.asarray(cv2.transform(frame, self._scale))
        return np.asarray(cv2.LUT(frame, self._table))
