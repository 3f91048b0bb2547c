"""What every baseline learner returns, and the checks they share on training cases.

A learner turns demonstration cases (road values and the commands given) into the weights of the
paper's 40-5-3 sigmoid network (see :mod:`lfd_track.policy.mlp` for the weight order). Whatever
the learner optimises internally, :attr:`LearnerFit.fitness` is the paper's Algorithm 3 imitation
fitness of the returned weights (for backprop's ensemble, the mean of its networks'), so learners
can be compared on one scale.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, TypeVar

import numpy as np

from ..policy.mlp import N_HIDDEN, N_INPUTS, N_OUTPUTS, check_numbers, n_weights

T = TypeVar("T")


@dataclass(frozen=True)
class LearnerFit:
    """Outcome of a baseline learner (:func:`~lfd_track.learning.bc.fit_bc`, ...)."""

    weights: np.ndarray
    """The learned network, (215,) float64, or (223,) with biases; for backprop's ensemble
    (``BCConfig.ensemble`` = k > 1) the k networks, (k, W)."""
    fitness: float
    """Algorithm 3 imitation fitness of ``weights`` on the training cases (lower is better); for
    an ensemble the mean of its networks' fitnesses (not that of their averaged outputs)."""
    history: np.ndarray
    """Best Algorithm 3 fitness of each epoch or generation, (epochs or generations,) float64;
    for an ensemble the mean of its networks' histories."""
    learner: str
    """Name of the learner, e.g. ``"bc"`` or ``"cma-es"``."""
    config: dict[str, Any]
    """The learner's settings as a plain JSON-friendly dict."""


def check_cases(inputs: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate training cases; returns ``(inputs (N, n) float64, actions (N,) intp)``, n = 40
    road values plus any memory inputs.

    The one check every learner and the imitation fitness run on their cases (once, at entry:
    their inner loops then use the checked arrays). Raises ``ValueError`` with one line saying
    what is wrong: wrong shapes, no cases, non-finite road values, or commands outside 0..2.
    """
    x = np.asarray(inputs)
    if x.ndim != 2 or x.shape[1] < 1:
        raise ValueError(
            f"inputs must have shape (N, n), n >= 1 (the {N_INPUTS} road values, then any"
            f" memory inputs; or the memory inputs alone), got {x.shape}"
        )
    check_numbers("inputs", x)
    x = x.astype(np.float64)
    a = check_actions(actions)
    if a.shape[0] != x.shape[0]:
        raise ValueError(f"{x.shape[0]} input rows but {a.shape[0]} actions")
    if x.shape[0] == 0:
        raise ValueError("no training cases: a learner needs at least one")
    if not np.isfinite(x).all():
        raise ValueError("inputs contain NaN or infinite road values")
    return x, a


def check_actions(actions: np.ndarray) -> np.ndarray:
    """Validate demonstrated commands: 1-D integers in 0..2 (may be empty); returns them intp."""
    a = np.asarray(actions)
    if a.ndim != 1:
        raise ValueError(f"actions must be 1-D, got shape {a.shape}")
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.integer):
        if a.size == 0 and a.dtype == np.float64:  # np.array([]): no commands at all
            return a.astype(np.intp)
        raise ValueError(f"actions must be integer commands 0..{N_OUTPUTS - 1}, got {a.dtype}")
    if a.size and (a.min() < 0 or a.max() >= N_OUTPUTS):
        raise ValueError(f"actions must be integers in 0..{N_OUTPUTS - 1}")
    return a.astype(np.intp)


def check_weights(
    weights: np.ndarray, n_inputs: int, bias: bool | None, hidden: int = N_HIDDEN
) -> tuple[np.ndarray, bool]:
    """Validate a population of networks, (P, W), for ``n_inputs`` inputs (and ``hidden``
    hidden nodes); ``bias`` None infers it from W. Returns ``(weights (P, W) float64, bias)``; raises ``ValueError`` on a wrong shape
    or NaN / infinite weights."""
    w = np.asarray(weights)
    if w.ndim != 2:
        raise ValueError(f"weights must be (P, W), got shape {w.shape}")
    check_numbers("weights", w)
    w = w.astype(np.float64, copy=False)
    if bias is None:
        bias = w.shape[1] == n_weights(True, n_inputs, hidden)
    size = n_weights(bias, n_inputs, hidden)
    if w.shape[1] != size:
        raise ValueError(
            f"weights must have shape ({size},) or (P, {size}) for {n_inputs} inputs, got {w.shape}"
        )
    if not np.isfinite(w).all():
        raise ValueError("weights contain NaN or infinite values")
    return w, bias


def check_config(config: Any, cls: type[T], function: str) -> T:
    """``config`` if it is a ``cls``, ``cls()`` (the defaults) if None, else a ``TypeError``
    naming the parameter (a dict of settings is not a config: ``cls.from_dict`` builds one)."""
    if config is None:
        return cls()
    if not isinstance(config, cls):
        raise TypeError(
            f"{function}: config must be a {cls.__name__} or None, got"
            f" {type(config).__name__} (build it with {cls.__name__}(...) or"
            f" {cls.__name__}.from_dict(settings))"
        )
    return config


def check_bool(name: str, value: Any) -> None:
    """Raise ``ValueError`` unless ``value`` is True or False (not 1, "yes" or a numpy bool)."""
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")


def initial_weights(
    bias: bool,
    init_range: float,
    rng: np.random.Generator,
    n_inputs: int = N_INPUTS,
    hidden: int = N_HIDDEN,
) -> np.ndarray:
    """One network drawn like a GA individual: uniform in [-init_range, init_range], (W,)."""
    return rng.uniform(-init_range, init_range, size=n_weights(bias, n_inputs, hidden))


def shown_int(value: int) -> str:
    """An integer as short text: a 400-digit number is not printed whole."""
    if abs(value) < 10**18:
        return str(value)
    return f"{'-' if value < 0 else ''}a number of more than 18 digits"


def check_int(name: str, value: Any, minimum: int, maximum: int | None = None) -> None:
    """Raise ``ValueError`` unless ``value`` is an int (not bool) in ``minimum..maximum``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if value < minimum:
        raise ValueError(f"{name} must be at least {minimum}, got {shown_int(value)}")
    if maximum is not None and value > maximum:
        raise ValueError(f"{name} must be at most {maximum}, got {shown_int(value)}")


def check_positive(name: str, value: Any, *, allow_zero: bool = False) -> None:
    """Raise ``ValueError`` unless ``value`` is a finite positive (or zero) real number."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{name} must be a number, got {value!r}")
    ok = value >= 0 if allow_zero else value > 0
    try:
        finite = math.isfinite(value)
    except OverflowError:  # an integer beyond any float
        finite = False
    if not (ok and finite):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
