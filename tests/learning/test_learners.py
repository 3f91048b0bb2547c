"""The learner seam: every learner fits cases into the paper's network; the GA also learns
incrementally, and one update of G generations from the start is exactly ``evolve``."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.learning import (
    BCConfig,
    CMAESConfig,
    GAConfig,
    GALearner,
    IncrementalLearner,
    Learner,
    LearnerFit,
    evolve,
    learner_for,
)
from lfd_track.policy.mlp import n_weights


@pytest.fixture(scope="module")
def cases():
    rng = np.random.default_rng(7)
    x = rng.uniform(0.0, 1.0, size=(60, 40))
    a = np.where(x[:, 3] > 0.6, 1, np.where(x[:, 4] > 0.6, 2, 0))
    return x, a


CONFIGS = [
    GAConfig(generations=15),
    BCConfig(epochs=20),
    CMAESConfig(generations=10),
]


@pytest.mark.parametrize("config", CONFIGS, ids=["ga", "bc", "cma-es"])
def test_every_learner_fits_the_network_deterministically(config, cases):
    x, a = cases
    learner = learner_for(config)
    assert isinstance(learner, Learner) and learner.config is config
    fit = learner.fit(x, a, np.random.default_rng(3))
    assert isinstance(fit, LearnerFit) and fit.learner == learner.name
    assert fit.weights.shape == (n_weights(config.bias),)
    again = learner_for(config).fit(x, a, np.random.default_rng(3))
    np.testing.assert_array_equal(fit.weights, again.weights)


def test_only_the_ga_learns_incrementally():
    assert isinstance(learner_for(GAConfig()), IncrementalLearner)
    assert not isinstance(learner_for(BCConfig()), IncrementalLearner)
    assert not isinstance(learner_for(CMAESConfig()), IncrementalLearner)
    with pytest.raises(TypeError, match="no learner"):
        learner_for({"generations": 3})  # type: ignore[arg-type]


def test_ga_fit_and_one_update_from_the_start_are_evolve(cases):
    x, a = cases
    config = GAConfig(generations=12)
    reference = evolve(x, a, config, np.random.default_rng(5))
    fitted = GALearner(config).fit(x, a, np.random.default_rng(5))
    np.testing.assert_array_equal(fitted.weights, reference.best_weights)
    assert fitted.fitness == reference.best_fitness
    incremental = GALearner(config)
    incremental.begin(np.random.default_rng(5))
    np.testing.assert_array_equal(incremental.update(x, a, 12), reference.best_weights)


def test_ga_updates_as_cases_arrive(cases):
    x, a = cases
    learner = GALearner(GAConfig())
    with pytest.raises(RuntimeError, match="begin"):
        learner.update(x, a, 1)
    learner.begin(np.random.default_rng(0))
    for n in (10, 20, 40, 60):
        weights = learner.update(x[:n], a[:n], 2)
        assert weights.shape == (n_weights(False),)
    assert learner.state is not None and learner.state.generation == 8
    # the best so far is re-scored on all 60 cases, so its fitness is that of the full set
    from lfd_track.learning.fitness import imitation_fitness

    best = imitation_fitness(learner.state.best_weights[None, :], x, a, 0.4)[0]
    assert learner.state.best_fitness == pytest.approx(best)
