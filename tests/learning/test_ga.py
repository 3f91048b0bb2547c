import numpy as np
import pytest

from lfd_track.learning.fitness import imitation_fitness
from lfd_track.learning.ga import (
    GAConfig,
    evolve,
    initial_population,
    mutate,
    next_generation,
    tournament_select,
    uniform_crossover,
)


def toy_data(seed=0, n=150):
    rng = np.random.default_rng(seed)
    x = rng.uniform(-1, 1, (n, 40))
    actions = np.where(x[:, 0] > 0.4, 1, np.where(x[:, 1] > 0.4, 2, 0))
    return x, actions


def test_tournament_of_three_picks_lowest_with_expected_probabilities():
    p, n = 10, 200_000
    fitness = np.random.default_rng(0).permutation(p).astype(float)  # distinct, rank = value
    picks = tournament_select(fitness, n, 3, np.random.default_rng(1))
    observed = np.bincount(fitness[picks].astype(int), minlength=p) / n
    ranks = np.arange(p)
    expected = ((p - ranks) ** 3 - (p - ranks - 1) ** 3) / p**3  # min of 3 draws with replacement
    np.testing.assert_allclose(observed, expected, atol=0.005)


def test_equal_fitness_makes_selection_uniform():
    picks = tournament_select(np.zeros(40), 400_000, 3, np.random.default_rng(2))
    freq = np.bincount(picks, minlength=40) / 400_000
    np.testing.assert_allclose(freq, 1 / 40, atol=0.002)


def test_uniform_crossover_takes_each_gene_from_a_parent_half_the_time():
    rng = np.random.default_rng(3)
    a = np.zeros((400, 215))
    b = np.ones((400, 215))
    child = uniform_crossover(a, b, rng)
    assert set(np.unique(child)) == {0.0, 1.0}
    assert child.mean() == pytest.approx(0.5, abs=0.01)
    # Genes are independent: no positional bias.
    assert np.abs(child.mean(axis=0) - 0.5).max() < 0.1


def test_mutation_rate_and_step_range():
    rng = np.random.default_rng(4)
    pop = np.zeros((400, 215))
    out = mutate(pop, 0.2, 0.1, rng)
    changed = out != 0
    assert changed.mean() == pytest.approx(0.2, abs=0.005)
    steps = out[changed]
    assert steps.min() >= -0.1 and steps.max() <= 0.1
    assert steps.mean() == pytest.approx(0.0, abs=0.003)
    assert np.histogram(steps, bins=4, range=(-0.1, 0.1))[0].min() > 0.23 * steps.size


def test_initial_population_range_and_size():
    pop = initial_population(GAConfig(), np.random.default_rng(5))
    assert pop.shape == (40, 215)
    assert pop.min() >= -1 and pop.max() <= 1 and pop.min() < -0.99 and pop.max() > 0.99
    assert initial_population(GAConfig(bias=True), np.random.default_rng(5)).shape == (40, 223)


def test_first_generation_is_bred_from_unevaluated_zero_fitness():
    x, actions = toy_data()
    config = GAConfig(generations=2)
    result = evolve(x, actions, config, np.random.default_rng(11))
    rng = np.random.default_rng(11)
    pop0 = initial_population(config, rng)
    pop1 = next_generation(pop0, np.zeros(40), config, rng)
    f1 = imitation_fitness(pop1, x, actions)
    assert result.best_history[0] == f1.min()
    assert result.mean_history[0] == pytest.approx(f1.mean())


def test_same_seed_same_result_and_different_seed_differs():
    x, actions = toy_data()
    config = GAConfig(generations=15)
    a = evolve(x, actions, config, np.random.default_rng(7))
    b = evolve(x, actions, config, np.random.default_rng(7))
    c = evolve(x, actions, config, np.random.default_rng(8))
    assert a.best_weights.tobytes() == b.best_weights.tobytes()
    assert a.best_history.tobytes() == b.best_history.tobytes()
    assert a.best_weights.tobytes() != c.best_weights.tobytes()
    restored = np.random.default_rng()
    restored.bit_generator.state = a.rng_state
    d = evolve(x, actions, config, restored)
    assert d.best_weights.tobytes() == a.best_weights.tobytes()


def test_evolution_improves_and_returns_best_ever():
    x, actions = toy_data()
    result = evolve(x, actions, GAConfig(generations=60), np.random.default_rng(9))
    assert result.best_history.shape == (60,) and result.mean_history.shape == (60,)
    assert result.best_fitness == result.best_history.min()
    assert result.best_history[result.best_generation - 1] == result.best_fitness
    assert result.best_fitness < result.best_history[0] - 0.05
    refit = imitation_fitness(result.best_weights[None], x, actions)[0]
    assert refit == pytest.approx(result.best_fitness, abs=1e-12)


def test_elitism_keeps_the_best():
    x, actions = toy_data()
    result = evolve(x, actions, GAConfig(generations=30, elitism=2), np.random.default_rng(1))
    assert np.all(np.diff(result.best_history[1:]) <= 1e-15)


def test_progress_callback_sees_every_generation():
    x, actions = toy_data(n=30)
    seen = []
    evolve(
        x,
        actions,
        GAConfig(generations=5),
        np.random.default_rng(0),
        progress=lambda g, best, mean: seen.append((g, best <= mean)),
    )
    assert seen == [(g, True) for g in range(1, 6)]


def test_bias_option_and_config_validation():
    x, actions = toy_data(n=30)
    result = evolve(x, actions, GAConfig(generations=3, bias=True), np.random.default_rng(0))
    assert result.best_weights.shape == (223,)
    with pytest.raises(ValueError):
        GAConfig(mutation_rate=1.5)
    with pytest.raises(ValueError):
        GAConfig(elitism=40)
    assert GAConfig.from_dict(GAConfig(elitism=2).to_dict()) == GAConfig(elitism=2)
    with pytest.raises(ValueError, match="unknown"):
        GAConfig.from_dict({"populaton_size": 3})
