"""The paper's imitation fitness (Algorithm 3), evaluated for a whole population at once."""

from __future__ import annotations

import numpy as np

from ..control.mlp import N_INPUTS, N_OUTPUTS, mlp_forward

# For expected action e, the two other outputs in index order ("first/second position other
# than the winner").
_OTHERS = np.array([[1, 2], [0, 2], [0, 1]], dtype=np.intp)


def category_weights(actions: np.ndarray) -> np.ndarray:
    """1 / (number of cases with the same expected action) for each case, (N,) float64."""
    actions = _check_actions(actions)
    counts = np.bincount(actions, minlength=N_OUTPUTS)
    return 1.0 / counts[actions]


def imitation_fitness(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    threshold: float = 0.4,
    *,
    bias: bool | None = None,
) -> np.ndarray:
    """Algorithm 3 for every network: lower is better, 0 is perfect.

    ``weights``: (P, 215) (or (P, 223) with biases). ``inputs``: (N, 40) road values.
    ``actions``: (N,) expected commands 0/1/2. For each case, d = output at the expected action
    minus each other output; each d adds 0.5 / n_e if d >= threshold, else 0.5 * (d / threshold) /
    n_e (negative d lowers the total), n_e = number of cases of that action. Fitness is
    1 - total / 3; when a category has no cases it contributes nothing (so 0 is then out of reach),
    exactly as the algorithm reads. Returns (P,) float64.
    """
    if not threshold > 0:
        raise ValueError(f"threshold must be positive, got {threshold}")
    w = np.asarray(weights, dtype=np.float64)
    if w.ndim != 2:
        raise ValueError(f"weights must be (P, W), got shape {w.shape}")
    x = np.asarray(inputs, dtype=np.float64)
    if x.ndim != 2 or x.shape[1] != N_INPUTS:
        raise ValueError(f"inputs must have shape (N, {N_INPUTS}), got {x.shape}")
    actions = _check_actions(actions)
    if actions.shape[0] != x.shape[0]:
        raise ValueError(f"{x.shape[0]} input rows but {actions.shape[0]} actions")
    if actions.size == 0:
        return np.ones(w.shape[0], dtype=np.float64)
    outputs = mlp_forward(w, x, bias=bias)  # (P, N, 3)
    winning = np.take_along_axis(outputs, actions[None, :, None], axis=2)  # (P, N, 1)
    others = np.take_along_axis(outputs, _OTHERS[actions][None], axis=2)  # (P, N, 2)
    diff = winning - others
    score = np.where(diff >= threshold, 0.5, 0.5 * (diff / threshold))
    total = score.sum(axis=2) @ category_weights(actions)  # (P,)
    return 1.0 - total / 3.0


def training_accuracy(weights: np.ndarray, inputs: np.ndarray, actions: np.ndarray) -> float:
    """Share of cases where the network's largest output is the demonstrated command.

    ``weights`` (W,), ``inputs`` (N, 40) road values, ``actions`` (N,) commands 0/1/2.
    """
    predicted = mlp_forward(weights, np.asarray(inputs, dtype=np.float64)).argmax(axis=1)
    return float((predicted == np.asarray(actions)).mean())


def _check_actions(actions: np.ndarray) -> np.ndarray:
    a = np.asarray(actions)
    if a.ndim != 1:
        raise ValueError(f"actions must be 1-D, got shape {a.shape}")
    if a.size and (not np.issubdtype(a.dtype, np.integer) or a.min() < 0 or a.max() >= N_OUTPUTS):
        raise ValueError(f"actions must be integers in 0..{N_OUTPUTS - 1}")
    return a.astype(np.intp)
