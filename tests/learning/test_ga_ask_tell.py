import hashlib

import numpy as np
import pytest

from lfd_track.learning.fitness import imitation_fitness
from lfd_track.learning.ga import GAConfig, evolve, ga_ask, ga_init, ga_rescore, ga_tell


def _cases(n=60):
    rng = np.random.default_rng(123)
    return rng.uniform(-1, 1, (n, 40)), rng.integers(0, 3, n)


def _digest(array):
    return hashlib.sha256(np.ascontiguousarray(array).tobytes()).hexdigest()[:16]


@pytest.mark.parametrize(
    ("config", "fitness", "generation", "weights", "histories"),
    [
        # Values computed with the closed-loop evolve() before it became a loop over ask/tell.
        (GAConfig(population_size=12, generations=15), 0.869791217676411, 15,
         "1ce31fda8a21dead", (13.571332719651993, 13.964968543880547)),
        (GAConfig(population_size=10, generations=8, elitism=2), 0.9350588403013554, 8,
         "61ff0de81057d7eb", (7.56685381549352, 7.750380837512216)),
    ],
)  # fmt: skip
def test_evolve_is_unchanged_from_the_closed_loop_version(
    config, fitness, generation, weights, histories
):
    x, a = _cases()
    result = evolve(x, a, config, np.random.default_rng(7))
    # The weights are drawn by the generator and chosen by fitness comparisons, none of them
    # near a tie: the same bytes under every OpenBLAS kernel (Prescott to Haswell, 1 or 2
    # threads), and so is the generation that found the best.
    assert _digest(result.best_weights) == weights
    assert result.best_generation == generation
    # Fitness values are sums of network outputs, which BLAS kernels round differently (the
    # histories' bytes differ between kernels): equal to well within 1e-12.
    assert result.best_fitness == pytest.approx(fitness, rel=0, abs=1e-12)
    sums = (result.best_history.sum(), result.mean_history.sum())
    assert sums == pytest.approx(histories, rel=0, abs=1e-11)
    assert len(result.best_history) == len(result.mean_history) == config.generations


def test_evolve_gives_the_same_bytes_twice_in_one_process():
    x, a = _cases()
    config = GAConfig(population_size=12, generations=15)
    one, two = (evolve(x, a, config, np.random.default_rng(7)) for _ in range(2))
    assert one.best_fitness == two.best_fitness
    for name in ("best_weights", "best_history", "mean_history"):
        assert getattr(one, name).tobytes() == getattr(two, name).tobytes()


def test_evolve_requires_a_generator():
    x, a = _cases()
    with pytest.raises(TypeError, match="Generator"):
        evolve(x, a, GAConfig(generations=1), None)


def test_ask_tell_pauses_and_resumes_without_changing_the_run():
    x, a = _cases()
    config = GAConfig(population_size=10, generations=6)
    reference = evolve(x, a, config, np.random.default_rng(3))
    rng = np.random.default_rng(3)
    state = ga_init(config, rng)
    for _ in range(3):
        children = ga_ask(state, config, rng)
        state = ga_tell(state, children, imitation_fitness(children, x, a))
    paused = state  # frozen: later tells cannot change it
    for _ in range(3):
        children = ga_ask(state, config, rng)
        state = ga_tell(state, children, imitation_fitness(children, x, a))
    assert paused.generation == 3 and state.generation == 6
    assert state.best_fitness == reference.best_fitness
    np.testing.assert_array_equal(state.best_weights, reference.best_weights)
    assert not state.population.flags.writeable


def test_rescore_recomputes_fitness_on_the_new_cases():
    x, a = _cases()
    config = GAConfig(population_size=8, generations=4)
    rng = np.random.default_rng(5)
    state = ga_init(config, rng)
    children = ga_ask(state, config, rng)
    state = ga_tell(state, children, imitation_fitness(children, x[:20], a[:20]))
    rescored = ga_rescore(state, x, a, config)
    np.testing.assert_array_equal(rescored.fitness, imitation_fitness(state.population, x, a))
    assert rescored.best_fitness == imitation_fitness(rescored.best_weights[None], x, a)[0]
    assert rescored.best_fitness <= imitation_fitness(state.best_weights[None], x, a)[0]
    assert rescored.best_history == state.best_history  # the record of past generations stays
