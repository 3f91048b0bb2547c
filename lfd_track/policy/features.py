"""Per-region input features: what the policy reads of the current frame (beyond the paper, §6).

The paper's network reads one number per region of the 8 x 5 grid, the region's road value (its
best histogram correlation with the road library). A road value says how much a region looks
like road, not what it looks like, so two frames whose regions match the library equally well
are the same to the network however different their colours. The feature sets:

* ``"road_values"`` — the paper's 40 road values (the default; every controller file written
  before feature sets existed);
* ``"road_values+colour"`` — the 40 road values, then three colour features per region (120):
  the region's mean hue as a vector, ``(1 + mean cos h) / 2`` and ``(1 + mean sin h) / 2``, and
  its mean saturation, each in [0, 1]. Hue is an angle (OpenCV's 8-bit H in [0, 180) is the
  hue circle at 2° a step), so its mean is the mean of unit vectors: red at H = 2 and H = 178
  average to red, not to cyan, and a region of many hues gets a short vector (both features
  near 0.5). The inputs are ordered feature by feature, each a row-major block of 40 regions:
  ``road values | hue cos | hue sin | saturation``;
* ``"near_felt"`` — two inputs of the frame instead of its 40 road values: where the felt lies
  across the picture's :data:`NEAR_ROWS` nearest rows of regions, ``(1 + p) / 2`` with ``p`` the
  felt-weighted mean of the columns' centres from -7/8 (the picture's right edge column) to 7/8
  (its left), so above 0.5 the felt lies left of the rover's axis; and how much felt those rows
  hold (the mean of their regions' felt levels). A region's felt level rises from 0 at road
  value 0.3 to 1 at 0.5 (the paper world's carpet and felt levels, as the ``fresh_felt`` map's
  fixed levels); with no felt in those rows the position is 0.5. A person steering by where the
  strip lies just ahead of the rover steers by about these two numbers (a pinhole camera's
  column is a bearing, whatever the row); with a memory kind they come before its inputs;
  mirrored, the position becomes ``1 - p`` (round 1 of
  ``benchmarks/experiments/human_goal/`` tried them beside the ``fresh_felt`` map: they fit the
  centreline human better and lapped less);
* ``"none"`` — no per-region inputs: the network reads its memory inputs alone (a memory kind
  with inputs is required). With the ``fresh_felt`` map (:mod:`lfd_track.policy.memory`) the
  road values still reach the network, through the map they feed (bearing, amount and distance
  of the felt not driven along yet), but not one by one: a 3-5-3 network on what a camera and
  the commands told the map. The picture-steering human steers by exactly those three inputs, so
  the 40 road values can only add ways to fit that teacher's labels by what the training track
  looks like rather than by where its felt lies (round 46 of ``benchmarks/experiments/human_goal/``
  measured it with the centreline human and ten other rooms' demonstrations: with the road values
  before the map's inputs the networks fit the human's commands more closely and lap fewer of
  the validation rooms' loops).

The colour features are computed from the region histograms the road values are computed from
(the H and S histograms of each region, :mod:`lfd_track.vision.histograms`), as the means of
the histograms over their bin centres. Those histograms are what a demonstration stores with
every case (:mod:`lfd_track.dataset.records`), so the features of a recorded case and of a
driving frame come from the same numbers by the same arithmetic, and every demonstration ever
recorded yields them without recording again. Two consequences of taking them from the stored
histograms:

* the histograms are min-max normalised (smallest bin 0, largest 1), so the mean is that of
  the distribution above its emptiest bin: exact for a region with an empty bin (a region of
  felt or carpet at the default 32 bins), pulled toward the middle of the range for a region
  whose pixels fill every bin, and 0.5 for a flat histogram (every bin alike, so uniform);
* the means are quantised to the bin width (32 bins: 11.25° of hue, 1/32 of saturation).

The value (V) of HSV is not among the stored histograms, so it is not a feature; brightness
already enters the road values through the R, G and B histograms.

Left-right mirroring (:mod:`lfd_track.learning.mirror`) moves each block's values to the
mirrored column, as for the road values; colours do not change in a mirror.
"""

from __future__ import annotations

import functools

import numpy as np

from ..core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS

FEATURE_SETS = ("road_values", "road_values+colour", "near_felt", "none")
"""Per-region input feature sets a policy may read (see the module docstring)."""
DEFAULT_FEATURES = "road_values"
COLOUR_PER_REGION = 3
"""Colour features per region: hue cos, hue sin, saturation."""
_HUE, _SATURATION = 3, 4  # channel indexes of the R, G, B, H, S histograms
NEAR_ROWS = 2
"""Rows of regions, nearest the rover, the ``near_felt`` features read."""
NEAR_FELT_INPUTS = 2
"""``near_felt`` inputs: the felt's position across the near rows, and its amount."""
_NEAR_CARPET, _NEAR_FELT = 0.3, 0.5  # road values of felt level 0 and 1 (the paper world's)


def check_features(features: str) -> str:
    """Return ``features`` if it names one of :data:`FEATURE_SETS`, else raise ``ValueError``."""
    if not isinstance(features, str) or features not in FEATURE_SETS:
        raise ValueError(f"features must be one of {', '.join(FEATURE_SETS)}, got {features!r}")
    return features


def reads_road_values(features: str) -> bool:
    """Whether a policy with ``features`` reads the 40 road values one by one."""
    return check_features(features) in (DEFAULT_FEATURES, "road_values+colour")


def frame_inputs(features: str = DEFAULT_FEATURES) -> int:
    """Inputs a network reads of one frame: 40, 160 with the colour features, 2 with
    ``near_felt``, 0 with none."""
    check_features(features)
    if features == "none":
        return 0
    if features == "near_felt":
        return NEAR_FELT_INPUTS
    return N_REGIONS if features == DEFAULT_FEATURES else N_REGIONS * (1 + COLOUR_PER_REGION)


def colour_features(histograms: np.ndarray) -> np.ndarray:
    """The colour features of region histograms (see the module docstring).

    ``histograms``: (..., 40, 5, bins) float, the normalised R, G, B, H, S histograms of the 40
    regions (one frame, or N cases). Returns (..., 120) float64 in [0, 1]: hue cos of the 40
    regions, then hue sin, then saturation.
    """
    h = np.asarray(histograms)
    if h.ndim < 3 or h.shape[-3:-1] != (N_REGIONS, 5):
        raise ValueError(f"histograms must have shape (..., {N_REGIONS}, 5, bins), got {h.shape}")
    hue_moments, sat_moments = _bin_moments(h.shape[-1])
    # Weighted sums over the bins: (..., 40, 3) = (total, sum cos, sum sin) of the hue, and
    # (..., 40, 2) = (total, sum of centres) of the saturation.
    hue = np.matmul(h[..., _HUE, :], hue_moments)
    sat = np.matmul(h[..., _SATURATION, :], sat_moments)
    out = np.empty((*h.shape[:-3], COLOUR_PER_REGION, N_REGIONS))
    hue_total, sat_total = hue[..., 0], sat[..., 0]
    empty_hue, empty_sat = hue_total <= 0, sat_total <= 0
    np.divide(hue[..., 1], np.where(empty_hue, 1.0, hue_total), out=out[..., 0, :])
    np.divide(hue[..., 2], np.where(empty_hue, 1.0, hue_total), out=out[..., 1, :])
    np.divide(sat[..., 1], np.where(empty_sat, 1.0, sat_total), out=out[..., 2, :])
    out[..., :2, :] += 1.0
    out[..., :2, :] *= 0.5
    out[..., 0, :][empty_hue] = 0.5
    out[..., 1, :][empty_hue] = 0.5
    out[..., 2, :][empty_sat] = 0.5
    np.clip(out, 0.0, 1.0, out=out)
    return out.reshape(*h.shape[:-3], COLOUR_PER_REGION * N_REGIONS)


@functools.lru_cache(maxsize=16)
def _bin_moments(bins: int) -> tuple[np.ndarray, np.ndarray]:
    """Per bin: (1, cos, sin) of the hue bin's centre angle, (bins, 3), and (1, centre as a
    fraction of the range) of a saturation bin, (bins, 2); float64, read-only."""
    centres = (np.arange(bins, dtype=np.float64) + 0.5) / bins
    angle = 2.0 * np.pi * centres
    hue = np.stack([np.ones(bins), np.cos(angle), np.sin(angle)], axis=1)
    sat = np.stack([np.ones(bins), centres], axis=1)
    hue.flags.writeable = sat.flags.writeable = False
    return hue, sat


def near_felt_features(road_values: np.ndarray) -> np.ndarray:
    """The ``near_felt`` inputs (..., 2) of road values (..., 40): the felt's position across
    the :data:`NEAR_ROWS` nearest rows and its amount (see the module docstring); float64."""
    values = np.asarray(road_values, dtype=np.float64)
    grid = values.reshape(*values.shape[:-1], GRID_ROWS, GRID_COLUMNS)[..., -NEAR_ROWS:, :]
    felt = np.clip((grid - _NEAR_CARPET) / (_NEAR_FELT - _NEAR_CARPET), 0.0, 1.0)
    columns = (GRID_COLUMNS - 1 - 2 * np.arange(GRID_COLUMNS)) / GRID_COLUMNS  # left positive
    total = felt.sum(axis=(-2, -1))
    moment = (felt * columns).sum(axis=(-2, -1))
    position = np.where(total > 0.0, moment / np.where(total > 0.0, total, 1.0), 0.0)
    amount = total / (NEAR_ROWS * GRID_COLUMNS)
    return np.stack([0.5 * (1.0 + position), amount], axis=-1)


def frame_features(
    road_values: np.ndarray, histograms: np.ndarray, features: str = DEFAULT_FEATURES
) -> np.ndarray:
    """The per-region inputs of ``features``: ``road_values`` (..., 40) alone, or followed by
    the :func:`colour_features` of ``histograms`` (..., 40, 5, bins), or the two
    :func:`near_felt_features` (..., 2), or nothing (..., 0) with ``"none"``; float64."""
    values = np.asarray(road_values, dtype=np.float64)
    if check_features(features) == DEFAULT_FEATURES:
        return values
    if features == "none":
        return values[..., :0]
    if features == "near_felt":
        return near_felt_features(values)
    return np.concatenate([values, colour_features(histograms)], axis=-1)


def mirror_frame_inputs(inputs: np.ndarray, features: str = DEFAULT_FEATURES) -> np.ndarray:
    """Per-region inputs (N, 40), (N, 160), (N, 2) or (N, 0) as they would be in a world flipped
    left to right: every block of 40 has each grid row reversed; the ``near_felt`` position
    becomes ``1 - p`` (its amount stays)."""
    x = np.asarray(inputs, dtype=np.float64)
    n = frame_inputs(features)
    if x.ndim != 2 or x.shape[1] != n:
        raise ValueError(f"inputs must have shape (N, {n}) for features {features!r}")
    if features == "near_felt":
        out = x.copy()
        out[:, 0] = 1.0 - out[:, 0]
        return out
    blocks = x.reshape(len(x), n // N_REGIONS, GRID_ROWS, GRID_COLUMNS)[..., ::-1]
    return blocks.reshape(len(x), n)
