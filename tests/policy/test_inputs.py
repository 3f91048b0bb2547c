"""The policy's input options: the colour features per region, the two ``near_felt`` inputs and
the previous-command memory.

Each is computed the same way for a recorded case and for a driving frame, every learner fits
it, and the controller file records it, so a reloaded controller decides the same.
"""

from __future__ import annotations

import json
import re

import cv2
import numpy as np
import pytest

from lfd_track.dataset import load_demonstration
from lfd_track.dataset.recording import recording_writer
from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.cmaes import CMAESConfig, fit_cmaes
from lfd_track.learning.fitness import training_accuracy
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.learning.mirror import mirror_cases
from lfd_track.policy.controller import Controller
from lfd_track.policy.features import (
    colour_features,
    frame_inputs,
    mirror_frame_inputs,
    near_felt_features,
)
from lfd_track.policy.memory import PreviousCommandConfig, PreviousCommandMemory, memory_config
from lfd_track.teaching.perception import Perception
from lfd_track.vision.histograms import N_CHANNELS
from lfd_track.vision.synthetic import patch_library, synthetic_frames

COLOUR = "road_values+colour"
PREVIOUS = PreviousCommandConfig()


@pytest.fixture(scope="module")
def frames() -> list[np.ndarray]:
    return synthetic_frames(np.random.default_rng(0), 6)


@pytest.fixture(scope="module")
def library(frames):
    return patch_library(frames, 32, np.random.default_rng(1))


# ------------------------------------------------------------------------- colour features
def test_mean_hue_is_circular_red_either_side_of_zero_averages_to_red():
    h = np.zeros((40, N_CHANNELS, 32))
    h[:, 3, 0] = 1.0  # hue just above 0
    h[:, 3, 31] = 1.0  # hue just below 180 (360 degrees)
    h[:, 4, 31] = 1.0  # fully saturated
    f = colour_features(h)
    cos, sin, sat = f[:40], f[40:80], f[80:]
    np.testing.assert_allclose(cos, (1 + np.cos(np.pi / 32)) / 2)  # red: cos near 1
    np.testing.assert_allclose(sin, 0.5, atol=1e-12)  # the two sides cancel
    np.testing.assert_allclose(sat, 31.5 / 32)


def test_a_flat_histogram_gives_the_middle_of_every_feature():
    f = colour_features(np.zeros((2, 40, N_CHANNELS, 8)))  # min-max normalised flat: all zeros
    assert f.shape == (2, 120)
    np.testing.assert_array_equal(f, 0.5)


def test_colour_features_match_the_pixels_means_to_the_bin_width(frames, library):
    for frame in frames[:3]:
        f = colour_features(library.region_histograms(frame))
        hsv = cv2.cvtColor(frame, cv2.COLOR_RGB2HSV).astype(np.float64)
        exact = []
        for region in range(40):
            row, col = divmod(region, 8)
            block = hsv[row * 96 : (row + 1) * 96, col * 80 : (col + 1) * 80]
            angle = block[..., 0] * np.pi / 90
            exact.append(
                (
                    (1 + np.cos(angle).mean()) / 2,
                    (1 + np.sin(angle).mean()) / 2,
                    block[..., 1].mean(),
                )
            )
        exact = np.array(exact)
        exact[:, 2] /= 256
        # Within the quantisation of 32 bins and the min-max normalisation's floor.
        np.testing.assert_allclose(f, exact.T.reshape(-1), atol=0.05)
        assert np.all((f >= 0) & (f <= 1))


def test_recorded_cases_and_driving_frames_get_the_same_inputs(tmp_path, frames, library):
    perception = Perception(library, "frozen", PREVIOUS, COLOUR)
    assert perception.n_inputs == 163
    writer = recording_writer(tmp_path / "d.lfdemo", {}, perception, fsync=False)
    seen = []
    for i, frame in enumerate(frames):
        percept = perception.perceive(frame)
        command = i % 3
        writer.append(command, percept.values, percept.histograms, memory=percept.memory)
        perception.note(command)
        seen.append(percept.inputs)
    writer.close()
    demo = load_demonstration(tmp_path / "d.lfdemo")
    assert demo.memory_settings() == PREVIOUS
    np.testing.assert_allclose(demo.policy_inputs(COLOUR), np.stack(seen), rtol=0, atol=1e-12)
    np.testing.assert_array_equal(demo.policy_inputs(), demo.inputs)  # the default: as before
    # Teacher forcing: each case's memory is the one-hot of the command executed before it.
    np.testing.assert_array_equal(demo.memory[0], [0, 0, 0])
    np.testing.assert_array_equal(np.argmax(demo.memory[1:], axis=1), demo.commands[:-1])


def test_a_recording_without_memory_still_yields_colour_features(tmp_path, frames, library):
    perception = Perception(library, "frozen")
    writer = recording_writer(tmp_path / "d.lfdemo", {}, perception, fsync=False)
    percept = perception.perceive(frames[0])
    writer.append(0, percept.values, percept.histograms)
    writer.close()
    x = load_demonstration(tmp_path / "d.lfdemo").policy_inputs(COLOUR)
    assert x.shape == (1, 160)
    np.testing.assert_allclose(x[0, 40:], colour_features(percept.histograms), atol=1e-12)


def test_mirror_reverses_every_block_and_swaps_the_previous_command(frames, library):
    perception = Perception(library, "frozen", PREVIOUS, COLOUR)
    perception.note(1)  # left
    x = perception.perceive(frames[0]).inputs[None]
    flipped = Perception(library, "frozen", PREVIOUS, COLOUR)
    flipped.note(2)  # right
    expected = flipped.perceive(np.ascontiguousarray(frames[0][:, ::-1])).inputs
    mirrored, actions = mirror_cases(x, [1], PREVIOUS, COLOUR)
    np.testing.assert_allclose(mirrored[0], expected, atol=1e-9)
    assert actions.tolist() == [2]
    with pytest.raises(ValueError, match=r"\(N, 163\) for memory 'previous_command'"):
        mirror_cases(x[:, :160], [1], PREVIOUS, COLOUR)


# ------------------------------------------------------------------------- near_felt
def _grid(near: list[list[float]]) -> np.ndarray:
    """Road values (40,): carpet (0.2) everywhere but the two nearest rows given (2 x 8)."""
    grid = np.full((5, 8), 0.2)
    grid[3:] = near
    return grid.reshape(40)


def test_near_felt_says_where_the_felt_lies_across_the_nearest_rows_and_how_much():
    felt, carpet = 0.6, 0.2
    # Felt in the two leftmost columns of both near rows: left of the axis, a quarter of them.
    left = _grid([[felt, felt] + [carpet] * 6] * 2)
    position, amount = near_felt_features(left)
    assert position == pytest.approx(0.5 * (1 + (7 / 8 + 5 / 8) / 2))
    assert amount == pytest.approx(0.25)
    # Its mirror image lies as far right; centred felt lies straight ahead.
    assert near_felt_features(_grid([[carpet] * 6 + [felt, felt]] * 2))[0] == pytest.approx(
        1 - position
    )
    centred = near_felt_features(_grid([[carpet] * 3 + [felt, felt] + [carpet] * 3] * 2))
    assert centred[0] == pytest.approx(0.5)
    # No felt in the near rows (felt further up does not count): the middle, nothing.
    far = np.full((5, 8), carpet)
    far[0] = felt
    np.testing.assert_array_equal(near_felt_features(far.reshape(40)), [0.5, 0.0])
    # Felt levels rise from 0 at road value 0.3 to 1 at 0.5: half-felt counts half.
    half = near_felt_features(_grid([[0.4] * 8] * 2))
    np.testing.assert_allclose(half, [0.5, 0.5], atol=1e-12)
    # Batches work row by row.
    batch = near_felt_features(np.stack([left, far.reshape(40)]))
    np.testing.assert_allclose(batch[0], near_felt_features(left), atol=0)
    assert frame_inputs("near_felt") == 2


def test_near_felt_of_a_mirrored_frame_is_the_mirrored_input(frames, library):
    perception = Perception(library, "frozen", PREVIOUS, "near_felt")
    assert perception.n_inputs == 5
    perception.note(1)
    x = perception.perceive(frames[0]).inputs[None]
    flipped = Perception(library, "frozen", PREVIOUS, "near_felt")
    flipped.note(2)
    expected = flipped.perceive(np.ascontiguousarray(frames[0][:, ::-1])).inputs
    mirrored, actions = mirror_cases(x, [1], PREVIOUS, "near_felt")
    np.testing.assert_allclose(mirrored[0], expected, atol=1e-9)
    assert actions.tolist() == [2]
    np.testing.assert_allclose(
        mirror_frame_inputs(x[:, :2], "near_felt")[0], [1 - x[0, 0], x[0, 1]], atol=0
    )


def test_near_felt_of_a_recorded_case_is_what_the_driving_frame_read(tmp_path, frames, library):
    perception = Perception(library, "frozen", PREVIOUS, "near_felt")
    writer = recording_writer(tmp_path / "d.lfdemo", {}, perception, fsync=False)
    seen = []
    for i, frame in enumerate(frames):
        percept = perception.perceive(frame)
        assert percept.inputs.shape == (5,)
        np.testing.assert_array_equal(percept.inputs[:2], near_felt_features(percept.values))
        writer.append(i % 3, percept.values, percept.histograms, memory=percept.memory)
        perception.note(i % 3)
        seen.append(percept.inputs)
    writer.close()
    demo = load_demonstration(tmp_path / "d.lfdemo")
    np.testing.assert_allclose(demo.policy_inputs("near_felt"), np.stack(seen), rtol=0, atol=1e-12)
    # A controller reading them drives the frames as the same network on those inputs.
    weights = np.random.default_rng(5).uniform(-3, 3, 5 * 5 + 15)
    controller = Controller(library, weights, features="near_felt", memory=PREVIOUS)
    commands = [controller.act(f) for f in frames]
    twin = Controller(library, weights, features="near_felt", memory=PREVIOUS)
    replay = Perception(library, "frozen", PREVIOUS, "near_felt")
    assert commands == _drive_by_hand(twin, replay, frames)
    loaded = Controller.load(_save(tmp_path, controller))
    assert loaded.features == "near_felt" and loaded.n_inputs == 5
    assert [loaded.act(f) for f in frames] == commands
    with pytest.raises(ValueError, match="the two near_felt inputs, then the memory inputs"):
        controller.act_on_values(np.zeros(3))


# --------------------------------------------------------------------------------- memory
def test_previous_command_memory_is_the_last_executed_command():
    memory = PreviousCommandMemory(PREVIOUS)
    np.testing.assert_array_equal(memory.inputs(), [0, 0, 0])
    memory.note(2)
    np.testing.assert_array_equal(memory.inputs(), [0, 0, 1])
    memory.note(0)
    np.testing.assert_array_equal(memory.inputs(), [1, 0, 0])
    memory.reset()
    np.testing.assert_array_equal(memory.inputs(), [0, 0, 0])
    assert PREVIOUS.n_inputs == 3
    with pytest.raises(ValueError, match="memory kind must be one of"):
        memory_config({"kind": "previous_output"})


# ------------------------------------------------------------------ learners and the file
def _synthetic_cases(kind: str, n: int = 90) -> tuple[np.ndarray, np.ndarray]:
    """Cases whose command only the new inputs can tell: the road values are noise."""
    rng = np.random.default_rng(7)
    actions = rng.integers(0, 3, n)
    x = rng.uniform(0, 1, (n, frame_inputs(COLOUR) if kind != "memory" else 40))
    if kind == "memory_only":  # no per-region inputs: the memory alone
        x = x[:, :0]
    if kind in ("colour", "both"):
        x[:, 80:120] = 0.2  # the hue sin block says the command
        x[:, 80:120] += 0.3 * actions[:, None]
    if kind in ("memory", "both", "memory_only"):
        previous = np.eye(3)[actions]
        x = np.hstack([x, previous])
    return x, actions


def _settings(kind: str) -> dict:
    return {
        "colour": {"features": COLOUR},
        "memory": {"memory": PREVIOUS},
        "both": {"features": COLOUR, "memory": PREVIOUS},
        "memory_only": {"features": "none", "memory": PREVIOUS},
    }[kind]


def _check_round_trip(tmp_path, controller: Controller, x: np.ndarray) -> Controller:
    path = tmp_path / "c.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.features == controller.features
    assert loaded.memory == controller.memory
    np.testing.assert_array_equal(loaded.weights, controller.weights)
    assert [loaded.act_on_values(v) for v in x] == [controller.act_on_values(v) for v in x]
    return loaded


@pytest.mark.parametrize("kind", ["colour", "memory", "both", "memory_only"])
def test_the_ga_learns_the_new_inputs_and_the_file_keeps_them(tmp_path, library, kind):
    x, a = _synthetic_cases(kind)
    result = evolve(x, a, GAConfig(generations=60), np.random.default_rng(0))
    controller = Controller.from_evolution(library, result, seed=0, **_settings(kind))
    assert controller.n_inputs == x.shape[1]
    assert training_accuracy(controller.weights, x, a) >= 0.7
    _check_round_trip(tmp_path, controller, x)


@pytest.mark.parametrize("kind", ["colour", "memory", "both", "memory_only"])
def test_bc_learns_the_new_inputs_and_the_file_keeps_them(tmp_path, library, kind):
    x, a = _synthetic_cases(kind)
    fit = fit_bc(x, a, BCConfig(epochs=400, learning_rate=0.05), np.random.default_rng(0))
    assert training_accuracy(fit.weights, x, a) >= 0.95
    controller = Controller(library, fit.weights, learner="bc", **_settings(kind))
    _check_round_trip(tmp_path, controller, x)


def test_cma_es_learns_the_colour_features(tmp_path, library):
    pytest.importorskip("cma")
    x, a = _synthetic_cases("both", n=45)
    fit = fit_cmaes(x, a, CMAESConfig(population_size=12, generations=40), np.random.default_rng(0))
    assert training_accuracy(fit.weights, x, a) >= 0.6
    controller = Controller(library, fit.weights, learner="cma-es", **_settings("both"))
    _check_round_trip(tmp_path, controller, x)


def test_the_file_records_every_option(tmp_path, library):
    w40 = np.zeros(215)
    plain = Controller(library, w40).to_dict()
    assert plain["schema_version"] == 8 and plain["features"] == "road_values"
    assert plain["memory"] is None
    memory = Controller(library, np.zeros(5 * 43 + 15), memory=PREVIOUS).to_dict()
    assert memory["schema_version"] == 8 and memory["features"] == "road_values"
    assert memory["memory"] == {"kind": "previous_command"}
    colour = Controller(library, np.zeros(5 * 160 + 15), features=COLOUR).to_dict()
    assert colour["schema_version"] == 8
    assert colour["features"] == COLOUR and colour["memory"] is None
    assert colour["layer_sizes"] == [160, 5, 3]
    both = Controller(library, np.zeros(5 * 163 + 15), features=COLOUR, memory=PREVIOUS)
    assert both.to_dict()["layer_sizes"] == [163, 5, 3]
    with pytest.raises(ValueError, match="expected 815 weights for 160 inputs"):
        Controller(library, w40, features=COLOUR)
    with pytest.raises(ValueError, match="features must be one of"):
        Controller(library, w40, features="colour")
    alone = Controller(library, np.zeros(5 * 3 + 15), features="none", memory=PREVIOUS).to_dict()
    assert alone["schema_version"] == 8 and alone["features"] == "none"
    assert alone["layer_sizes"] == [3, 5, 3] and alone["memory"]["kind"] == "previous_command"
    with pytest.raises(ValueError, match="features 'none' .* needs a memory"):
        Controller(library, np.zeros(15), features="none")


def test_a_damaged_file_is_refused_in_one_line(tmp_path, library):
    from lfd_track.errors import FileFormatError
    from lfd_track.policy.controller import checksum

    good = Controller(library, np.zeros(5 * 160 + 15), features=COLOUR).to_dict()
    for change, message in [
        ({"features": "road_values+depth"}, "features 'road_values+depth' are not supported"),
        ({"memory": {"kind": "none"}}, "stores null as its memory"),
        ({"memory": {"kind": "last_bend", "bend_pivots": 0}}, "memory bend_pivots = 0 is no"),
        ({"layer_sizes": [40, 5, 3]}, "expected [160, 5, 3]"),
        ({"features": "none", "layer_sizes": [0, 5, 3]}, "it needs a memory"),
    ]:
        data = {**good, **change}
        data["checksum"] = checksum(data)
        path = tmp_path / "bad.json"
        path.write_text(json.dumps(data))
        with pytest.raises(FileFormatError, match=re.escape(message)):
            Controller.load(path)


def test_a_controller_drives_frames_with_the_inputs_it_was_trained_on(tmp_path, frames, library):
    """act(frame) reads the colour features and feeds back its own commands."""
    rng = np.random.default_rng(3)
    weights = rng.uniform(-1, 1, 5 * 163 + 15)
    controller = Controller(library, weights, features=COLOUR, memory=PREVIOUS)
    commands = [controller.act(f) for f in frames]
    # The same by hand: perception with the same options, the executed command noted.
    perception = Perception(library, "frozen", PREVIOUS, COLOUR)
    twin = Controller(library, weights, features=COLOUR, memory=PREVIOUS)
    assert commands == _drive_by_hand(twin, perception, frames)
    loaded = Controller.load(_save(tmp_path, controller))
    assert [loaded.act(f) for f in frames] == commands


def test_a_controller_reading_its_memory_alone_drives_frames_by_it(tmp_path, frames, library):
    """Features "none": the network reads the memory inputs only (here the previous command),
    the road values still computed for the library but not fed to the network."""
    rng = np.random.default_rng(4)
    weights = rng.uniform(-3, 3, 5 * 3 + 15)
    controller = Controller(library, weights, features="none", memory=PREVIOUS)
    commands = [controller.act(f) for f in frames]
    perception = Perception(library, "frozen", PREVIOUS, "none")
    assert perception.n_inputs == 3
    twin = Controller(library, weights, features="none", memory=PREVIOUS)
    assert commands == _drive_by_hand(twin, perception, frames, n_inputs=3)
    loaded = Controller.load(_save(tmp_path, controller))
    assert loaded.features == "none" and loaded.n_inputs == 3
    assert [loaded.act(f) for f in frames] == commands
    with pytest.raises(ValueError, match="features 'none' .* set a memory kind"):
        Perception(library, "frozen", None, "none")
    x = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    mx, ma = mirror_cases(x, np.array([1, 2]), PREVIOUS, "none")  # no per-region block
    np.testing.assert_array_equal(mx, [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0]])
    assert ma.tolist() == [2, 1]


def _drive_by_hand(
    twin: Controller, perception: Perception, frames, n_inputs: int | None = None
) -> list[int]:
    """The commands of ``twin`` fed ``perception``'s inputs frame by frame, each command noted
    as executed (what ``Controller.act`` does inside); checks the inputs' length if given."""
    commands = []
    for frame in frames:
        percept = perception.perceive(frame)
        if n_inputs is not None:
            assert percept.inputs.shape == (n_inputs,) and percept.values.shape == (40,)
        commands.append(twin.act_on_values(percept.inputs))
        perception.note(commands[-1])
    return commands


def _save(tmp_path, controller: Controller):
    path = tmp_path / "drive.json"
    controller.save(path)
    return path


# ----------------------------------------------------------------- study and benchmark
def test_a_study_condition_selects_the_features_and_the_learned_memory(tmp_path):
    from lfd_track.benchmark.runner import config_dict
    from lfd_track.errors import FileFormatError
    from lfd_track.study.spec import load_study

    base = """[study]
seeds = [0]
repetitions = 1

[[conditions]]
name = "colour"
method = "bc"
features = "road_values+colour"
[conditions.memory]
kind = "previous_command"

[[conditions]]
name = "paper"
"""
    path = tmp_path / "s.toml"
    path.write_text(base)
    colour, paper = load_study(path, check_names=False).conditions
    assert colour.config.features == "road_values+colour"
    assert colour.config.memory == PREVIOUS
    assert config_dict(colour.config)["features"] == "road_values+colour"
    assert config_dict(paper.config)["features"] == "road_values"  # every setting is written
    path.write_text(base.replace('"road_values+colour"', '"colours"'))
    with pytest.raises(FileFormatError, match="features must be one of"):
        load_study(path, check_names=False)
    path.write_text(
        base.replace('"road_values+colour"', '"none"').replace("previous_command", "none")
    )
    with pytest.raises(FileFormatError, match="features 'none' .* set a memory kind"):
        load_study(path, check_names=False)
