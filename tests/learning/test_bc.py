import numpy as np
import pytest

from lfd_track.learning.bc import BCConfig, bc_loss_and_gradient, fit_bc
from lfd_track.learning.fitness import (
    category_weights,
    checked_cases,
    imitation_fitness,
    training_accuracy,
)
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.mlp import mlp_forward


def random_cases(seed=0, n=30):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 40))
    actions = rng.choice(3, size=n, p=[0.6, 0.25, 0.15])
    return x, actions


@pytest.mark.parametrize("bias", [False, True])
@pytest.mark.parametrize("weight_decay", [0.0, 0.03])
def test_gradient_matches_central_finite_differences(bias, weight_decay):
    x, actions = random_cases()
    rng = np.random.default_rng(1)
    w = rng.uniform(-1.5, 1.5, 223 if bias else 215)
    c = category_weights(actions) * rng.uniform(0.5, 1.5, actions.size)
    _, grad = bc_loss_and_gradient(w, x, actions, c, 0.1, weight_decay)
    h = 1e-6
    numeric = np.empty_like(w)
    for i in range(w.size):
        e = np.zeros_like(w)
        e[i] = h
        up, _ = bc_loss_and_gradient(w + e, x, actions, c, 0.1, weight_decay)
        down, _ = bc_loss_and_gradient(w - e, x, actions, c, 0.1, weight_decay)
        numeric[i] = (up - down) / (2 * h)
    assert np.abs(grad).max() > 1e-3  # the check is not vacuous
    np.testing.assert_allclose(grad, numeric, atol=1e-7, rtol=1e-5)


def test_loss_is_the_balanced_softmax_cross_entropy_of_the_network_outputs():
    x, actions = random_cases(2)
    w = np.random.default_rng(3).uniform(-1, 1, 215)
    loss, _ = bc_loss_and_gradient(w, x, actions, category_weights(actions), 0.1)
    out = mlp_forward(w, x) / 0.1
    p = np.exp(out) / np.exp(out).sum(axis=1, keepdims=True)
    per_case = -np.log(p[np.arange(actions.size), actions])
    expected = np.mean([per_case[actions == k].mean() for k in range(3)])
    assert loss == pytest.approx(expected, rel=1e-12)


def test_each_command_weighs_the_same_however_often_it_was_demonstrated():
    x, actions = random_cases(4, n=12)
    w = np.random.default_rng(5).uniform(-1, 1, 215)
    base = bc_loss_and_gradient(w, x, actions, category_weights(actions), 0.1)
    forward = actions == 0
    x_many = np.concatenate([np.repeat(x[forward], 10, axis=0), x[~forward]])
    a_many = np.concatenate([np.repeat(actions[forward], 10), actions[~forward]])
    many = bc_loss_and_gradient(w, x_many, a_many, category_weights(a_many), 0.1)
    assert many[0] == pytest.approx(base[0], rel=1e-12)
    np.testing.assert_allclose(many[1], base[1], rtol=1e-10, atol=1e-14)


def test_bc_reaches_at_least_the_paper_ga_training_accuracy(demo_cases):
    x, actions = demo_cases
    for seed in (0, 1):
        ga = evolve(x, actions, GAConfig(), np.random.default_rng(seed))
        bc = fit_bc(x, actions, BCConfig(), np.random.default_rng(seed))
        ga_accuracy = training_accuracy(ga.best_weights, x, actions)
        assert training_accuracy(bc.weights, x, actions) >= ga_accuracy
        # And it is scored on the GA's own scale.
        assert bc.fitness == imitation_fitness(bc.weights[None], x, actions)[0]
        assert bc.fitness < ga.best_fitness


def test_fit_result_shapes_history_and_training_lowers_the_loss(demo_cases):
    x, actions = demo_cases
    config = BCConfig(epochs=300)
    rng = np.random.default_rng(0)
    start = np.random.default_rng(0).uniform(-1, 1, 215)  # fit_bc's first draw
    fit = fit_bc(x, actions, config, rng)
    assert fit.learner == "bc" and fit.config == config.to_dict()
    assert fit.weights.shape == (215,) and fit.weights.dtype == np.float64
    assert fit.history.shape == (300,) and fit.history[-1] == fit.fitness
    c = category_weights(actions)
    before, _ = bc_loss_and_gradient(start, x, actions, c, 0.1)
    after, _ = bc_loss_and_gradient(fit.weights, x, actions, c, 0.1)
    assert after < 0.5 * before
    assert fit.fitness < imitation_fitness(start[None], x, actions)[0] - 0.3
    assert fit_bc(x, actions, BCConfig(epochs=5, bias=True), rng).weights.shape == (223,)


@pytest.mark.parametrize("batch_size", [0, 16])
def test_same_seed_same_bytes_and_another_seed_differs(batch_size):
    x, actions = random_cases(6, n=40)
    config = BCConfig(epochs=40, batch_size=batch_size)
    a = fit_bc(x, actions, config, np.random.default_rng(7))
    b = fit_bc(x, actions, config, np.random.default_rng(7))
    c = fit_bc(x, actions, config, np.random.default_rng(8))
    assert a.weights.tobytes() == b.weights.tobytes()
    assert a.history.tobytes() == b.history.tobytes()
    assert a.weights.tobytes() != c.weights.tobytes()


def test_minibatches_change_the_steps_and_a_batch_of_all_cases_is_full_batch():
    x, actions = random_cases(6, n=40)
    full = fit_bc(x, actions, BCConfig(epochs=3), np.random.default_rng(7))
    mini = fit_bc(x, actions, BCConfig(epochs=3, batch_size=8), np.random.default_rng(7))
    whole = fit_bc(x, actions, BCConfig(epochs=3, batch_size=40), np.random.default_rng(7))
    assert mini.weights.tobytes() != full.weights.tobytes()
    assert whole.weights.tobytes() == full.weights.tobytes()


def test_bad_cases_are_rejected_clearly():
    x, actions = random_cases()
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="input rows"):
        fit_bc(x, actions[:-1], BCConfig(epochs=1), rng)
    with pytest.raises(ValueError, match="at least one"):
        fit_bc(x[:0], actions[:0], BCConfig(epochs=1), rng)
    with pytest.raises(ValueError, match=r"shape \(N, n\), n >= 1"):
        fit_bc(x[:, :0], actions, BCConfig(epochs=1), rng)
    bad = x.copy()
    bad[3, 7] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        fit_bc(bad, actions, BCConfig(epochs=1), rng)
    with pytest.raises(ValueError, match="0..2"):
        fit_bc(x, np.where(actions == 2, 3, actions), BCConfig(epochs=1), rng)
    with pytest.raises(ValueError, match="integer"):
        fit_bc(x, actions.astype(float), BCConfig(epochs=1), rng)
    with pytest.raises(ValueError, match="Generator"):
        fit_bc(x, actions, BCConfig(epochs=1), None)


def test_config_validation_and_round_trip():
    config = BCConfig(epochs=10, batch_size=4, weight_decay=1e-3)
    assert BCConfig.from_dict(config.to_dict()) == config
    with pytest.raises(ValueError, match="unknown BC setting 'epoch'"):
        BCConfig.from_dict({"epoch": 3})
    for bad in (
        {"epochs": 0},
        {"epochs": 2.5},
        {"batch_size": -1},
        {"learning_rate": 0},
        {"learning_rate": float("nan")},
        {"beta1": 1.0},
        {"temperature": -1},
        {"bias": 1},
        {"weight_decay": "x"},
        {"class_balance": -0.5},
        {"class_balance": 1.5},
    ):
        with pytest.raises(ValueError):
            BCConfig.from_dict(bad)


def test_class_balance_weighs_cases_between_each_command_the_same_and_each_case_the_same():
    """k = 1 (the default, and what every file before the setting did) is Algorithm 3's
    normalisation and leaves ``to_dict`` as it was; k = 0 is plain cross-entropy; a fit with k = 0
    on cases where forward is the teacher's most frequent command predicts it more often."""
    x, actions = random_cases(6, n=60)
    cases = checked_cases(x, actions)
    assert "class_balance" not in BCConfig().to_dict()
    assert BCConfig(class_balance=0.5).to_dict()["class_balance"] == 0.5
    assert BCConfig.from_dict({"class_balance": 0}) == BCConfig(class_balance=0.0)
    np.testing.assert_array_equal(
        BCConfig().case_weights(cases.category_weights), category_weights(actions)
    )
    np.testing.assert_array_equal(
        BCConfig(class_balance=0.0).case_weights(cases.category_weights), 1.0
    )
    counts = np.bincount(actions, minlength=3)
    np.testing.assert_allclose(
        BCConfig(class_balance=0.5).case_weights(cases.category_weights),
        counts[actions] ** -0.5,
        rtol=1e-12,
    )
    w = np.random.default_rng(7).uniform(-1, 1, 215)
    plain, _ = bc_loss_and_gradient(w, x, actions, np.ones(actions.size), 0.1)
    out = mlp_forward(w, x) / 0.1
    p = np.exp(out) / np.exp(out).sum(axis=1, keepdims=True)
    assert plain == pytest.approx(-np.log(p[np.arange(actions.size), actions]).mean(), rel=1e-12)

    rng = np.random.default_rng(8)
    x = rng.uniform(-1, 1, (200, 40))
    actions = np.where(rng.random(200) < 0.7, 0, rng.choice([1, 2], 200))  # 70 % forward, noisy

    def forward_share(k: float) -> float:
        fit = fit_bc(x, actions, BCConfig(epochs=300, class_balance=k), np.random.default_rng(9))
        return float(np.mean(mlp_forward(fit.weights, x).argmax(axis=1) == 0))

    assert forward_share(0.0) > forward_share(1.0) + 0.05
