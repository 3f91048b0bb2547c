import numpy as np
import pytest

import lfd_track.learning.cmaes as cmaes_module
from lfd_track.learning.cmaes import CMAESConfig, fit_cmaes
from lfd_track.learning.fitness import imitation_fitness, training_accuracy


def start_of(seed, bias=False):
    """The start mean fit_cmaes draws first from its generator."""
    return np.random.default_rng(seed).uniform(-1, 1, 223 if bias else 215)


def test_cmaes_improves_on_its_start_and_returns_the_best_evaluated(demo_cases):
    x, actions = demo_cases
    fit = fit_cmaes(x, actions, CMAESConfig(generations=60), np.random.default_rng(0))
    start_fitness = imitation_fitness(start_of(0)[None], x, actions)[0]
    assert fit.learner == "cma-es" and fit.config == CMAESConfig(generations=60).to_dict()
    assert fit.history.shape == (60,) and fit.weights.shape == (215,)
    assert fit.fitness == pytest.approx(fit.history.min(), abs=1e-12)
    assert fit.fitness == imitation_fitness(fit.weights[None], x, actions)[0]
    assert fit.fitness < start_fitness - 0.2
    assert fit.history[-10:].mean() < fit.history[:10].mean() - 0.1
    assert training_accuracy(fit.weights, x, actions) > training_accuracy(start_of(0), x, actions)


def test_same_seed_same_bytes_whatever_numpys_global_state():
    rng = np.random.default_rng(1)
    x = rng.uniform(-1, 1, (40, 40))
    actions = np.arange(40) % 3
    config = CMAESConfig(generations=15)
    np.random.seed(1)
    a = fit_cmaes(x, actions, config, np.random.default_rng(7))
    np.random.seed(2)
    b = fit_cmaes(x, actions, config, np.random.default_rng(7))
    c = fit_cmaes(x, actions, config, np.random.default_rng(8))
    assert a.weights.tobytes() == b.weights.tobytes()
    assert a.history.tobytes() == b.history.tobytes()
    assert a.weights.tobytes() != c.weights.tobytes()


def test_one_batched_fitness_call_per_generation_and_the_paper_budget(monkeypatch):
    assert CMAESConfig().population_size * CMAESConfig().generations == 40 * 200
    calls = []
    real = cmaes_module.population_fitness  # the cases are checked once, before the loop

    def counting(weights, *args, **kwargs):
        calls.append(np.shape(weights))
        return real(weights, *args, **kwargs)

    monkeypatch.setattr(cmaes_module, "population_fitness", counting)
    rng = np.random.default_rng(2)
    x = rng.uniform(-1, 1, (30, 40))
    fit = fit_cmaes(x, np.arange(30) % 3, CMAESConfig(generations=7, bias=True), rng)
    assert calls == [(40, 223)] * 7 + [(1, 223)]  # then the winner is scored alone
    assert fit.weights.shape == (223,)


def test_bad_input_and_config_are_rejected_clearly():
    rng = np.random.default_rng(0)
    x = rng.uniform(-1, 1, (10, 40))
    actions = np.arange(10) % 3
    config = CMAESConfig(generations=1)
    with pytest.raises(ValueError, match="input rows"):
        fit_cmaes(x, actions[:5], config, rng)
    with pytest.raises(ValueError, match="at least one"):
        fit_cmaes(x[:0], actions[:0], config, rng)
    with pytest.raises(ValueError, match="infinite"):
        fit_cmaes(np.where(x > 0.9, np.inf, x), actions, config, rng)
    with pytest.raises(ValueError, match="0..2"):
        fit_cmaes(x, actions - 1, config, rng)
    with pytest.raises(ValueError, match="Generator"):
        fit_cmaes(x, actions, config, None)
    assert CMAESConfig.from_dict(CMAESConfig(sigma0=0.2).to_dict()) == CMAESConfig(sigma0=0.2)
    with pytest.raises(ValueError, match="unknown CMA-ES setting 'popsize'"):
        CMAESConfig.from_dict({"popsize": 10})
    for bad in ({"population_size": 1}, {"generations": 0}, {"sigma0": 0}, {"bias": "yes"}):
        with pytest.raises(ValueError):
            CMAESConfig.from_dict(bad)
