"""Mirrored teaching cases: what a case would have been with the world flipped left to right.

A road value is the best match of one image region's colour histograms, and a histogram does not
depend on where in the region a pixel lies, so flipping a frame left to right only moves each
region's value to the mirrored column of the 8 x 5 grid (the grid and the safe box are symmetric
about the image's centre line): the mirrored frame's road values are the original's with each
row reversed, exactly. The same holds for the regions' colour features
(:mod:`lfd_track.policy.features`, also from the region histograms): each block of 40 has its
rows reversed. The command swaps left and right, and a memory input swaps its sides
(:meth:`lfd_track.policy.memory.MemoryConfig.mirror`).

Learning from the cases plus their mirror images makes the network treat left and right alike.
The paper's demonstration is not symmetric: it starts at the training track's right end, so the
first bend of every demonstration turns right, and with a last-bend memory the "no bend yet"
state is only ever taught with a right bend ahead.
"""

from __future__ import annotations

import numpy as np

from ..policy.features import DEFAULT_FEATURES, frame_inputs, mirror_frame_inputs
from ..policy.memory import MemoryConfig, NoMemory, policy_inputs

#: Command each command becomes in a mirror: forward stays, left and right swap.
MIRRORED_COMMAND = np.array([0, 2, 1], dtype=np.intp)


def mirror_cases(
    inputs: np.ndarray,
    actions: np.ndarray,
    memory: MemoryConfig | None = None,
    features: str = DEFAULT_FEATURES,
) -> tuple[np.ndarray, np.ndarray]:
    """The mirror images of cases: ``inputs`` (N, f + m) float, ``actions`` (N,) 0/1/2.

    ``features`` says what the f per-region inputs are (the 40 road values by default, or 160
    with the colour features), ``memory`` what the m inputs after them are (None: none).
    """
    x = np.asarray(inputs, dtype=np.float64)
    a = np.asarray(actions, dtype=np.intp)
    memory = memory or NoMemory()
    n_inputs = policy_inputs(memory, features)
    if x.ndim != 2 or x.shape[1] != n_inputs:
        extra = "" if features == DEFAULT_FEATURES else f" and features {features!r}"
        raise ValueError(
            f"inputs must have shape (N, {n_inputs}) for memory {memory.kind!r}{extra},"
            f" got {x.shape}"
        )
    f = frame_inputs(features)
    mirrored = np.hstack([mirror_frame_inputs(x[:, :f], features), memory.mirror(x[:, f:])])
    return mirrored, MIRRORED_COMMAND[a]


def with_mirrored(
    inputs: np.ndarray,
    actions: np.ndarray,
    memory: MemoryConfig | None = None,
    features: str = DEFAULT_FEATURES,
) -> tuple[np.ndarray, np.ndarray]:
    """The cases followed by their mirror images (2N rows)."""
    x, a = mirror_cases(inputs, actions, memory, features)
    return (
        np.concatenate([np.asarray(inputs, dtype=np.float64), x]),
        np.concatenate([np.asarray(actions, dtype=np.intp), a]),
    )
