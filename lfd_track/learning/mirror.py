"""Mirrored teaching cases: what a case would have been with the world flipped left to right.

A road value is the best match of one image region's colour histograms, and a histogram does not
depend on where in the region a pixel lies, so flipping a frame left to right only moves each
region's value to the mirrored column of the 8 x 5 grid (the grid and the safe box are symmetric
about the image's centre line): the mirrored frame's road values are the original's with each
row reversed, exactly. The command swaps left and right, and a memory input swaps its sides
(:meth:`lfd_track.policy.memory.MemoryConfig.mirror`).

Learning from the cases plus their mirror images makes the network treat left and right alike.
The paper's demonstration is not symmetric: it starts at the training track's right end, so the
first bend of every demonstration turns right, and with a last-bend memory the "no bend yet"
state is only ever taught with a right bend ahead.
"""

from __future__ import annotations

import numpy as np

from ..core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from ..policy.memory import MemoryConfig

#: Command each command becomes in a mirror: forward stays, left and right swap.
MIRRORED_COMMAND = np.array([0, 2, 1], dtype=np.intp)


def mirror_cases(
    inputs: np.ndarray, actions: np.ndarray, memory: MemoryConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The mirror images of cases: ``inputs`` (N, 40 + m) float, ``actions`` (N,) 0/1/2.

    ``memory`` says what the m inputs after the road values are (None: no memory inputs).
    """
    x = np.asarray(inputs, dtype=np.float64)
    a = np.asarray(actions, dtype=np.intp)
    memory = memory or MemoryConfig()
    if x.ndim != 2 or x.shape[1] != memory.policy_inputs:
        raise ValueError(
            f"inputs must have shape (N, {memory.policy_inputs}) for memory"
            f" {memory.kind!r}, got {x.shape}"
        )
    road = x[:, :N_REGIONS].reshape(-1, GRID_ROWS, GRID_COLUMNS)[:, :, ::-1]
    mirrored = np.hstack([road.reshape(-1, N_REGIONS), memory.mirror(x[:, N_REGIONS:])])
    return mirrored, MIRRORED_COMMAND[a]


def with_mirrored(
    inputs: np.ndarray, actions: np.ndarray, memory: MemoryConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """The cases followed by their mirror images (2N rows)."""
    x, a = mirror_cases(inputs, actions, memory)
    return (
        np.concatenate([np.asarray(inputs, dtype=np.float64), x]),
        np.concatenate([np.asarray(actions, dtype=np.intp), a]),
    )
