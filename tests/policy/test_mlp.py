import math

import numpy as np
import pytest

from lfd_track.policy.mlp import mlp_forward, n_weights, select_action


def literal_forward(w, x, bias=False):
    """One network, one input, written out node by node."""
    hidden = []
    for j in range(5):
        s = sum(w[j * 40 + i] * x[i] for i in range(40)) + (w[215 + j] if bias else 0.0)
        hidden.append(1.0 / (1.0 + math.exp(-s)))
    out = []
    for k in range(3):
        s = sum(w[200 + k * 5 + j] * hidden[j] for j in range(5)) + (w[220 + k] if bias else 0.0)
        out.append(1.0 / (1.0 + math.exp(-s)))
    return np.array(out)


@pytest.mark.parametrize("bias", [False, True])
def test_forward_matches_literal_network(bias):
    rng = np.random.default_rng(0)
    w = rng.uniform(-1, 1, (4, n_weights(bias)))
    x = rng.uniform(-1, 1, (6, 40))
    out = mlp_forward(w, x)
    assert out.shape == (4, 6, 3)
    for p in range(4):
        for n in range(6):
            np.testing.assert_allclose(out[p, n], literal_forward(w[p], x[n], bias), atol=1e-14)
    np.testing.assert_allclose(mlp_forward(w[1], x), out[1], atol=1e-15)
    np.testing.assert_allclose(mlp_forward(w[1], x[2]), out[1, 2], atol=1e-15)


def test_weight_counts_and_shape_checks():
    assert n_weights() == 215 and n_weights(bias=True) == 223
    with pytest.raises(ValueError, match="weights"):
        mlp_forward(np.zeros(214), np.zeros((1, 40)))
    with pytest.raises(ValueError, match="inputs"):
        mlp_forward(np.zeros(215), np.zeros((1, 39)))


def test_extreme_inputs_saturate_without_overflow():
    w = np.full(215, 50.0)
    with np.errstate(all="raise"):
        out = mlp_forward(w, np.full((1, 40), -1.0))
    assert np.all(np.isfinite(out))


def test_select_action_argmax_and_tie_keeps_previous():
    assert select_action(np.array([0.1, 0.7, 0.3])) == 1
    assert select_action(np.array([0.5, 0.2, 0.5]), previous=1) == 1
    assert select_action(np.array([0.5, 0.2, 0.5]), previous=None) == 0
    assert select_action(np.array([0.5, 0.2, 0.4]), previous=2) == 0
    # A tie below the maximum is not a tie for the action.
    assert select_action(np.array([0.3, 0.3, 0.9]), previous=0) == 2
