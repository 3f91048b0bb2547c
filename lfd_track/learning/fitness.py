"""The paper's imitation fitness (Algorithm 3), evaluated for a whole population at once.

The kernel runs the population's hidden layers as one stacked matrix product and works in place
wherever it can: freshly allocated temporaries of this size (hundreds of kB) are returned to the
operating system on free and cost a page fault per 4 kB on the next allocation, which used to
dominate the run time. Its results equal ``mlp_forward``-based evaluation bit for bit
(``tests/learning/test_fitness.py``).
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass

import numpy as np

from ..policy.mlp import N_HIDDEN, N_INPUTS, N_OUTPUTS, ensemble_forward, mlp_forward, n_weights
from .result import check_actions, check_cases, check_weights

# For expected action e, the two other outputs in index order ("first/second position other
# than the winner").
_OTHERS = np.array([[1, 2], [0, 2], [0, 1]], dtype=np.intp)

_W2 = N_OUTPUTS * N_HIDDEN
# OpenBLAS hands a GEMM of more than 65536 * 4 multiply-adds to several threads; under load those
# threads wait on busy cores. Products are split into row blocks under this size so every call
# stays on the calling thread (the sums per element are the same either way).
_SINGLE_THREAD_MACS = 65536 * 4
# Columns per block of the double-precision micro-kernel (OpenBLAS Haswell: 4 x 8).
_COLUMN_BLOCK = 8


def category_weights(actions: np.ndarray) -> np.ndarray:
    """1 / (number of cases with the same expected action) for each case, (N,) float64."""
    return _category_weights(check_actions(actions))


def _category_weights(actions: np.ndarray) -> np.ndarray:
    counts = np.bincount(actions, minlength=N_OUTPUTS)
    return 1.0 / counts[actions]


@dataclass(frozen=True, eq=False)
class Cases:
    """Training cases checked once (:func:`checked_cases`), ready for :func:`population_fitness`
    in a learner's inner loop without checking them again."""

    inputs: np.ndarray
    """(N, n) float64, finite, N >= 1, n = 40 road values plus any memory inputs."""
    actions: np.ndarray
    """(N,) intp commands 0/1/2."""
    category_weights: np.ndarray
    """(N,) float64, see :func:`category_weights`."""

    @property
    def n_inputs(self) -> int:
        return int(self.inputs.shape[1])


def checked_cases(inputs: np.ndarray, actions: np.ndarray) -> Cases:
    """Validate cases with the learners' shared :func:`~lfd_track.learning.result.check_cases`."""
    x, a = check_cases(inputs, actions)
    return Cases(x, a, _category_weights(a))


def imitation_fitness(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    threshold: float = 0.4,
    *,
    bias: bool | None = None,
) -> np.ndarray:
    """Algorithm 3 for every network: lower is better, 0 is perfect.

    ``weights``: (P, 215) (or (P, 223) with biases). ``inputs``: (N, 40) road values (or
    (N, 40 + m) with m memory inputs, and weights to match).
    ``actions``: (N,) expected commands 0/1/2. For each case, d = output at the expected action
    minus each other output; each d adds 0.5 / n_e if d >= threshold, else 0.5 * (d / threshold) /
    n_e (negative d lowers the total), n_e = number of cases of that action. Fitness is
    1 - total / 3; when a category has no cases it contributes nothing (so 0 is then out of reach),
    exactly as the algorithm reads. Returns (P,) float64.

    Raises ``ValueError`` (one line) on bad arguments: no cases, NaN or infinite road values or
    weights, shapes that do not match, commands outside 0..2, a threshold that is not a finite
    positive number. A learner checks its cases once (:func:`checked_cases`) and then scores each
    generation with the unchecked :func:`population_fitness`.
    """
    _check_threshold(threshold)
    cases = checked_cases(inputs, actions)
    w, bias = check_weights(weights, cases.n_inputs, bias)
    return population_fitness(w, cases, threshold, bias=bias)


def _check_threshold(threshold: float) -> None:
    if isinstance(threshold, bool | np.bool_) or not isinstance(threshold, numbers.Real):
        raise ValueError(f"threshold must be a number, got {threshold!r}")
    try:
        value = float(threshold)
    except OverflowError:  # an integer beyond any float
        value = math.inf
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"threshold must be a finite positive number, got {threshold!r}")


def population_fitness(
    weights: np.ndarray, cases: Cases, threshold: float, *, bias: bool, hidden: int = N_HIDDEN
) -> np.ndarray:
    """:func:`imitation_fitness` without any check: for learners' inner loops, after the cases
    were checked once (:func:`checked_cases`) and with weights they made themselves (finite,
    (P, W) float64 of the width for ``cases.n_inputs`` inputs, ``bias`` and ``hidden`` hidden
    nodes; a network of another width than the paper's 5 is evaluated by ``mlp_forward``)."""
    actions = cases.actions
    if hidden == N_HIDDEN:
        outputs = population_outputs(weights, cases.inputs, bias=bias)  # (P, N, 3)
    else:
        outputs = mlp_forward(weights, cases.inputs, bias=bias, hidden=hidden)
    p, n = outputs.shape[:2]
    flat = outputs.reshape(p, n * N_OUTPUTS)
    row = np.arange(n) * N_OUTPUTS
    winning = np.take(flat, row + actions, axis=1)  # (P, N)
    diff = np.take(flat, row[:, None] + _OTHERS[actions], axis=1)  # (P, N, 2), the others for now
    np.subtract(winning[:, :, None], diff, out=diff)
    saturated = diff >= threshold
    np.divide(diff, threshold, out=diff)
    np.multiply(diff, 0.5, out=diff)
    np.copyto(diff, 0.5, where=saturated)
    # C order matters: the matrix-vector product below sums in a different order for a
    # Fortran-ordered matrix.
    score = np.add(diff[:, :, 0], diff[:, :, 1], out=np.empty((p, n)))
    total = score @ cases.category_weights  # (P,)
    return 1.0 - total / 3.0


def population_outputs(weights: np.ndarray, inputs: np.ndarray, *, bias: bool) -> np.ndarray:
    """Outputs of P networks on N inputs, (P, N, 3) float64, equal bit for bit to
    ``mlp_forward(weights, inputs)``.

    ``weights``: (P, 215) or (P, 223) float64 (validated by the caller); ``inputs``: (N, 40)
    float64. ``mlp_forward`` multiplies (N, 40) @ (40, 5) once per network; here layer 1 is one
    (N, 40) @ (40, 5P) product (in row blocks small enough for one thread) and layer 2 reads its
    result in place; both sigmoids work in place.

    Each product element is a sum over 40 terms whose rounding depends on the BLAS micro-kernel
    that computes it. With OpenBLAS's Haswell kernels both forms agree except in the last row when
    N is odd: there ``mlp_forward``'s fifth column (hidden node 4) comes from a one-by-one edge
    kernel, a single fused multiply-add chain, while the wide product uses a row kernel with four
    partial sums; that row is recomputed from a two-row product, whose kernels are plain fused
    chains. Other BLAS kernels may split sums differently, so the stacked form is checked once
    per process against ``mlp_forward`` on shapes that exercise every case, and ``mlp_forward``
    itself is used if any bit differs.
    """
    if weights.shape[0] == 0 or inputs.shape[0] < 2 or not stacked_form_matches(inputs.shape[1]):
        # One row goes to different kernels (and the per-network form is cheap there).
        return mlp_forward(weights, inputs, bias=bias)
    return _stacked_outputs(weights, inputs, bias=bias)


_STACKED_MATCHES: dict[int, bool] = {}


def stacked_form_matches(n_inputs: int = N_INPUTS) -> bool:
    """Whether the stacked population kernel (``_stacked_outputs``) equals ``mlp_forward`` bit for
    bit with this process's BLAS (the fitness falls back to ``mlp_forward`` where it does not).

    Probes odd and even case counts, one and several row blocks, populations that do and do not
    fill the padding, with and without biases; computed once per input width and cached.
    """
    if n_inputs not in _STACKED_MATCHES:
        matches = True
        for p, n, bias in [(1, 9, False), (3, 13, True), (7, 64, False), (40, 151, False),
                           (40, 150, True), (13, 701, False)]:  # fmt: skip
            # Fixed, irregular values in the ranges the GA sees (no random stream involved).
            w = 3.0 * np.sin(0.7 * np.arange(p * n_weights(bias, n_inputs)) + 1.0).reshape(p, -1)
            x = 0.45 + 0.55 * np.cos(0.37 * np.arange(n * n_inputs)).reshape(n, n_inputs)
            if not np.array_equal(_stacked_outputs(w, x, bias=bias), mlp_forward(w, x)):
                matches = False
                break
        _STACKED_MATCHES[n_inputs] = matches
    return _STACKED_MATCHES[n_inputs]


def _stacked_outputs(weights: np.ndarray, inputs: np.ndarray, *, bias: bool) -> np.ndarray:
    """The stacked form of :func:`population_outputs` (N >= 2)."""
    p, (n, n_in) = weights.shape[0], inputs.shape
    w1 = N_HIDDEN * n_in
    # Column j*5 + h holds network j's weights into hidden node h; padded with zero columns to a
    # multiple of 8 so no column falls to an edge kernel.
    cols = p * N_HIDDEN
    padded = -(-cols // _COLUMN_BLOCK) * _COLUMN_BLOCK
    w_ih = np.zeros((n_in, padded))
    w_ih[:, :cols] = (
        weights[:, :w1].reshape(p, N_HIDDEN, n_in).transpose(2, 0, 1).reshape(n_in, cols)
    )
    hidden = np.empty((n, padded))
    # Even row blocks: an odd block would put an odd row in the one-row kernel.
    rows = max(2, (_SINGLE_THREAD_MACS // (n_in * padded) - 1) // 2 * 2)
    for start in range(0, n, rows):
        stop = n if n - start < rows + 2 else start + rows  # no block of a single row
        np.matmul(inputs[start:stop], w_ih, out=hidden[start:stop])
        if stop == n:
            break
    if n % 2:
        node4 = np.zeros((n_in, max(p, 2)))  # one column would go to a matrix-vector kernel
        node4[:, :p] = w_ih[:, N_HIDDEN - 1 : cols : N_HIDDEN]
        hidden[-1, N_HIDDEN - 1 : cols : N_HIDDEN] = np.matmul(inputs[[-1, -1]], node4)[0, :p]
    if bias:
        hidden[:, :cols] += weights[:, w1 + _W2 : w1 + _W2 + N_HIDDEN].reshape(-1)
    _sigmoid_inplace(hidden)
    w_ho = np.ascontiguousarray(
        weights[:, w1 : w1 + _W2].reshape(p, N_OUTPUTS, N_HIDDEN).transpose(0, 2, 1)
    )
    # (P, N, 5) view of the hidden activations, network-major, without copying.
    item = hidden.itemsize
    per_net = np.lib.stride_tricks.as_strided(
        hidden, shape=(p, n, N_HIDDEN), strides=(N_HIDDEN * item, padded * item, item)
    )
    out = np.matmul(per_net, w_ho)  # (P, N, 3)
    if bias:
        out += weights[:, None, w1 + _W2 + N_HIDDEN :]
    return _sigmoid_inplace(out)


def _sigmoid_inplace(a: np.ndarray) -> np.ndarray:
    """``a`` ← 1 / (1 + exp(-a)), the same operations as ``mlp.sigmoid``; returns ``a``."""
    np.negative(a, out=a)
    with np.errstate(over="ignore"):
        np.exp(a, out=a)
    a += 1.0
    return np.reciprocal(a, out=a)


def training_accuracy(
    weights: np.ndarray, inputs: np.ndarray, actions: np.ndarray, *, hidden: int = N_HIDDEN
) -> float:
    """Share of cases where the network's largest output is the demonstrated command.

    ``weights`` (W,), or (k, W) for an ensemble driving by its networks' mean outputs
    (:func:`~lfd_track.policy.mlp.ensemble_forward`; a GA population is not one: score its
    networks one by one); ``inputs`` (N, 40) road values (plus
    memory inputs), ``actions`` (N,) commands 0/1/2; checked as :func:`imitation_fitness` checks
    them. ``hidden``: hidden nodes of the network (the paper's 5).
    """
    x, a = check_cases(inputs, actions)
    if np.ndim(weights) not in (1, 2):
        raise ValueError(
            f"weights must be one network, (W,), or an ensemble, (k, W), got shape"
            f" {np.shape(weights)}"
        )
    w, bias = check_weights(np.atleast_2d(np.asarray(weights)), x.shape[1], None, hidden)
    predicted = ensemble_forward(w, x, bias=bias, hidden=hidden).argmax(axis=1)  # one: its own
    return float((predicted == a).mean())
