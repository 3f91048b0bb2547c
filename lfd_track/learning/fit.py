"""What every baseline learner returns, and the checks they share on training cases.

A learner turns demonstration cases (road values and the commands given) into the weights of the
paper's 40-5-3 sigmoid network (see :mod:`lfd_track.control.mlp` for the weight order). Whatever
the learner optimises internally, :attr:`LearnerFit.fitness` is the paper's Algorithm 3 imitation
fitness of the returned weights, so learners can be compared on one scale.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from ..control.mlp import N_INPUTS, N_OUTPUTS, n_weights


@dataclass(frozen=True)
class LearnerFit:
    """Outcome of a baseline learner (:func:`~lfd_track.learning.bc.fit_bc`, ...)."""

    weights: np.ndarray
    """The learned network, (215,) float64, or (223,) with biases."""
    fitness: float
    """Algorithm 3 imitation fitness of ``weights`` on the training cases (lower is better)."""
    history: np.ndarray
    """Best Algorithm 3 fitness of each epoch or generation, (epochs or generations,) float64."""
    learner: str
    """Name of the learner, e.g. ``"bc"`` or ``"cma-es"``."""
    config: dict[str, Any]
    """The learner's settings as a plain JSON-friendly dict."""


def check_cases(inputs: np.ndarray, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Validate training cases; returns ``(inputs (N, n) float64, actions (N,) intp)``, n = 40
    road values plus any memory inputs.

    Raises ``ValueError`` with one line saying what is wrong: wrong shapes, no cases, non-finite
    road values, or commands outside 0..2.
    """
    x = np.asarray(inputs)
    if x.ndim != 2 or x.shape[1] < N_INPUTS:
        raise ValueError(
            f"inputs must have shape (N, {N_INPUTS}) (road values, then any memory inputs),"
            f" got {x.shape}"
        )
    if not (np.issubdtype(x.dtype, np.floating) or np.issubdtype(x.dtype, np.integer)):
        raise ValueError(f"inputs must be numbers, got dtype {x.dtype}")
    x = x.astype(np.float64)
    a = np.asarray(actions)
    if a.ndim != 1:
        raise ValueError(f"actions must be 1-D, got shape {a.shape}")
    if a.shape[0] != x.shape[0]:
        raise ValueError(f"{x.shape[0]} input rows but {a.shape[0]} actions")
    if x.shape[0] == 0:
        raise ValueError("no training cases: a learner needs at least one")
    if not np.isfinite(x).all():
        raise ValueError("inputs contain NaN or infinite road values")
    if a.dtype == np.bool_ or not np.issubdtype(a.dtype, np.integer):
        raise ValueError(f"actions must be integer commands 0..{N_OUTPUTS - 1}, got {a.dtype}")
    if a.min() < 0 or a.max() >= N_OUTPUTS:
        raise ValueError(f"actions must be integers in 0..{N_OUTPUTS - 1}")
    return x, a.astype(np.intp)


def initial_weights(
    bias: bool, init_range: float, rng: np.random.Generator, n_inputs: int = N_INPUTS
) -> np.ndarray:
    """One network drawn like a GA individual: uniform in [-init_range, init_range], (W,)."""
    return rng.uniform(-init_range, init_range, size=n_weights(bias, n_inputs))


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
    if not (ok and np.isfinite(value)):
        kind = "non-negative" if allow_zero else "positive"
        raise ValueError(f"{name} must be a finite {kind} number, got {value!r}")
