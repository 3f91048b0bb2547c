"""The Elman network: its sequence run, its GA with sequential fitness, and its controller file."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.elman import (
    elman_loss_and_gradient,
    episode_starts,
    evolve_elman,
    fit_bc_elman,
    sequence_accuracy,
    sequence_fitness,
)
from lfd_track.learning.fitness import imitation_fitness, training_accuracy
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.controller import Controller
from lfd_track.policy.elman import ElmanState, elman_sequence, elman_weights
from lfd_track.policy.mlp import mlp_forward, n_weights
from lfd_track.teaching.types import Moment
from lfd_track.vision.synthetic import patch_library, synthetic_frames


@pytest.fixture(scope="module")
def library():
    frames = synthetic_frames(np.random.default_rng(0), 2)
    return patch_library(frames, 8, np.random.default_rng(1))


def _without_context(mlp: np.ndarray, n: int, bias: bool) -> np.ndarray:
    """The Elman weights of an MLP of n inputs: context weights 0."""
    w1 = mlp[: 5 * n].reshape(5, n)
    return np.concatenate([np.hstack([w1, np.zeros((5, 5))]).ravel(), mlp[5 * n :]])


@pytest.mark.parametrize("bias", [False, True])
def test_an_elman_network_without_context_weights_is_the_mlp(bias):
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (30, 43))
    a = rng.integers(0, 3, 30)
    mlps = rng.uniform(-1, 1, (4, n_weights(bias, 43)))
    elman = np.stack([_without_context(w, 43, bias) for w in mlps])
    assert elman.shape[1] == elman_weights(bias, 43)
    np.testing.assert_allclose(
        elman_sequence(elman, x, bias=bias), mlp_forward(mlps, x), atol=1e-12
    )
    starts = episode_starts(30, [10, 20])
    np.testing.assert_allclose(
        sequence_fitness(elman, x, a, starts, 0.4, bias=bias),
        imitation_fitness(mlps, x, a, bias=bias),
        atol=1e-12,
    )


def test_the_sequence_run_is_the_step_by_step_run_with_the_context_reset_per_episode():
    rng = np.random.default_rng(1)
    x = rng.uniform(0, 1, (12, 40))
    w = rng.uniform(-2, 2, (3, elman_weights(True, 40)))
    out = elman_sequence(w, x, bias=True, starts=episode_starts(12, [5, 7]))
    for p in range(3):
        state = ElmanState(w[p], True, 40)
        for t in range(12):
            if t == 5:
                state.reset()
            state.step(x[t])
            np.testing.assert_allclose(state.last_outputs, out[p, t], atol=1e-12)
    with pytest.raises(ValueError, match="episodes hold 11 cases, the inputs 12"):
        episode_starts(12, [5, 6])


def _cued_cases(n: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """The command at step t is shown only by a cue in step t - 1's inputs (the first 8 values):
    a network reading one step cannot know it, one with a context can."""
    rng = np.random.default_rng(4)
    actions = rng.integers(0, 3, n)
    x = rng.uniform(0.4, 0.6, (n, 40))
    cue = np.roll(actions, -1)  # step t shows the command of step t + 1
    x[:, :8] = (cue[:, None] == 1) * 1.0
    x[:, 8:16] = (cue[:, None] == 2) * 1.0
    return x, actions


def test_the_ga_evolves_an_elman_network_that_uses_its_context():
    x, a = _cued_cases()
    config = GAConfig(generations=150)
    elman = evolve_elman(x, a, config, np.random.default_rng(0))
    mlp = evolve(x, a, config, np.random.default_rng(0))
    assert elman.best_weights.shape == (elman_weights(False, 40),)
    assert elman.best_fitness < mlp.best_fitness - 0.1
    assert len(elman.best_history) == 150
    again = evolve_elman(x, a, config, np.random.default_rng(0))
    np.testing.assert_array_equal(again.best_weights, elman.best_weights)


def test_an_elman_controller_reloads_and_drives_the_same(tmp_path, library):
    x, a = _cued_cases(40)
    result = evolve_elman(x, a, GAConfig(generations=10), np.random.default_rng(2))
    controller = Controller.from_evolution(library, result, seed=2, policy_kind="elman-sigmoid")
    data = controller.to_dict()
    assert data["policy_kind"] == "elman-sigmoid" and data["schema_version"] == 8
    assert data["layer_sizes"] == [45, 5, 3]
    path = tmp_path / "elman.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.policy_kind == "elman-sigmoid"
    decisions = [controller.act_on_values(v) for v in x]
    assert [loaded.act_on_values(v) for v in x] == decisions
    commander = loaded.commander()
    commander.reset()
    proposed = [int(commander.propose(Moment(0, np.zeros((1, 1, 3)), v, {}, "policy"))) for v in x]
    assert proposed == decisions
    # The decisions are the sequence run's.
    out = elman_sequence(result.best_weights[None], x, bias=False)[0]
    assert decisions == [int(np.argmax(o)) for o in out]
    loaded.reset()  # a new episode starts from a zero context
    assert [loaded.act_on_values(v) for v in x] == decisions


def test_a_plain_controller_is_written_as_before(library):
    c = Controller(library, np.zeros(215))
    assert c.to_dict()["policy_kind"] == "mlp-sigmoid" and c.to_dict()["layer_sizes"] == [40, 5, 3]
    with pytest.raises(ValueError, match="expected 240 weights for 45 inputs"):
        Controller(library, np.zeros(215), policy_kind="elman-sigmoid")
    with pytest.raises(ValueError, match="policy kind 'lstm' is not supported"):
        Controller(library, np.zeros(215), policy_kind="lstm")


@pytest.mark.parametrize("bias", [False, True])
def test_backprop_through_time_gives_the_exact_gradient(bias):
    """Central differences of the loss agree with the gradient, across an episode boundary."""
    rng = np.random.default_rng(5)
    x = rng.uniform(0, 1, (25, 4))
    a = rng.integers(0, 3, 25)
    starts = episode_starts(25, [10, 15])
    w = rng.uniform(-2, 2, elman_weights(bias, 4))
    case_weights = rng.uniform(0.5, 1.5, 25)
    loss, grad, out = elman_loss_and_gradient(w, x, a, case_weights, starts, 0.1, 0.01)
    np.testing.assert_allclose(
        out, elman_sequence(w[None], x, bias=bias, starts=starts)[0], atol=1e-12
    )
    step = 1e-6
    numeric = np.empty_like(w)
    for i in range(len(w)):
        up, down = w.copy(), w.copy()
        up[i] += step
        down[i] -= step
        numeric[i] = (
            elman_loss_and_gradient(up, x, a, case_weights, starts, 0.1, 0.01)[0]
            - elman_loss_and_gradient(down, x, a, case_weights, starts, 0.1, 0.01)[0]
        ) / (2 * step)
    np.testing.assert_allclose(grad, numeric, atol=1e-7)
    assert np.abs(grad[: 5 * 9].reshape(5, 9)[:, 4:]).max() > 1e-4  # the context's weights learn


def _recall_cases(n: int = 300) -> tuple[np.ndarray, np.ndarray]:
    """Every 6th step shows a cue (turn left or right) and asks for forward; the 5th step after
    it asks for the cued turn with nothing in its own inputs to say which: only a network that
    carries the cue over 5 steps can answer."""
    rng = np.random.default_rng(6)
    x = np.zeros((n, 2))
    a = np.zeros(n, dtype=np.intp)
    cue = 1
    for t in range(n):
        if t % 6 == 0:
            cue = int(rng.integers(1, 3))
            x[t] = (1.0 if cue == 1 else 0.0, 1.0)
        elif t % 6 == 5:
            a[t] = cue
    return x, a


def test_backprop_trains_an_elman_network_that_carries_a_cue():
    x, a = _recall_cases()
    config = BCConfig(bias=True, epochs=600, learning_rate=0.03)
    fit = fit_bc_elman(x, a, config, np.random.default_rng(1))
    assert fit.weights.shape == (elman_weights(True, 2),) and len(fit.history) == 600
    starts = episode_starts(len(a))
    assert fit.fitness == pytest.approx(
        sequence_fitness(fit.weights[None], x, a, starts, 0.4, bias=True)[0], abs=1e-12
    )
    recall = np.arange(len(a)) % 6 == 5
    out = elman_sequence(fit.weights[None], x, bias=True, starts=starts)[0]
    assert (out[recall].argmax(axis=1) == a[recall]).mean() > 0.9
    assert sequence_accuracy(fit.weights, x, a, starts, bias=True) > 0.9
    # The MLP reading the same inputs cannot tell the recall steps' turns apart.
    mlp = fit_bc(x, a, config, np.random.default_rng(1))
    mlp_out = mlp_forward(mlp.weights, x, bias=True)
    assert (mlp_out[recall].argmax(axis=1) == a[recall]).mean() < 0.75
    assert training_accuracy(mlp.weights, x, a) < sequence_accuracy(
        fit.weights, x, a, starts, bias=True
    )
    again = fit_bc_elman(x, a, config, np.random.default_rng(1))
    np.testing.assert_array_equal(again.weights, fit.weights)
    with pytest.raises(ValueError, match="batch_size must be 0 for an Elman network"):
        fit_bc_elman(x, a, BCConfig(batch_size=32), np.random.default_rng(1))
