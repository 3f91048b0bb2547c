"""The paper's GA for an Elman network (:mod:`lfd_track.policy.elman`): Algorithm 3 scored over
each recorded episode run in order.

An Elman network's context (its previous hidden activations) depends on its own weights, so its
fitness cannot be taken case by case as the MLP's is: every individual runs over each episode's
cases in recorded order, its context starting at 0 with each episode, and Algorithm 3 scores the
outputs it produced. The run is vectorised over the population (one matrix product per episode
for the inputs, a (P, 5) x (5, 5) product per step for the context). Selection, crossover and
mutation are the paper GA's own (:func:`~lfd_track.learning.ga.ga_ask` / ``ga_tell``), on the
Elman network's longer weight vectors.

The cases of a recording are the steps the human drove as teaching cases; the few steps that are
not (the library-only commands before the first case) are not part of the sequence, whereas
when driving the context runs over every frame.

Backprop trains the same network (:func:`fit_bc_elman`): the behaviour-cloning loss of
:mod:`lfd_track.learning.bc` on the outputs of the sequence run, its exact gradient by
backpropagation through time over each whole episode (the context's gradient flows back step by
step until the episode's first case), Adam on whole episodes at once.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from ..policy.elman import N_CONTEXT, elman_sequence, elman_weights
from ..policy.mlp import N_HIDDEN, N_OUTPUTS, sigmoid
from .bc import BCConfig, adam_step, bc_fit
from .fitness import _OTHERS, _category_weights, _check_threshold
from .ga import EvolutionResult, GAConfig, ga_ask, ga_init, ga_result, ga_tell
from .result import LearnerFit, check_cases, check_config


def episode_starts(n_cases: int, episodes: list[int] | None = None) -> np.ndarray:
    """(N,) bool, True at the first case of each episode; ``episodes``: the episodes' case counts
    in order (None: one episode of all the cases). Raises ``ValueError`` if they do not sum to N."""
    starts = np.zeros(n_cases, dtype=bool)
    if episodes is None:
        episodes = [n_cases]
    if any(isinstance(e, bool) or int(e) != e or e < 1 for e in episodes):
        raise ValueError("episodes must be positive case counts")
    if sum(episodes) != n_cases:
        raise ValueError(f"episodes hold {sum(episodes)} cases, the inputs {n_cases}")
    starts[np.cumsum([0, *episodes[:-1]])] = True
    return starts


def sequence_fitness(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    starts: np.ndarray,
    threshold: float,
    *,
    bias: bool,
) -> np.ndarray:
    """Algorithm 3 for every Elman network, each run over the episodes in order; (P,) float64,
    lower is better (see :func:`~lfd_track.learning.fitness.imitation_fitness` for the rule)."""
    outputs = elman_sequence(weights, inputs, bias=bias, starts=starts)  # (P, N, 3)
    return _outputs_fitness(outputs, np.asarray(actions, dtype=np.intp), threshold)


def _outputs_fitness(outputs: np.ndarray, a: np.ndarray, threshold: float) -> np.ndarray:
    """Algorithm 3 of P networks' outputs (P, N, 3) on the commands ``a`` (N,); (P,) float64."""
    n = a.shape[0]
    winning = outputs[:, np.arange(n), a]  # (P, N)
    others = outputs[:, np.arange(n)[:, None], _OTHERS[a]]  # (P, N, 2)
    diff = winning[:, :, None] - others
    score = np.where(diff >= threshold, 0.5, 0.5 * diff / threshold).sum(axis=2)
    return 1.0 - (score @ _category_weights(a)) / 3.0


def evolve_elman(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: GAConfig | None,
    rng: np.random.Generator,
    *,
    episodes: list[int] | None = None,
    progress: Callable[[int, float, float], None] | None = None,
) -> EvolutionResult:
    """Evolve an Elman network that imitates ``actions`` from ``inputs`` (N, n) (the per-region
    features and any memory inputs, as for the MLP), the cases in recorded order; ``episodes``
    as for :func:`episode_starts`. The paper's GA (``config`` None: Table 1), the same random
    stream order as :func:`~lfd_track.learning.ga.evolve`; the result's weights are
    :func:`~lfd_track.policy.elman.elman_weights` long."""
    config = check_config(config, GAConfig, "evolve_elman")
    if not isinstance(rng, np.random.Generator):
        raise TypeError("evolve_elman needs a seeded np.random.Generator (rng)")
    _check_threshold(config.threshold)
    rng_state = rng.bit_generator.state
    x, a = check_cases(inputs, actions)
    starts = episode_starts(len(a), episodes)
    state = ga_init(config, rng, x.shape[1] + N_CONTEXT)
    for _ in range(config.generations):
        children = ga_ask(state, config, rng)
        fitness = sequence_fitness(children, x, a, starts, config.threshold, bias=config.bias)
        state = ga_tell(state, children, fitness)
        if progress is not None:
            progress(state.generation, state.best_history[-1], state.mean_history[-1])
    return ga_result(state, config, rng_state)


def sequence_accuracy(
    weights: np.ndarray, inputs: np.ndarray, actions: np.ndarray, starts: np.ndarray, *, bias: bool
) -> float:
    """Share of cases where one Elman network's (W,) largest output, run over the episodes in
    order, is the demonstrated command (the MLP's
    :func:`~lfd_track.learning.fitness.training_accuracy`)."""
    x, a = check_cases(inputs, actions)
    outputs = elman_sequence(
        np.asarray(weights, dtype=np.float64)[None], x, bias=bias, starts=starts
    )
    return float((outputs[0].argmax(axis=1) == a).mean())


def elman_loss_and_gradient(
    weights: np.ndarray,
    inputs: np.ndarray,
    actions: np.ndarray,
    case_weights: np.ndarray,
    starts: np.ndarray,
    temperature: float,
    weight_decay: float = 0.0,
) -> tuple[float, np.ndarray, np.ndarray]:
    """The BC loss of one Elman network (W,) run over the episodes in order, its exact gradient
    by backpropagation through time, and the outputs it produced, ``(loss, gradient (W,),
    outputs (N, 3))``. ``inputs`` (N, n), ``actions`` (N,) intp, ``case_weights`` (N,) as for
    :func:`~lfd_track.learning.bc.bc_loss_and_gradient`; ``starts`` (N,) bool as for
    :func:`episode_starts`."""
    w = np.asarray(weights, dtype=np.float64)
    x = np.asarray(inputs, dtype=np.float64)
    n, n_in = x.shape
    bias = w.shape[0] == elman_weights(True, n_in)
    width = N_HIDDEN * (n_in + N_CONTEXT)
    w_ih = w[:width].reshape(N_HIDDEN, n_in + N_CONTEXT)
    w_x, w_c = w_ih[:, :n_in], w_ih[:, n_in:]
    w_ho = w[width : width + N_OUTPUTS * N_HIDDEN].reshape(N_OUTPUTS, N_HIDDEN)
    tail = width + N_OUTPUTS * N_HIDDEN
    pre_x = x @ w_x.T
    if bias:
        pre_x += w[tail : tail + N_HIDDEN]
    reset = np.asarray(starts, dtype=bool)
    hidden = np.empty((n, N_HIDDEN))
    contexts = np.zeros((n, N_CONTEXT))  # the context each step read
    context = np.zeros(N_CONTEXT)
    for t in range(n):
        if reset[t]:
            context = np.zeros(N_CONTEXT)
        contexts[t] = context
        context = sigmoid(pre_x[t] + w_c @ context)
        hidden[t] = context
    pre_out = hidden @ w_ho.T
    if bias:
        pre_out += w[tail + N_HIDDEN :]
    out = sigmoid(pre_out)
    logits = out / temperature
    logits -= logits.max(axis=1, keepdims=True)
    log_norm = np.log(np.exp(logits).sum(axis=1))
    rows = np.arange(n)
    c = case_weights / case_weights.sum()
    loss = float(c @ (log_norm - logits[rows, actions])) + 0.5 * weight_decay * float(w @ w)

    d_logits = np.exp(logits - log_norm[:, None])
    d_logits[rows, actions] -= 1.0
    d_logits *= c[:, None]
    d_pre_out = d_logits / temperature * out * (1.0 - out)  # (N, 3)
    d_hidden = d_pre_out @ w_ho  # (N, 5): from each step's own outputs
    slope = hidden * (1.0 - hidden)
    d_pre = np.empty((n, N_HIDDEN))
    carry = np.zeros(N_HIDDEN)  # from the steps after, through the context
    for t in range(n - 1, -1, -1):
        d_pre[t] = (d_hidden[t] + carry) * slope[t]
        carry = np.zeros(N_HIDDEN) if reset[t] else d_pre[t] @ w_c
    grad = np.empty_like(w)
    grad[:width] = np.hstack([d_pre.T @ x, d_pre.T @ contexts]).ravel()
    grad[width:tail] = (d_pre_out.T @ hidden).ravel()
    if bias:
        grad[tail : tail + N_HIDDEN] = d_pre.sum(axis=0)
        grad[tail + N_HIDDEN :] = d_pre_out.sum(axis=0)
    grad += weight_decay * w
    return loss, grad, out


def fit_bc_elman(
    inputs: np.ndarray,
    actions: np.ndarray,
    config: BCConfig | None,
    rng: np.random.Generator,
    *,
    episodes: list[int] | None = None,
) -> LearnerFit:
    """Train an Elman network on cases in recorded order by backpropagation through time: Adam
    on :func:`elman_loss_and_gradient`, every episode whole in every step (``config.batch_size``
    must be 0). ``rng`` draws the initial weights (uniform in ±``init_range``, as the GA draws
    them); ``episodes`` as for :func:`episode_starts`. ``history[e]`` is the Algorithm 3
    fitness (:func:`sequence_fitness`) of the weights after epoch ``e + 1``."""
    if not isinstance(rng, np.random.Generator):
        raise ValueError("fit_bc_elman needs a numpy Generator (rng) so that runs are reproducible")
    config = check_config(config, BCConfig, "fit_bc_elman")
    if config.ensemble != 1:
        raise ValueError("an Elman network is one network: backprop's ensemble must be 1")
    if config.batch_size != 0:
        raise ValueError(
            "backprop through time fits whole episodes: the BC batch_size must be 0 for an Elman"
            f" network, got {config.batch_size}"
        )
    x, a = check_cases(inputs, actions)
    starts = episode_starts(len(a), episodes)
    case_weights = config.case_weights(_category_weights(a))
    weights = rng.uniform(
        -config.init_range, config.init_range, size=elman_weights(config.bias, x.shape[1])
    )
    m = np.zeros_like(weights)
    v = np.zeros_like(weights)
    history = np.empty(config.epochs)
    for epoch in range(config.epochs):
        _, grad, out = elman_loss_and_gradient(
            weights, x, a, case_weights, starts, config.temperature, config.weight_decay
        )
        if epoch:  # the outputs of the weights after the previous epoch
            history[epoch - 1] = _outputs_fitness(out[None], a, config.threshold)[0]
        weights, m, v = adam_step(weights, grad, m, v, epoch + 1, config)
    history[-1] = sequence_fitness(weights[None], x, a, starts, config.threshold, bias=config.bias)[
        0
    ]
    return bc_fit(weights, history, config)
