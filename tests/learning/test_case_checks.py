"""Every learner and the fitness refuse bad cases, weights and settings up front, through one
shared check (``lfd_track.learning.result.check_cases``), instead of returning NaN, inf or a
meaningless fitness, or failing later with an AttributeError."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.learning import (
    BCConfig,
    BCLearner,
    CMAESConfig,
    CMAESLearner,
    GAConfig,
    GALearner,
    evolve,
    fit_bc,
    fit_cmaes,
    imitation_fitness,
)
from lfd_track.learning.fitness import training_accuracy


def _cases(n=12):
    rng = np.random.default_rng(0)
    return rng.uniform(0, 1, (n, 40)), np.arange(n) % 3


def _run_fitness(x, a):
    return imitation_fitness(np.zeros((2, 215)), x, a)


def _run_ga(x, a):
    return evolve(x, a, GAConfig(generations=2, population_size=4), np.random.default_rng(0))


def _run_bc(x, a):
    return fit_bc(x, a, BCConfig(epochs=1), np.random.default_rng(0))


def _run_cmaes(x, a):
    return fit_cmaes(x, a, CMAESConfig(generations=1, population_size=2), np.random.default_rng(0))


def _run_ga_update(x, a):
    learner = GALearner(GAConfig(population_size=4))
    learner.begin(np.random.default_rng(0))
    return learner.update(x, a, 1)


def _run_accuracy(x, a):
    return training_accuracy(np.zeros(215), x, a)


RUNS = [_run_fitness, _run_ga, _run_bc, _run_cmaes, _run_ga_update, _run_accuracy]
IDS = ["fitness", "ga", "bc", "cma-es", "ga-update", "accuracy"]


def _one_nan(x, a):
    x = x.copy()
    x[3, 7] = np.nan
    return x, a


def _all_nan(x, a):
    return np.full_like(x, np.nan), a


def _inf(x, a):
    x = x.copy()
    x[0, 0] = np.inf
    return x, a


BAD_CASES = [
    (_one_nan, "NaN or infinite"),
    (_all_nan, "NaN or infinite"),
    (_inf, "NaN or infinite"),
    (lambda x, a: (x[:0], a[:0]), "at least one"),
    (lambda x, a: (x, a[:-1]), "input rows"),
    (lambda x, a: (x[:, :0], a), r"shape \(N, n\), n >= 1"),
    (lambda x, a: (x[0], a[:1]), r"shape \(N, n\), n >= 1"),
    (lambda x, a: (x, np.where(a == 2, 3, a)), "0..2"),
    (lambda x, a: (x, -a), "0..2"),
    (lambda x, a: (x, a.astype(float)), "integer"),
    (lambda x, a: (x, a.astype(bool)), "integer"),
    (lambda x, a: (x.astype(str), a), "numbers"),
]
BAD_IDS = [
    "one-nan", "all-nan", "inf", "empty", "rows", "columns", "1-d", "label-3", "negative",
    "float-labels", "bool-labels", "strings",
]  # fmt: skip


@pytest.mark.parametrize("run", RUNS, ids=IDS)
@pytest.mark.parametrize("bad, match", BAD_CASES, ids=BAD_IDS)
def test_bad_cases_are_refused_by_every_learner(run, bad, match):
    x, a = bad(*_cases())
    with pytest.raises(ValueError, match=match):
        run(x, a)


def test_evolve_with_a_nan_case_no_longer_returns_a_nan_history():
    x, a = _one_nan(*_cases())
    with pytest.raises(ValueError, match="inputs contain NaN"):
        evolve(x, a, GAConfig(generations=3), np.random.default_rng(0))


@pytest.mark.parametrize("value", [np.nan, np.inf, -np.inf])
def test_fitness_refuses_non_finite_weights(value):
    x, a = _cases()
    w = np.zeros((3, 215))
    w[1, 5] = value
    with pytest.raises(ValueError, match="weights contain NaN or infinite"):
        imitation_fitness(w, x, a)
    with pytest.raises(ValueError, match="weights contain NaN or infinite"):
        training_accuracy(w[1], x, a)


@pytest.mark.parametrize("threshold", [0, -1, np.nan, np.inf, "0.4", True])
def test_fitness_refuses_a_bad_threshold(threshold):
    x, a = _cases()
    with pytest.raises(ValueError, match="threshold"):
        imitation_fitness(np.zeros((1, 215)), x, a, threshold)


def test_checked_fitness_equals_the_previous_results_bit_for_bit():
    # The checks only refuse; valid calls give the very same numbers (and evolve, which checks
    # once and then runs the unchecked kernel, the same as scoring each generation publicly).
    x, a = _cases(31)
    config = GAConfig(generations=4, population_size=6)
    result = evolve(x, a, config, np.random.default_rng(4))
    refit = imitation_fitness(result.best_weights[None], x, a)[0]
    assert refit == pytest.approx(result.best_fitness, abs=1e-12)
    assert np.isfinite(result.best_history).all()


@pytest.mark.parametrize(
    "run, cls",
    [
        (lambda c: evolve(*_cases(), c, np.random.default_rng(0)), "GAConfig"),
        (lambda c: fit_bc(*_cases(), c, np.random.default_rng(0)), "BCConfig"),
        (lambda c: fit_cmaes(*_cases(), c, np.random.default_rng(0)), "CMAESConfig"),
        (GALearner, "GAConfig"),
        (BCLearner, "BCConfig"),
        (CMAESLearner, "CMAESConfig"),
    ],
    ids=["evolve", "fit_bc", "fit_cmaes", "GALearner", "BCLearner", "CMAESLearner"],
)
@pytest.mark.parametrize("config", [{"generations": 2}, {}, "fast", BCConfig(), GAConfig()])
def test_config_must_be_the_learners_settings_class(run, cls, config):
    if type(config).__name__ == cls:
        return  # the right class is accepted (covered elsewhere)
    with pytest.raises(TypeError, match=rf"config must be a {cls}"):
        run(config)


def test_ga_update_refuses_cases_of_another_width():
    x, a = _cases()
    learner = GALearner(GAConfig(population_size=4))
    learner.begin(np.random.default_rng(0))
    with pytest.raises(ValueError, match="41"):
        learner.update(np.hstack([x, x[:, :1]]), a, 1)


@pytest.mark.parametrize("bias", ["yes", 1, 0, None, np.bool_(True)])
def test_ga_config_bias_must_be_a_bool(bias):
    with pytest.raises(ValueError, match="bias must be true or false"):
        GAConfig(bias=bias)


@pytest.mark.parametrize("name", ["mutation_rate", "mutation_delta", "init_range", "threshold"])
def test_ga_config_numbers_must_be_numbers(name):
    with pytest.raises(ValueError, match=name):
        GAConfig(**{name: "0.5"})
