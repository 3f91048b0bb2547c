"""Evolution without a human (lfd_track.learning.direct): the (mu+1)-ONLINE rules, the on-board
robot's put-backs and the robot-time counts, on tiny budgets."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.learning.direct import (
    Candidate,
    DirectConfig,
    MuPlusOneConfig,
    OnboardRobot,
    RoadDriver,
    adapt_sigma,
    combine_fitness,
    direct_evolution,
    drive_from_start,
    mu_plus_one_online,
    online_ask,
    online_init,
    online_tell,
)
from lfd_track.policy.mlp import N_HIDDEN, N_INPUTS, n_weights
from lfd_track.vision.road_library import RoadLibrary

LIBRARY = Path(__file__).resolve().parents[2] / "benchmarks/experiments/limits/results/library.json"


@pytest.fixture(scope="module")
def library() -> RoadLibrary:
    return RoadLibrary.from_dict(json.loads(LIBRARY.read_text()))


def always(command: int) -> np.ndarray:
    """Weights whose network gives ``command`` whatever it sees (hidden nodes constant 0.5)."""
    w = np.zeros(n_weights(False))
    out = w[N_HIDDEN * N_INPUTS :].reshape(3, N_HIDDEN)
    out[:] = -1.0
    out[command] = 1.0
    return w


# ------------------------------------------------------------------------------ sigma, fitness
def test_sigma_is_reset_on_success_and_doubled_up_to_the_cap_on_failure():
    config = MuPlusOneConfig(sigma_min=0.1, sigma_max=0.5)
    assert adapt_sigma(0.4, True, config) == 0.1
    assert adapt_sigma(0.1, False, config) == pytest.approx(0.2)
    assert adapt_sigma(0.2, False, config) == pytest.approx(0.4)
    assert adapt_sigma(0.4, False, config) == 0.5
    assert adapt_sigma(0.5, False, config) == 0.5


def test_a_reevaluated_fitness_is_the_mean_of_old_and_new():
    assert combine_fitness(2.0, 1.0) == 1.5
    assert combine_fitness(-1.0, 1.0) == 0.0


def test_bad_settings_are_refused():
    with pytest.raises(ValueError, match="sigma_max"):
        MuPlusOneConfig(sigma_min=1.0, sigma_max=0.5)
    with pytest.raises(ValueError, match="reevaluation"):
        MuPlusOneConfig(reevaluation=1.5)
    with pytest.raises(ValueError, match="population_size"):
        DirectConfig(population_size=1)


# ------------------------------------------------------------------------------ ask / tell
def _evaluated(config: MuPlusOneConfig, fitness: list[float]) -> object:
    state = online_init(config, np.random.default_rng(0))
    state.fitness[:] = fitness
    state.evaluated[:] = 1
    return state


def test_every_member_is_evaluated_once_before_anything_else():
    config = MuPlusOneConfig(mu=3, reevaluation=1.0)
    state = online_init(config, np.random.default_rng(0))
    for i in range(3):
        candidate = online_ask(state, config, np.random.default_rng(1))
        assert (candidate.kind, candidate.index) == ("initial", i)
        online_tell(state, candidate, float(i), config)
    assert list(state.fitness) == [0.0, 1.0, 2.0]
    assert online_ask(state, config, np.random.default_rng(1)).kind == "reevaluate"


def test_reevaluation_probability_decides_between_reevaluating_and_breeding():
    state = _evaluated(MuPlusOneConfig(mu=4), [1.0, 2.0, 3.0, 4.0])
    kinds = {
        p: [
            online_ask(state, MuPlusOneConfig(mu=4, reevaluation=p), np.random.default_rng(s)).kind
            for s in range(50)
        ]
        for p in (0.0, 0.3, 1.0)
    }
    assert set(kinds[0.0]) == {"child"}
    assert set(kinds[1.0]) == {"reevaluate"}
    assert 5 <= kinds[0.3].count("reevaluate") <= 25


def test_reevaluation_averages_and_counts():
    config = MuPlusOneConfig(mu=3)
    state = _evaluated(config, [1.0, 2.0, 3.0])
    genome = state.population[1].copy()
    assert not online_tell(state, Candidate("reevaluate", 1, genome), 0.0, config)
    assert list(state.fitness) == [1.0, 1.0, 3.0]
    assert list(state.evaluated) == [1, 2, 1]
    assert state.reevaluations == 1
    np.testing.assert_array_equal(state.population[1], genome)


def test_a_better_child_replaces_the_worst_and_resets_sigma():
    config = MuPlusOneConfig(mu=3, sigma_min=0.1, sigma_max=1.6)
    state = _evaluated(config, [2.0, 0.5, 3.0])
    state.sigma = 0.8
    child = np.full(state.population.shape[1], 7.0)
    assert online_tell(state, Candidate("child", -1, child), 1.0, config)
    assert list(state.fitness) == [2.0, 1.0, 3.0]
    np.testing.assert_array_equal(state.population[1], child)
    assert state.sigma == 0.1
    assert (state.children, state.accepted) == (1, 1)


def test_a_child_no_better_than_the_worst_is_dropped_and_sigma_doubles():
    config = MuPlusOneConfig(mu=3, sigma_min=0.1, sigma_max=1.6)
    state = _evaluated(config, [2.0, 0.5, 3.0])
    before = state.population.copy()
    for sigma_after in (0.2, 0.4):
        child = np.full(state.population.shape[1], 7.0)
        assert not online_tell(state, Candidate("child", -1, child), 0.5, config)  # tie: out
        assert state.sigma == pytest.approx(sigma_after)
    np.testing.assert_array_equal(state.population, before)
    assert list(state.fitness) == [2.0, 0.5, 3.0]
    assert (state.children, state.accepted) == (2, 0)


def test_children_are_the_same_for_the_same_seed_and_mutated_by_sigma():
    config = MuPlusOneConfig(mu=4, reevaluation=0.0)
    state = _evaluated(config, [1.0, 2.0, 3.0, 4.0])
    a = online_ask(state, config, np.random.default_rng(5))
    b = online_ask(state, config, np.random.default_rng(5))
    np.testing.assert_array_equal(a.genome, b.genome)
    state.sigma = 0.0
    c = online_ask(state, config, np.random.default_rng(5))
    # With no mutation every gene comes from one of the population's members.
    assert np.all(np.any(np.isclose(state.population, c.genome[None]), axis=0))


# ------------------------------------------------------------------------------ the robot
def test_a_network_that_spins_in_place_stops_at_the_stall_rule(library):
    env = LfDTrackEnv(track="training")
    env.reset(seed=3)
    gain, steps = drive_from_start(env, RoadDriver(library), always(1), 10, 0.05)
    env.close()
    assert steps == 10
    assert abs(gain) < 0.05


@pytest.fixture(scope="module")
def robot(library):
    r = OnboardRobot(library, world_seed=11)
    yield r
    r.close()


def test_the_robot_is_put_back_on_the_felt_and_counted(robot):
    before = robot.put_backs
    _, put = robot.drive(always(0), 60)  # straight on: off the felt at a bend or an end
    assert put >= 1
    assert robot.put_backs == before + put
    assert robot.on_felt(robot.pose)
    assert robot.steps >= 60
    assert robot.robot_s == pytest.approx(robot.steps * 0.4)


def test_put_back_faces_the_way_the_rover_faced_or_back_into_the_track_at_an_end(robot):
    track = robot.track
    s = track.length_m / 2
    point, tangent = track.point_at(s)
    robot.s, robot.pose = s, np.array([point[0], point[1], tangent + math.pi])
    x, y, heading = robot.put_back_pose()
    assert math.cos(heading - tangent) == pytest.approx(-1.0)
    assert np.hypot(x - point[0], y - point[1]) < 1e-9
    for s, facing, inward in ((track.length_m - 0.1, 0.0, -1.0), (0.1, math.pi, 1.0)):
        _, tangent = track.point_at(s)
        robot.s, robot.pose = s, np.array([0.0, 0.0, tangent + facing])
        _, _, heading = robot.put_back_pose()
        assert math.cos(heading - tangent) == pytest.approx(inward)
        assert robot.put_back_pose()[:2] == pytest.approx(
            tuple(track.point_at(track.length_m - 0.4 if inward < 0 else 0.4)[0])
        )


def test_online_evolution_counts_robot_time_stops_at_its_budget_and_repeats_per_seed(library):
    config = MuPlusOneConfig(
        mu=2, tau=3, recovery=1, evaluations=100, reevaluation=0.5, robot_budget_s=6.0
    )
    runs = [mu_plus_one_online(library, config, seed=2) for _ in range(2)]
    for run in runs:
        assert run.evaluations == 4  # 1.6 s each: the budget is passed in the fourth
        assert run.steps == 4 * (3 + 1)
        assert run.robot_s == pytest.approx(run.steps * 0.4)
        assert [p["robot_s"] for p in run.curve] == pytest.approx([1.6, 3.2, 4.8, 6.4])
        assert [p["kind"] for p in run.curve][:2] == ["initial", "initial"]
    assert [p["kind"] for p in runs[0].curve] == [p["kind"] for p in runs[1].curve]
    assert runs[0].put_backs == runs[1].put_backs


def test_direct_evolution_counts_every_drive(library):
    config = DirectConfig(population_size=2, generations=2, robot_budget_s=1e-3, stall_steps=5)
    run = direct_evolution(library, config, seed=0)
    assert run.generations == 1  # the budget is spent in the first generation
    assert run.evaluations == 2 * 2  # two individuals, one drive each way
    assert run.robot_s == pytest.approx(run.steps * 0.4)
    assert run.curve[-1]["robot_s"] == pytest.approx(run.robot_s)
    assert run.best_fitness == run.curve[-1]["best_ever"]
    assert len(run.world_seeds) == 2
