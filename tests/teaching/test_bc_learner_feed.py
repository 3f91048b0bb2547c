"""The backprop learner feed: Adam epochs warm-started from the current weights as cases arrive."""

import numpy as np
import pytest

from lfd_track.learning.bc import BCConfig, adam_step, bc_loss_and_gradient
from lfd_track.learning.fitness import checked_cases, training_accuracy
from lfd_track.learning.result import initial_weights
from lfd_track.teaching.commanders import PolicyCommander
from lfd_track.teaching.learner_feed import BCLearnerFeed


def _cases(n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Three inputs; the command is the input that is largest (separable)."""
    x = rng.uniform(0, 1, (n, 3))
    return x, np.argmax(x, axis=1).astype(np.intp)


def test_each_update_continues_adam_from_the_current_weights():
    config = BCConfig(bias=True)
    x, a = _cases(30, np.random.default_rng(0))
    policy = PolicyCommander(None)
    feed = BCLearnerFeed(config, np.random.default_rng(5), 3, policy, n_inputs=3)
    feed.update(x[:10], a[:10])
    feed.update(x, a)
    # the same six Adam steps by hand: three on the first ten cases, three more on all thirty
    weights = initial_weights(True, config.init_range, np.random.default_rng(5), 3)
    m, v = np.zeros_like(weights), np.zeros_like(weights)
    for step in range(1, 7):
        cases = checked_cases(*((x[:10], a[:10]) if step <= 3 else (x, a)))
        _, grad = bc_loss_and_gradient(
            weights, cases.inputs, cases.actions, cases.category_weights, config.temperature
        )
        weights, m, v = adam_step(weights, grad, m, v, step, config)
    np.testing.assert_allclose(feed.weights, weights, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(policy.weights, feed.weights)
    assert feed.generation == 6 and 0.0 <= feed.best_fitness <= 1.0


def test_the_feed_learns_from_cases_as_they_arrive():
    x, a = _cases(60, np.random.default_rng(1))
    feed = BCLearnerFeed(
        BCConfig(bias=True), np.random.default_rng(2), 20, PolicyCommander(None), 3
    )
    for n in range(1, len(a) + 1):
        feed.update(x[:n], a[:n])
    assert training_accuracy(feed.weights, x, a) >= 0.9
    assert feed.generation == 20 * len(a)


def test_the_feed_refuses_settings_it_cannot_use():
    policy = PolicyCommander(None)
    with pytest.raises(ValueError, match="epochs_per_case"):
        BCLearnerFeed(BCConfig(), np.random.default_rng(0), 0, policy)
    with pytest.raises(TypeError, match="BCConfig"):
        BCLearnerFeed({"epochs": 3}, np.random.default_rng(0), 1, policy)  # type: ignore[arg-type]
    with pytest.raises(TypeError, match="Generator"):
        BCLearnerFeed(BCConfig(), 0, 1, policy)  # type: ignore[arg-type]
