"""The Elman network: its sequence run, its GA with sequential fitness, and its controller file."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.learning.elman import episode_starts, evolve_elman, sequence_fitness
from lfd_track.learning.fitness import imitation_fitness
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
    assert data["policy_kind"] == "elman-sigmoid" and data["schema_version"] == 2
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
