"""The last-bend memory input: the latch, its place in perception and the loop, and the files."""

import json

import numpy as np
import pytest
from lfd_test_support import library_with_road, training_track_frame

from lfd_track.core.commands import Command
from lfd_track.dataset import DemonstrationWriter, load_demonstration, save_demonstration
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.errors import FileFormatError
from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.cmaes import CMAESConfig, fit_cmaes
from lfd_track.learning.fitness import imitation_fitness, population_outputs
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import UNKNOWN_SIDE, LastBendConfig, MemoryConfig, TurnMemory
from lfd_track.policy.mlp import mlp_forward, n_weights
from lfd_track.teaching import Arbiter, Perception, QueueCommander, TeachingLoop
from lfd_track.teaching.observers import CaseBuffer

F, L, R = Command.FORWARD, Command.LEFT, Command.RIGHT
LAST_BEND = LastBendConfig()


def _side_after(commands):
    memory = TurnMemory(LastBendConfig())
    sides = []
    for c in commands:
        memory.note(c)
        sides.append(memory.side)
    return sides


def test_a_bend_is_two_net_pivots_one_way_and_a_wobble_is_none():
    assert _side_after([]) == []
    assert _side_after([L]) == [UNKNOWN_SIDE]
    assert _side_after([L, F, F, L]) == [UNKNOWN_SIDE] * 3 + [1.0]  # forwards count nothing
    assert _side_after([R, R]) == [UNKNOWN_SIDE, 0.0]
    # Alternating single pivots (a wobble on a straight) never make a bend.
    assert set(_side_after([L, R] * 10)) == set(_side_after([R, F, L] * 10)) == {UNKNOWN_SIDE}
    # ... but two right from the last peak is a right bend, whatever came before.
    assert _side_after([L, R, R]) == [UNKNOWN_SIDE, UNKNOWN_SIDE, 0.0]


def test_the_side_flips_on_a_bend_back_however_long_the_turn_before():
    turnaround = [L] * 8
    sides = _side_after([*turnaround, F, R, F, R, F, L])
    assert sides[7] == 1.0
    assert sides[9] == 1.0  # one pivot back is not yet a bend
    assert sides[11] == 0.0  # two are
    assert sides[-1] == 0.0  # a single correction after it does not flip it back
    assert _side_after([L, L]) == [UNKNOWN_SIDE, 1.0]  # a bend is two pivots


def test_reset_forgets_the_side():
    memory = TurnMemory(LAST_BEND)
    memory.note(R)
    memory.note(R)
    assert memory.inputs().tolist() == [0.0]
    memory.reset()
    assert memory.inputs().tolist() == [UNKNOWN_SIDE]


@pytest.mark.parametrize(
    ("settings", "message"),
    [
        ({"kind": "last_turns"}, "memory kind must be one of"),
        ({"kind": "last_bend", "bend_pivots": 3}, "memory bend_pivots = 3 is no longer supp"),
        ({"kind": "last_bend", "pivots": 2}, "unknown memory setting 'pivots'"),
    ],
)
def test_bad_memory_settings_are_refused_in_one_line(settings, message):
    with pytest.raises(ValueError, match=message):
        MemoryConfig.from_dict(settings)


def _frame():
    return training_track_frame()


def _library():
    return library_with_road()[0]


def test_perception_appends_the_memory_to_the_road_values():
    plain = Perception(_library(), "frozen").perceive(_frame())
    assert plain.inputs is plain.values and plain.memory.shape == (0,)
    perception = Perception(_library(), "frozen", LAST_BEND)
    assert perception.n_inputs == 41
    percept = perception.perceive(_frame())
    np.testing.assert_array_equal(percept.inputs[:40], plain.values)
    assert percept.inputs[40] == UNKNOWN_SIDE
    perception.note(L)
    perception.note(L)
    assert perception.perceive(_frame()).inputs[40] == 1.0
    perception.start_episode()
    assert perception.perceive(_frame()).inputs[40] == UNKNOWN_SIDE


def test_the_loop_feeds_the_memory_executed_commands_and_records_it():
    """The memory follows what the loop executed, and every case carries the memory it saw."""
    env = LfDTrackEnv(track="training", max_steps=50)
    human = QueueCommander()
    buffer = CaseBuffer(41)
    loop = TeachingLoop(
        env,
        Perception(_library(), "frozen", LAST_BEND),
        Arbiter("human"),
        human=human,
        observers=[buffer],
    )
    loop.reset(seed=3)
    for command in (R, R, F, L, L):
        human.push(command)
        step = loop.step()
        assert step.moment.inputs is not None and len(step.moment.inputs) == 41
    x, a = buffer.arrays()
    assert x.shape == (5, 41)
    assert a.tolist() == [2, 2, 0, 1, 1]
    # Seen before each command: nothing, one right, a right bend, still right, one left back.
    assert x[:, 40].tolist() == [UNKNOWN_SIDE, UNKNOWN_SIDE, 0.0, 0.0, 0.0]
    human.push(F)
    assert loop.step().percept.memory.tolist() == [1.0]  # the two lefts made a left bend
    loop.reset(seed=3)
    human.push(F)
    assert loop.step().percept.memory.tolist() == [UNKNOWN_SIDE]  # a new episode forgets
    env.close()


def test_learners_take_the_extra_input():
    rng = np.random.default_rng(0)
    x = rng.uniform(0, 1, (60, 41))
    a = (x[:, 40] > 0.5).astype(int) + 1  # the command is the memory side: left or right
    result = evolve(x, a, GAConfig(generations=5), np.random.default_rng(1))
    assert result.best_weights.shape == (n_weights(False, 41),) == (220,)
    bc = fit_bc(x, a, BCConfig(epochs=3), np.random.default_rng(1))
    assert bc.weights.shape == (220,)
    cma = fit_cmaes(x, a, CMAESConfig(generations=2), np.random.default_rng(1))
    assert cma.weights.shape == (220,)
    with pytest.raises(ValueError, match="for 41 inputs"):
        mlp_forward(np.zeros(215), x)


@pytest.mark.parametrize(("p", "n", "bias"), [(40, 151, False), (40, 150, True), (3, 13, False)])
def test_the_fitness_kernel_matches_the_network_bit_for_bit_with_memory(p, n, bias):
    rng = np.random.default_rng(p + n)
    w = rng.uniform(-3, 3, (p, n_weights(bias, 41)))
    x = rng.uniform(-0.1, 1, (n, 41))
    np.testing.assert_array_equal(population_outputs(w, x, bias=bias), mlp_forward(w, x))
    a = rng.integers(0, 3, n)
    single = [imitation_fitness(w[i : i + 1], x, a, bias=bias)[0] for i in range(p)]
    np.testing.assert_allclose(imitation_fitness(w, x, a, bias=bias), single, rtol=0, atol=1e-15)


def _write_demo(path, n_memory, memory_rows):
    rng = np.random.default_rng(2)
    with DemonstrationWriter(path, {"kind": "test"}, bins=4, fsync=False, n_memory=n_memory) as w:
        for row in memory_rows:
            hists = rng.uniform(0, 0.2, (40, 5, 4))
            w.append(1, rng.uniform(0, 1, 40), hists, memory=row)


def test_demonstrations_carry_memory_inputs(tmp_path):
    path = tmp_path / "m.lfdemo"
    _write_demo(path, 1, [[0.5], [1.0], [0.0]])
    demo = load_demonstration(path)
    assert demo.metadata["schema_version"] == 4  # memory inputs, records numbered
    assert demo.memory.tolist() == [[0.5], [1.0], [0.0]]
    assert demo.inputs.shape == (3, 41)
    np.testing.assert_array_equal(demo.inputs[:, :40], demo.road_values)
    copy = tmp_path / "copy.lfdemo"
    save_demonstration(copy, demo)
    again = load_demonstration(copy)
    np.testing.assert_array_equal(again.inputs, demo.inputs)

    plain = tmp_path / "plain.lfdemo"
    _write_demo(plain, 0, [None, None])
    old = load_demonstration(plain)
    assert old.metadata["schema_version"] == 4  # no memory: n_memory 0
    assert old.memory.shape == (2, 0) and old.inputs is old.road_values


def test_bad_memory_in_a_demonstration_is_refused(tmp_path):
    with pytest.raises(ValueError, match="memory must hold 1 inputs"):
        _write_demo(tmp_path / "a.lfdemo", 1, [None])
    with pytest.raises(ValueError, match=r"memory inputs must lie in \[0, 1\]"):
        _write_demo(tmp_path / "b.lfdemo", 1, [[2.0]])
    path = tmp_path / "c.lfdemo"
    _write_demo(path, 1, [[1.0]])
    data = bytearray(path.read_bytes())
    header_end = data.index(b"}", data.index(b'"n_memory"'))
    marker = data.index(b'"n_memory":1', 0, header_end + 50)
    data[marker : marker + 12] = b'"n_memory":0'  # same length; the header CRC now fails
    path.write_bytes(bytes(data))
    with pytest.raises(FileFormatError, match="c.lfdemo"):
        load_demonstration(path)


def _memory_controller(weights=None):
    w = np.zeros(n_weights(False, 41)) if weights is None else weights
    return Controller(_library(), w, memory=LAST_BEND, learner="ga")


def test_a_memory_controller_saves_its_memory_and_loads(tmp_path):
    rng = np.random.default_rng(5)
    controller = _memory_controller(rng.uniform(-1, 1, 220))
    path = tmp_path / "c.json"
    controller.save(path)
    data = json.loads(path.read_text())
    assert data["schema_version"] == 8 and data["layer_sizes"] == [41, 5, 3]
    assert data["memory"] == {"kind": "last_bend"}
    loaded = Controller.load(path)
    assert loaded.memory == LAST_BEND and loaded.n_inputs == 41
    np.testing.assert_array_equal(loaded.weights, controller.weights)
    assert loaded.perception().n_inputs == 41

    data["memory"] = {"kind": "none"}
    path.write_text(json.dumps(data))
    with pytest.raises(FileFormatError, match="checksum mismatch"):
        Controller.load(path)
    with pytest.raises(ValueError, match="expected 215 weights for 40 inputs"):
        Controller(_library(), np.zeros(220))


def test_a_memory_controller_acts_on_its_own_commands():
    """Weights that turn the way the memory says: from 'unknown' (0.5) the net turns left."""
    w = np.zeros(220)
    # Hidden node 0 reads only the memory input; outputs: left = +h0, right = -h0 (forward 0).
    w[40] = 20.0
    w5 = 5 * 41
    w[w5 + 1 * 5 + 0] = 4.0
    w[w5 + 2 * 5 + 0] = -4.0
    controller = _memory_controller(w)
    frame = _frame()
    first = controller.act(frame)
    assert first == Command.LEFT  # memory 0.5 → h0 = sigmoid(10) → left wins
    second = controller.act(frame)
    assert second == Command.LEFT
    assert controller._act_perception.perceive(frame).memory.tolist() == [1.0]
    controller.reset()
    assert controller._act_perception.perceive(frame).memory.tolist() == [UNKNOWN_SIDE]


def test_turn_arounds_toward_the_last_bend_record_the_memory(tmp_path):
    """On the training track the last bend before each end alternates right, left, ...; the
    demonstration's cases carry the memory, and a turn-around is made toward the side it holds."""
    from lfd_track.demo.demonstrator import HumanConfig, run_demonstration

    path = tmp_path / "d.lfdemo"
    summary = run_demonstration(
        path,
        seed=0,
        human=HumanConfig(turnarounds="toward_last_bend"),
        fsync=False,
        memory=LAST_BEND,
    )
    assert summary.turnarounds == ("right", "left", "right", "left")
    demo = load_demonstration(path)
    assert demo.metadata["memory"] == LAST_BEND.to_dict()
    turning = demo.phases == "turnaround"
    side = {Command.LEFT: 1.0, Command.RIGHT: 0.0}
    # From its second command on, a turn-around's cases see the side it turns to.
    for i in np.flatnonzero(turning[1:] & turning[:-1]) + 1:
        assert demo.memory[i, 0] == side[Command(int(demo.commands[i]))]


def test_runs_without_memory_store_the_settings_they_stored_before():
    """Resuming a study finished before memory inputs existed must find the same settings."""
    from lfd_track.benchmark.runner import BenchmarkConfig, config_dict

    assert config_dict(BenchmarkConfig())["memory"] == {"kind": "none"}  # every setting written
    assert config_dict(BenchmarkConfig(memory=LAST_BEND))["memory"] == LAST_BEND.to_dict()


def test_a_reset_in_place_keeps_the_memory():
    """A real robot re-armed where it stopped (``keep_memory``) goes on with the same memory; a
    plain reset (a new run) forgets it."""
    env = LfDTrackEnv(track="training", max_steps=50)
    human = QueueCommander()
    loop = TeachingLoop(
        env, Perception(_library(), "frozen", LAST_BEND), Arbiter("human"), human=human
    )
    loop.reset(seed=3)
    for command in (L, L):
        human.push(command)
        loop.step()
    loop.reset(keep_memory=True)
    human.push(F)
    assert loop.step().percept.memory.tolist() == [1.0]
    loop.reset()
    human.push(F)
    assert loop.step().percept.memory.tolist() == [UNKNOWN_SIDE]
    env.close()


@pytest.mark.parametrize(
    ("schema", "extra", "problem"),
    [
        (2, {"n_memory": 1}, "a schema 2 header cannot declare n_memory"),
        (3, {}, "header n_memory must be an integer in 1..16, got None"),
        (3, {"n_memory": 0}, "header n_memory must be an integer in 1..16, got 0"),
        (3, {"n_memory": True}, "header n_memory must be an integer in 1..16, got True"),
    ],
)
def test_a_header_must_declare_memory_inputs_exactly_when_schema_3(
    tmp_path, schema, extra, problem
):
    from lfd_track.dataset import records as dataset

    header = {
        "format": dataset.FORMAT_NAME,
        "schema": schema,
        "bins": 4,
        "n_values": 40,
        "n_channels": 5,
        "metadata": {},
        "initial_road_library": None,
        **extra,
    }
    path = tmp_path / "h.lfdemo"
    record = dataset._frame(dataset._KIND_HEADER, dataset._json_bytes(header, "header"))
    path.write_bytes(dataset._MAGIC + record)
    with pytest.raises(FileFormatError, match=problem) as error:
        load_demonstration(path)
    assert "h.lfdemo" in str(error.value) and "\n" not in str(error.value)
