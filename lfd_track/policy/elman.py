"""An Elman network: the 5 hidden activations of the previous step fed back as 5 more inputs.

Where the ``previous_command`` memory (:mod:`lfd_track.policy.memory`) feeds back what the robot
did, an Elman network feeds back what it *thought*: its hidden layer's activations of the step
before (the *context*, all 0 at an episode's first step), so the network itself learns what to
carry from frame to frame. Policy kind ``"elman-sigmoid"`` of the controller file.

Weights: exactly the layout of the MLP (:mod:`lfd_track.policy.mlp`) of ``n + 5`` inputs, the
five context inputs last — the input-to-hidden matrix row-major (5 x (n + 5)), then the 3 x 5
hidden-to-output matrix, then with ``bias`` the 5 hidden and 3 output biases — so an Elman
network whose context weights are all 0 is the MLP of its first ``n`` inputs.

Its context depends on its own weights, so no recording holds it: a learner must run the network
over each recorded episode in order (:mod:`lfd_track.learning.elman`; the GA, vectorised over
the population). Backprop through time is not implemented, so BC does not train this kind.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..core.commands import Command
from .mlp import N_HIDDEN, N_OUTPUTS, n_weights, select_action, sigmoid

if TYPE_CHECKING:
    from ..teaching.types import Moment

N_CONTEXT = N_HIDDEN
"""Context inputs an Elman network adds: its previous hidden activations."""
_W2 = N_OUTPUTS * N_HIDDEN


def elman_weights(bias: bool, n_inputs: int) -> int:
    """Weights of an Elman network reading ``n_inputs`` inputs (plus its 5 context inputs)."""
    return n_weights(bias, n_inputs + N_CONTEXT)


def elman_sequence(
    weights: np.ndarray,
    inputs: np.ndarray,
    *,
    bias: bool,
    starts: np.ndarray | None = None,
) -> np.ndarray:
    """Outputs of P Elman networks run over a sequence of N steps, (P, N, 3) float64.

    ``weights`` (P, W) float64 with W = :func:`elman_weights` (``bias``, n); ``inputs`` (N, n).
    ``starts``: (N,) bool, True where an episode starts (the context is reset to 0 there; the
    first step always starts one). The input part of every step is one matrix product for the
    whole population; only the 5 x 5 context product runs step by step.
    """
    w = np.asarray(weights, dtype=np.float64)
    x = np.asarray(inputs, dtype=np.float64)
    p, (n, n_in) = w.shape[0], x.shape
    width = N_HIDDEN * (n_in + N_CONTEXT)
    w_ih = w[:, :width].reshape(p, N_HIDDEN, n_in + N_CONTEXT)
    w_x = np.ascontiguousarray(w_ih[:, :, :n_in].transpose(0, 2, 1))  # (P, n, 5)
    w_c = np.ascontiguousarray(w_ih[:, :, n_in:].transpose(0, 2, 1))  # (P, 5, 5)
    w_ho = np.ascontiguousarray(w[:, width : width + _W2].reshape(p, N_OUTPUTS, N_HIDDEN))
    pre_x = np.matmul(x, w_x)  # (P, N, 5)
    if bias:
        pre_x += w[:, None, width + _W2 : width + _W2 + N_HIDDEN]
    reset = np.zeros(n, dtype=bool) if starts is None else np.asarray(starts, dtype=bool)
    hidden = np.empty((p, n, N_HIDDEN))
    context = np.zeros((p, 1, N_HIDDEN))
    for t in range(n):
        if reset[t]:
            context[:] = 0.0
        pre = pre_x[:, t : t + 1] + np.matmul(context, w_c)
        context = sigmoid(pre)
        hidden[:, t] = context[:, 0]
    pre_out = np.matmul(hidden, w_ho.transpose(0, 2, 1))
    if bias:
        pre_out += w[:, None, width + _W2 + N_HIDDEN :]
    return sigmoid(pre_out)


class ElmanState:
    """One Elman network driving step by step: its context and its previous command."""

    def __init__(self, weights: np.ndarray, bias: bool, n_inputs: int) -> None:
        self.weights = np.asarray(weights, dtype=np.float64)
        self.bias = bool(bias)
        self.n_inputs = int(n_inputs)
        if self.weights.shape != (elman_weights(self.bias, self.n_inputs),):
            raise ValueError(
                f"an Elman network of {self.n_inputs} inputs needs"
                f" {elman_weights(self.bias, self.n_inputs)} weights, got {self.weights.shape}"
            )
        self.reset()

    def reset(self) -> None:
        """Start of an episode: context 0, no previous command."""
        self.context = np.zeros(N_CONTEXT)
        self.previous: int | None = None
        self.last_outputs: np.ndarray | None = None

    def step(self, values: np.ndarray) -> int:
        """Command for one step's inputs (n,) (the context is added and updated here)."""
        n = self.n_inputs + N_CONTEXT
        w1 = N_HIDDEN * n
        w_ih = self.weights[:w1].reshape(N_HIDDEN, n)
        w_ho = self.weights[w1 : w1 + _W2].reshape(N_OUTPUTS, N_HIDDEN)
        pre = w_ih @ np.concatenate([np.asarray(values, dtype=np.float64), self.context])
        if self.bias:
            pre += self.weights[w1 + _W2 : w1 + _W2 + N_HIDDEN]
        hidden = sigmoid(pre)
        pre_out = w_ho @ hidden
        if self.bias:
            pre_out += self.weights[w1 + _W2 + N_HIDDEN :]
        self.context = hidden
        self.last_outputs = sigmoid(pre_out)
        self.previous = select_action(self.last_outputs, self.previous)
        return self.previous


class ElmanCommander:
    """An Elman network as a commander of the teaching loop (its context runs over the episode;
    ``reset`` at an episode's start)."""

    def __init__(self, weights: np.ndarray, bias: bool, n_inputs: int) -> None:
        self._state = ElmanState(weights, bias, n_inputs)

    @property
    def last_outputs(self) -> np.ndarray | None:
        return self._state.last_outputs

    def reset(self) -> None:
        self._state.reset()

    def propose(self, moment: Moment) -> Command | None:
        return Command(self._state.step(moment.policy_inputs))
