"""The paper's 40-5-3 sigmoid MLP (§4.2.3) as a flat weight vector, batched over a population.

Weight order (no biases, the paper's 215 weights): the 5 x 40 input-to-hidden matrix row-major
(row = hidden node), then the 3 x 5 hidden-to-output matrix row-major (row = output node).
With ``bias=True`` the 5 hidden biases and then the 3 output biases follow (223 weights), so a
bias-free vector is a prefix of the bias layout.

The input layer is the 40 road values, optionally followed by memory inputs
(:mod:`lfd_track.policy.memory`): a network with ``n`` inputs has ``5 n + 15`` weights (plus 8
biases); its number of inputs is read from the inputs it is given.

The hidden layer has the paper's 5 nodes unless ``hidden`` says otherwise (a wider network for
learners that can fit one, e.g. backprop): with ``h`` hidden nodes the layout is the same with 5
replaced by ``h`` (``h n + 3 h`` weights, plus ``h + 3`` biases).
"""

from __future__ import annotations

import numpy as np

N_INPUTS = 40
N_HIDDEN = 5
N_OUTPUTS = 3
LAYER_SIZES = (N_INPUTS, N_HIDDEN, N_OUTPUTS)

MAX_HIDDEN = 1_000
"""Most hidden nodes a network may have."""


def check_hidden(hidden: int) -> int:
    """``hidden`` if it is an integer in 1..MAX_HIDDEN, else ``ValueError`` (one line)."""
    if isinstance(hidden, bool) or not isinstance(hidden, int | np.integer):
        raise ValueError(
            f"hidden must be an integer number of hidden nodes, got {type(hidden).__name__}"
        )
    if not 1 <= hidden <= MAX_HIDDEN:
        shown = hidden if abs(hidden) < 10**18 else "a number of more than 18 digits"
        raise ValueError(f"hidden must be in 1..{MAX_HIDDEN}, got {shown}")
    return int(hidden)


def n_weights(bias: bool = False, n_inputs: int = N_INPUTS, hidden: int = N_HIDDEN) -> int:
    """Length of a weight vector: 215 without biases, 223 with (for the paper's 40 inputs and 5
    hidden nodes)."""
    return hidden * n_inputs + N_OUTPUTS * hidden + (hidden + N_OUTPUTS if bias else 0)


def layer_sizes(n_inputs: int = N_INPUTS, hidden: int = N_HIDDEN) -> tuple[int, int, int]:
    """(inputs, hidden, outputs) of the network: (40, 5, 3), or more inputs with memory (or
    another hidden width)."""
    return (n_inputs, hidden, N_OUTPUTS)


def sigmoid(x: np.ndarray) -> np.ndarray:
    """Logistic function 1 / (1 + exp(-x)), float64.

    exp(-x) overflows to inf for x < -709, which correctly gives 0; the warning is silenced.
    """
    with np.errstate(over="ignore"):
        e = np.exp(-np.asarray(x, dtype=np.float64))
    e += 1.0
    return np.reciprocal(e, out=e)


def mlp_forward(
    weights: np.ndarray,
    inputs: np.ndarray,
    *,
    bias: bool | None = None,
    hidden: int = N_HIDDEN,
) -> np.ndarray:
    """Outputs of one network or a population of networks on a batch of inputs.

    ``weights``: (W,) or (P, W) float, W = 215 (or 223 with biases; inferred from W when ``bias``
    is None) for 40 inputs. ``inputs``: (N, n) or (n,), n = 40 road values (plus any memory
    inputs). Returns float64 (N, 3), (P, N, 3), or without the N axis when ``inputs`` is 1-D.
    Sigmoid on hidden and output nodes. ``hidden``: nodes of the hidden layer (the paper's 5).
    """
    w = np.asarray(weights, dtype=np.float64)
    x = np.asarray(inputs, dtype=np.float64)
    single_input = x.ndim == 1
    x2 = x[None, :] if single_input else x
    if x2.ndim != 2 or x2.shape[1] < 1:
        raise ValueError(
            f"inputs must have shape (N, n), n >= 1 (the {N_INPUTS} road values, then any"
            f" memory inputs; or the memory inputs alone), got {x.shape}"
        )
    n_in = x2.shape[1]
    if bias is None:
        bias = w.shape[-1] == n_weights(True, n_in, hidden)
    if w.ndim not in (1, 2) or w.shape[-1] != n_weights(bias, n_in, hidden):
        size = n_weights(bias, n_in, hidden)
        raise ValueError(
            f"weights must have shape ({size},) or (P, {size}) for {n_in} inputs, got {w.shape}"
        )
    w1 = hidden * n_in
    w_2 = N_OUTPUTS * hidden
    single_net = w.ndim == 1
    w2 = w[None, :] if single_net else w
    p = w2.shape[0]
    w_ih = w2[:, :w1].reshape(p, hidden, n_in)
    w_ho = w2[:, w1 : w1 + w_2].reshape(p, N_OUTPUTS, hidden)
    # Batched (P, N, 40) @ (P, 40, 5) products: many small GEMMs, which OpenBLAS runs on the
    # calling thread. One big (N, 40) @ (40, P*5) GEMM is no faster alone but gets multi-threaded
    # and stalls several-fold when other processes load the cores.
    pre_hidden = np.matmul(x2, np.ascontiguousarray(w_ih.transpose(0, 2, 1)))
    if bias:
        pre_hidden += w2[:, None, w1 + w_2 : w1 + w_2 + hidden]
    hidden_out = sigmoid(pre_hidden)
    pre_out = np.matmul(hidden_out, np.ascontiguousarray(w_ho.transpose(0, 2, 1)))
    if bias:
        pre_out += w2[:, None, w1 + w_2 + hidden :]
    out = sigmoid(pre_out)
    if single_input:
        out = out[:, 0]
    return out[0] if single_net else out


MAX_MEMBERS = 64
"""Most networks an ensemble may hold."""


def ensemble_forward(
    weights: np.ndarray,
    inputs: np.ndarray,
    *,
    bias: bool | None = None,
    hidden: int = N_HIDDEN,
) -> np.ndarray:
    """Outputs of a policy: one network's (``weights`` (W,), exactly :func:`mlp_forward`), or
    the mean of an ensemble's (``weights`` (k, W): k networks of the same layout, each fitted
    from its own starting weights; :attr:`~lfd_track.learning.bc.BCConfig.ensemble`).
    Returns (N, 3), or (3,) when ``inputs`` is 1-D."""
    w = np.asarray(weights, dtype=np.float64)
    out = mlp_forward(w, inputs, bias=bias, hidden=hidden)
    return out if w.ndim == 1 else out.mean(axis=0)


def select_action(outputs: np.ndarray, previous: int | None = None) -> int:
    """Index of the largest of the 3 outputs (0 forward, 1 left, 2 right).

    An exact tie for the largest output sends no new command, so ``previous`` is returned (the
    paper, §4.2.3); with no previous command the first tied index is taken.
    """
    out = np.asarray(outputs, dtype=np.float64).reshape(-1)
    if out.shape != (N_OUTPUTS,):
        raise ValueError(f"outputs must have {N_OUTPUTS} values, got {out.shape}")
    best = int(np.argmax(out))
    if previous is not None and np.count_nonzero(out == out[best]) > 1:
        return int(previous)
    return best


def check_numbers(name: str, array: np.ndarray) -> None:
    """Raise ``ValueError`` unless ``array`` holds real numbers (integers or floats, not bools)."""
    dtype = array.dtype
    if dtype == np.bool_ or not (
        np.issubdtype(dtype, np.floating) or np.issubdtype(dtype, np.integer)
    ):
        raise ValueError(f"{name} must be numbers, got dtype {dtype}")
