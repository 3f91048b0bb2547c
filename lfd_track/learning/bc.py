"""Behaviour cloning baseline: the paper's 40-5-3 network trained by backpropagation (numpy only).

The network is exactly the one the GA evolves (sigmoid hidden and output nodes, no biases unless
asked; weight order of :mod:`lfd_track.policy.mlp`), so a BC fit drops into a controller file
unchanged. The loss is a class-balanced softmax cross-entropy over the three sigmoid outputs
divided by a temperature:

    p = softmax(o / temperature),  loss = sum_i c_i * -log p_i[a_i] / sum_i c_i
                                         + weight_decay / 2 * |w|^2

where ``o`` (N, 3) are the sigmoid outputs, ``a_i`` the demonstrated command and ``c_i = 1 / n_e``
with ``n_e`` the number of cases of that command, so each command weighs the same however often
it was demonstrated (as Algorithm 3 normalises per category). ``class_balance`` = k makes it
``c_i = n_e ** -k``: 0 weighs every case the same (plain cross-entropy, the commands as often as
the teacher gave them), 0.5 between the two. The outputs lie in (0, 1), so
without a temperature the softmax could never be confident; 0.1 lets the winning output lead by
a margin well past Algorithm 3's threshold before the loss flattens. Adam minimises it.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..core.config import DictConfig
from ..policy.mlp import MAX_MEMBERS, N_HIDDEN, N_OUTPUTS, check_hidden, n_weights, sigmoid
from .fitness import Cases, checked_cases, population_fitness
from .result import (
    LearnerFit,
    check_bool,
    check_config,
    check_int,
    check_positive,
    initial_weights,
)

MAX_WATCHED_FITS = 10
"""At most this many fits for :attr:`BCConfig.watched_fits` (each watched over laps of the
demonstration track)."""


@dataclass(frozen=True)
class BCConfig(DictConfig):
    """Behaviour-cloning settings (chosen on the training track's demonstrations only)."""

    settings_name = "BC"

    epochs: int = 2000
    """Passes over the training cases (at most 1 000 000)."""
    batch_size: int = 0
    """Cases per Adam step, drawn as a fresh permutation each epoch; 0 = all cases (full batch);
    at most 1 000 000."""
    learning_rate: float = 0.01
    """Adam step size (per weight, in weight units)."""
    beta1: float = 0.9
    """Adam decay of the gradient's running mean."""
    beta2: float = 0.999
    """Adam decay of the squared gradient's running mean."""
    epsilon: float = 1e-8
    """Adam's guard against division by zero."""
    temperature: float = 0.1
    """The sigmoid outputs (0..1) are divided by this before the softmax."""
    weight_decay: float = 0.0
    """L2 penalty coefficient on all weights (loss units per squared weight)."""
    init_range: float = 1.0
    """Initial weights are uniform in [-init_range, init_range], as the GA draws them."""
    bias: bool = False
    """Give hidden and output nodes biases (223 weights instead of the paper's 215)."""
    threshold: float = 0.4
    """Output-difference threshold of the Algorithm 3 fitness reported in the history."""
    class_balance: float = 1.0
    """k in the case weights ``n_e ** -k`` (``n_e``: cases of the case's command): 1 each command
    weighs the same (Algorithm 3's normalisation), 0 each case the same; in [0, 1]."""
    ensemble: int = 1
    """Networks fitted to the same cases, each from its own starting weights (drawn in turn from
    the same generator, so the first is the single fit's), driving by the mean of their outputs
    (:func:`~lfd_track.policy.mlp.ensemble_forward`); 1: one network. At most
    :data:`~lfd_track.policy.mlp.MAX_MEMBERS`. On one demonstration the starting weights alone
    move a policy's laps more than the demonstration does
    (``benchmarks/experiments/human_goal/round20/``)."""
    watched_fits: int = 1
    """Fits the ``bc`` method chooses among by watching each drive the demonstration track
    (:mod:`lfd_track.methods.watched`): it fits again, from new starting weights drawn from the
    same generator, while a fit does not lap every watched lap, up to this many fits, and keeps
    the one that lapped most; 1: the first fit, not watched. At most :data:`MAX_WATCHED_FITS`."""
    hidden: int = N_HIDDEN
    """Nodes of the hidden layer: the paper's 5, or another width up to
    :data:`~lfd_track.policy.mlp.MAX_HIDDEN`; the controller file records it in its
    ``layer_sizes``. On the saved demonstrations of twenty rooms, 10 nodes match a held-out
    room's human on 1.4 points more of its cases than 5 (``benchmarks/experiments/human_goal/
    round42/``), and drive no more laps (``round43/``)."""

    def to_dict(self) -> dict[str, Any]:
        """The settings as a dict; ``class_balance``, ``ensemble`` and ``watched_fits`` only
        when they are not 1, ``hidden`` only when it is not the paper's 5 (what every fit did
        before each setting existed), so that files written before them still match theirs."""
        data = super().to_dict()
        for name in ("class_balance", "ensemble", "watched_fits"):
            if data[name] == 1:
                del data[name]
        if data["hidden"] == N_HIDDEN:
            del data["hidden"]
        return data

    def case_weights(self, category_weights: np.ndarray) -> np.ndarray:
        """(N,) the loss's weight of each case from its ``category_weights`` ``1 / n_e``
        (:func:`~lfd_track.learning.fitness.category_weights`; see :attr:`class_balance`)."""
        if self.class_balance == 1.0:
            return category_weights
        return np.asarray(category_weights**self.class_balance, dtype=np.float64)

    def __post_init__(self) -> None:
        check_int("epochs", self.epochs, 1, 1_000_000)
        check_int("batch_size", self.batch_size, 0, 1_000_000)
        check_positive("learning_rate", self.learning_rate)
        for name in ("beta1", "beta2"):
            value = getattr(self, name)
            check_positive(name, value, allow_zero=True)
            if not value < 1:
                raise ValueError(f"{name} must be in [0, 1), got {value!r}")
        check_positive("epsilon", self.epsilon)
        check_positive("temperature", self.temperature)
        check_positive("weight_decay", self.weight_decay, allow_zero=True)
        check_positive("init_range", self.init_range, allow_zero=True)
        check_bool("bias", self.bias)
        check_positive("threshold", self.threshold)
        check_positive("class_balance", self.class_balance, allow_zero=True)
        if not self.class_balance <= 1.0:
            raise ValueError(f"class_balance must be in [0, 1], got {self.class_balance!r}")
        check_int("ensemble", self.ensemble, 1, MAX_MEMBERS)
        check_int("watched_fits", self.watched_fits, 1, MAX_WATCHED_FITS)
        check_hidden(self.hidden)


def bc_loss_and_gradient(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    case_weights: np.ndarray,
    temperature: float,
    weight_decay: float = 0.0,
    hidden: int = N_HIDDEN,
) -> tuple[float, np.ndarray]:
    """The BC loss (see the module docstring) and its exact gradient by backpropagation.

    ``weights`` (W,) float64 with W = 215 or 223 (biases); ``inputs`` (N, 40); ``actions`` (N,)
    intp commands; ``case_weights`` (N,) non-negative importance of each case (normalised here).
    ``hidden``: nodes of the hidden layer (the paper's 5). Returns ``(loss, gradient (W,)
    float64)``.
    """
    n_in = inputs.shape[1]
    n1 = hidden * n_in  # weights into the hidden layer
    n2 = N_OUTPUTS * hidden
    bias = weights.shape[0] == n_weights(True, n_in, hidden)
    w1 = weights[:n1].reshape(hidden, n_in)
    w2 = weights[n1 : n1 + n2].reshape(N_OUTPUTS, hidden)
    pre_hidden = inputs @ w1.T
    if bias:
        pre_hidden += weights[n1 + n2 : n1 + n2 + hidden]
    h = sigmoid(pre_hidden)  # (N, hidden)
    pre_out = h @ w2.T
    if bias:
        pre_out += weights[n1 + n2 + hidden :]
    out = sigmoid(pre_out)  # (N, 3)
    logits = out / temperature
    logits -= logits.max(axis=1, keepdims=True)
    log_norm = np.log(np.exp(logits).sum(axis=1))
    rows = np.arange(inputs.shape[0])
    c = case_weights / case_weights.sum()
    loss = float(c @ (log_norm - logits[rows, actions]))
    loss += 0.5 * weight_decay * float(weights @ weights)

    # Backward pass, layer by layer.
    d_logits = np.exp(logits - log_norm[:, None])  # softmax probabilities
    d_logits[rows, actions] -= 1.0
    d_logits *= c[:, None]
    d_pre_out = d_logits / temperature * out * (1.0 - out)  # (N, 3)
    d_hidden = d_pre_out @ w2
    d_pre_hidden = d_hidden * h * (1.0 - h)  # (N, hidden)
    grad = np.empty_like(weights)
    grad[:n1] = (d_pre_hidden.T @ inputs).ravel()
    grad[n1 : n1 + n2] = (d_pre_out.T @ h).ravel()
    if bias:
        grad[n1 + n2 : n1 + n2 + hidden] = d_pre_hidden.sum(axis=0)
        grad[n1 + n2 + hidden :] = d_pre_out.sum(axis=0)
    grad += weight_decay * weights
    return loss, grad


def adam_step(
    weights: np.ndarray,
    grad: np.ndarray,
    m: np.ndarray,
    v: np.ndarray,
    step: int,
    config: BCConfig,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One Adam update (``step`` counts from 1): the new ``(weights, m, v)``."""
    m = config.beta1 * m + (1.0 - config.beta1) * grad
    v = config.beta2 * v + (1.0 - config.beta2) * grad * grad
    m_hat = m / (1.0 - config.beta1**step)
    v_hat = v / (1.0 - config.beta2**step)
    return weights - config.learning_rate * m_hat / (np.sqrt(v_hat) + config.epsilon), m, v


def adam_epoch(
    weights: np.ndarray,
    moments: tuple[np.ndarray, np.ndarray, int],
    cases: Cases,
    config: BCConfig,
    order: np.ndarray | None = None,
    hidden: int = N_HIDDEN,
) -> tuple[np.ndarray, tuple[np.ndarray, np.ndarray, int]]:
    """One epoch of Adam on the BC loss over ``cases``: the new weights and Adam's state
    ``moments`` = (m, v, steps so far).

    ``order`` None: one full-batch step on the cases as they are; else minibatches of
    ``config.batch_size`` cases taken in that order (a permutation of the cases)."""
    m, v, step = moments
    x, a, case_weights = cases.inputs, cases.actions, config.case_weights(cases.category_weights)
    batches: list[np.ndarray | None] = [None]
    if order is not None:
        n = x.shape[0]
        batch = n if config.batch_size == 0 else min(config.batch_size, n)
        batches = [order[start : start + batch] for start in range(0, n, batch)]
    for idx in batches:
        _, grad = bc_loss_and_gradient(
            weights,
            x if idx is None else x[idx],
            a if idx is None else a[idx],
            case_weights if idx is None else case_weights[idx],
            config.temperature,
            config.weight_decay,
            hidden,
        )
        step += 1
        weights, m, v = adam_step(weights, grad, m, v, step, config)
    return weights, (m, v, step)


def fit_bc(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: BCConfig | None,
    rng: np.random.Generator,
    *,
    hidden: int | None = None,
) -> LearnerFit:
    """Train the 40-5-3 network on demonstration cases by Adam on the BC loss.

    ``inputs``: (N, 40) road values; ``actions``: (N,) commands 0/1/2; ``rng`` (required) draws
    the initial weights and, with minibatches, each epoch's case order, so the same seed gives
    the same bytes; ``config`` None means ``BCConfig()``. Returns the weights after the last epoch; ``history[e]`` is the Algorithm 3
    fitness of the weights after epoch ``e + 1`` (one network per epoch, so it is also that
    epoch's best).

    With ``config.ensemble`` = k > 1 the k networks are fitted one after the other, each from
    the generator's next starting weights (the first is the single fit), and the weights are
    (k, W); ``history`` is then the mean of the networks' histories.

    ``hidden``: nodes of the hidden layer, ``config.hidden`` (the paper's 5 unless a wider
    network is asked for) when None (40-``hidden``-3; the fit is otherwise the same).
    """
    if not isinstance(rng, np.random.Generator):
        raise ValueError("fit_bc needs a numpy Generator (rng) so that runs are reproducible")
    config = check_config(config, BCConfig, "fit_bc")
    hidden = check_hidden(config.hidden if hidden is None else hidden)
    cases = checked_cases(inputs, actions)  # checked once; the epochs use the checked arrays
    fits = [_fit_one(cases, config, rng, hidden) for _ in range(config.ensemble)]
    if len(fits) == 1:
        return bc_fit(*fits[0], config)
    weights = np.stack([w for w, _ in fits])
    return bc_fit(weights, np.mean([h for _, h in fits], axis=0), config)


def bc_fit(weights: np.ndarray, history: np.ndarray, config: BCConfig) -> LearnerFit:
    """The :class:`LearnerFit` of backprop's ``weights`` (one network, or an ensemble's) whose
    Algorithm 3 fitness per epoch is ``history``; the fit's fitness is its last epoch's."""
    return LearnerFit(
        weights=weights,
        fitness=float(history[-1]),
        history=history,
        learner="bc",
        config=config.to_dict(),
    )


def _fit_one(
    cases: Cases, config: BCConfig, rng: np.random.Generator, hidden: int
) -> tuple[np.ndarray, np.ndarray]:
    """One network's weights after the last epoch and its history (:func:`fit_bc`)."""
    n = cases.inputs.shape[0]
    weights = initial_weights(config.bias, config.init_range, rng, cases.inputs.shape[1], hidden)
    moments = (np.zeros_like(weights), np.zeros_like(weights), 0)
    history = np.empty(config.epochs)
    full_batch = config.batch_size == 0 or config.batch_size >= n
    for epoch in range(config.epochs):
        order = None if full_batch else rng.permutation(n)
        weights, moments = adam_epoch(weights, moments, cases, config, order, hidden)
        fitness = population_fitness(
            weights[None], cases, config.threshold, bias=config.bias, hidden=hidden
        )
        history[epoch] = fitness[0]
    return weights, history
