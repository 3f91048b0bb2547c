import json

import numpy as np
import pytest
from lfd_test_support import TEST_DATA

from lfd_track.errors import FileFormatError
from lfd_track.learning.ga import GAConfig, evolve
from lfd_track.policy.controller import Controller, checksum
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import synthetic_frames


@pytest.fixture(scope="module")
def trained():
    frames = synthetic_frames(np.random.default_rng(5), 14)
    library = RoadLibrary()
    values, actions = [], []
    for i, frame in enumerate(frames):
        library.learn(frame)
        values.append(library.road_values(frame))
        actions.append(i % 3)
    result = evolve(
        np.array(values), np.array(actions), GAConfig(generations=20), np.random.default_rng(2)
    )
    return Controller.from_evolution(library, result, seed=2), frames


def test_saved_and_loaded_controller_acts_identically(trained, tmp_path):
    controller, frames = trained
    path = tmp_path / "ctrl.json"
    controller.save(path)
    loaded = Controller.load(path)
    assert loaded.weights.tobytes() == controller.weights.tobytes()
    assert loaded.learner == "ga" and loaded.seed == 2
    assert loaded.learner_config == controller.learner_config == GAConfig(generations=20).to_dict()
    assert loaded.fitness_history == controller.fitness_history
    assert loaded.library.to_dict() == controller.library.to_dict()
    controller.reset()
    acts = [controller.act(f) for f in frames]
    outs = controller.last_outputs
    acts_loaded = [loaded.act(f) for f in frames]
    assert acts == acts_loaded
    np.testing.assert_array_equal(outs, loaded.last_outputs)
    assert len(set(acts)) > 1  # the comparison means something
    data = json.loads(path.read_text())
    assert data["schema_version"] == 8 and data["layer_sizes"] == [40, 5, 3]
    assert data["policy_kind"] == "mlp-sigmoid" and data["learner"] == "ga"
    assert data["checksum"] == checksum(data) and len(data["checksum"]) == 64
    assert data["bias"] is False and len(data["weights"]) == 215


def test_act_uses_road_values_mlp_and_tie_rule(trained):
    controller, frames = trained
    lib = RoadLibrary.from_dict(controller.library.to_dict())
    tie = Controller(lib, np.zeros(215))  # all outputs 0.5: every step is a tie
    assert tie.act(frames[0]) == 0  # nothing to keep yet: first index
    tie._previous = 2
    assert tie.act(frames[0]) == 2
    tie.reset()
    assert tie.act(frames[1]) == 0


def test_learn_option_grows_the_library(trained):
    controller, frames = trained
    lib = RoadLibrary()
    learning = Controller(lib, controller.weights, learn=True)
    learning.act(frames[0])
    assert lib.n_models == 1


def _saved(trained, tmp_path):
    path = tmp_path / "c.json"
    trained[0].save(path)
    return path, json.loads(path.read_text())


def _write_with_checksum(path, data):
    """An edited file that still passes the checksum (to reach the checks behind it)."""
    data["checksum"] = checksum(data)
    path.write_text(json.dumps(data))


def _expect_one_line_error(path, match):
    with pytest.raises(FileFormatError, match=match) as info:
        Controller.load(path)
    message = str(info.value)
    assert message.startswith(str(path) + ": ") and "\n" not in message
    return message


def test_truncated_file_fails_clearly(trained, tmp_path):
    path, _ = _saved(trained, tmp_path)
    text = path.read_text()
    path.write_text(text[: len(text) // 2])
    _expect_one_line_error(path, "not valid JSON")


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d["weights"].pop(), "expected 215 weights.*got 214"),
        (lambda d: d.update(schema_version=9), "schema version 9 is not supported"),
        (lambda d: d.pop("road_library"), "missing key 'road_library'"),
        (lambda d: d.update(extra=1), "unknown key 'extra'"),
        (lambda d: d.update(layer_sizes=[40, 6, 3]), "layer_sizes"),
        (lambda d: d["weights"].__setitem__(3, "x"), "weights"),
        (lambda d: d["road_library"].pop("bins"), "road library is missing key 'bins'"),
        (lambda d: d["learner_config"].update(mutation_rate=3.0), "mutation_rate"),
        (lambda d: d["learner_config"].update(bias=True), "disagrees"),
        (lambda d: d.update(format="something"), "not a controller file"),
        (lambda d: d.update(policy_kind="transformer"), "policy kind 'transformer'"),
        (lambda d: d.update(learner_config=[1]), "learner_config"),
        (lambda d: d.update(learner=""), "learner"),
        (lambda d: d["weights"].__setitem__(0, 1e300), r"within \+-1e\+06"),
        (lambda d: d["road_library"].update(types=[]), "road library is empty"),
        (lambda d: d.update(seed=-1), "seed"),
        (lambda d: d.update(fitness_history=[-1.0]), "fitness_history"),
        (
            lambda d: d["road_library"]["types"][0]["examples"][0]["model"][0].__setitem__(0, 7.0),
            r"\[0, 1\]",
        ),
        (
            lambda d: d["road_library"]["types"][0].update(selections=10**9, comparisons=1),
            "more selections than comparisons",
        ),
    ],
)
def test_edited_file_fails_clearly(trained, tmp_path, edit, match):
    path, data = _saved(trained, tmp_path)
    edit(data)
    _write_with_checksum(path, data)
    _expect_one_line_error(path, match)


def test_any_changed_digit_is_caught_by_the_checksum(trained, tmp_path):
    path, data = _saved(trained, tmp_path)
    text = path.read_text()
    rng = np.random.default_rng(0)
    digits = [i for i, ch in enumerate(text) if ch.isdigit()]
    same_value = 0
    for i in rng.choice(digits, 200, replace=False):
        new = str((int(text[i]) + int(rng.integers(1, 10))) % 10)
        path.write_text(text[:i] + new + text[i + 1 :])
        try:
            loaded = Controller.load(path)
        except FileFormatError as exc:
            assert str(exc).startswith(f"{path}: ") and "\n" not in str(exc)
            continue
        # Accepted only when the number still parses to the very same float (e.g. the 17th
        # significant digit of a weight): then the controller is unchanged.
        assert loaded.to_dict() == data
        same_value += 1
    assert same_value < 10
    # An edit with a stale checksum names the problem.
    data["weights"][0] += 0.5
    path.write_text(json.dumps(data))
    _expect_one_line_error(path, "checksum mismatch")


def test_wave_1_files_still_load(trained, tmp_path):
    path, data = _saved(trained, tmp_path)
    old = {
        k: v
        for k, v in data.items()
        if k not in ("checksum", "policy_kind", "features", "frame_size", "map_geometry")
    }
    del old["memory"]
    old["schema_version"] = 1
    old["ga_config"] = old.pop("learner_config")
    del old["learner"]
    path.write_text(json.dumps(old))
    loaded = Controller.load(path)
    assert loaded.learner == "ga" and loaded.learner_config == data["learner_config"]
    assert loaded.weights.tobytes() == trained[0].weights.tobytes()
    old["ga_config"]["bias"] = True
    path.write_text(json.dumps(old))
    _expect_one_line_error(path, "disagrees")


def test_a_file_written_by_the_first_release_loads_and_drives_the_same():
    """A real schema-1 file (tests/data/), not a new file with keys removed."""
    import cv2

    data_dir = TEST_DATA
    controller = Controller.load(data_dir / "schema1_controller.json")
    expected = json.loads((data_dir / "schema1_controller_expected.json").read_text())
    assert controller.learner == "ga" and controller.learner_config["generations"] == 5
    assert controller.library.n_models == 7
    rng = np.random.default_rng(11)
    mosaic = rng.integers(0, 256, size=(12, 16, 3), dtype=np.uint8)
    frame = cv2.resize(mosaic, (640, 480), interpolation=cv2.INTER_NEAREST)
    values = controller.library.road_values(frame, update_statistics=False)
    np.testing.assert_allclose(values, expected["road_values"], rtol=0, atol=1e-12)
    assert int(controller.act(frame)) == expected["command"]


def test_policy_does_not_import_its_trainer(tmp_path):
    import subprocess
    import sys

    code = (
        "import sys, lfd_track.policy.controller;"
        "print([m for m in sys.modules if m.startswith('lfd_track.learning')])"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_nan_weight_fails_clearly(trained, tmp_path):
    path, _ = _saved(trained, tmp_path)
    text = path.read_text()
    data = json.loads(text)
    first = json.dumps(data["weights"][0])
    path.write_text(text.replace(f'"weights":[{first}', '"weights":[NaN', 1))
    _expect_one_line_error(path, "non-finite number NaN")


def test_missing_file_fails_clearly(tmp_path):
    _expect_one_line_error(tmp_path / "nope.json", "file not found")


def test_constructor_checks_weights(trained):
    lib = trained[0].library
    with pytest.raises(ValueError, match="215"):
        Controller(lib, np.zeros(10))
    with pytest.raises(ValueError, match="NaN"):
        Controller(lib, np.full(215, np.nan))
    assert Controller(lib, np.zeros(223), bias=True).bias


def test_huge_integers_and_deep_nesting_are_one_line_errors(trained, tmp_path):
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    _expect_one_line_error(deep, "nested too deeply")
    path, data = _saved(trained, tmp_path)
    data["weights"][0] = 10**400  # valid JSON, but no float can hold it
    _write_with_checksum(path, data)
    _expect_one_line_error(path, "finite numbers")
    trained[0].save(path)
    text = path.read_text()
    assert '"seed":2,' in text
    path.write_text(text.replace('"seed":2,', '"seed":' + "7" * 5000 + ","))  # past int limit
    _expect_one_line_error(path, "not a valid controller file")


def test_fifo_device_and_folder_are_refused_without_waiting(tmp_path):
    import os

    fifo = tmp_path / "c.json"
    os.mkfifo(fifo)  # wave 1 waited forever for a writer
    _expect_one_line_error(fifo, "not a regular file")
    _expect_one_line_error("/dev/zero", "not a regular file")  # wave 1: MemoryError traceback
    _expect_one_line_error(tmp_path, "is a folder")


def test_from_evolution_refuses_an_empty_library(trained):
    controller, frames = trained
    values = np.zeros((6, 40))
    result = evolve(values, np.arange(6) % 3, GAConfig(generations=2), np.random.default_rng(0))
    with pytest.raises(ValueError, match="road library is empty"):
        Controller.from_evolution(RoadLibrary(), result)


@pytest.mark.parametrize("library", [None, "lib", {"bins": 32}])
def test_constructor_checks_the_library_type(trained, library):
    # Accepted before, then act() failed with an AttributeError deep in the perception.
    with pytest.raises(TypeError, match="library must be a RoadLibrary, got"):
        Controller(library, trained[0].weights)
    with pytest.raises(TypeError, match="library must be a RoadLibrary, got"):
        Controller.from_evolution(library, None)  # type: ignore[arg-type]


def test_constructor_checks_the_memory_type(trained):
    with pytest.raises(TypeError, match="memory must be a MemoryConfig"):
        Controller(trained[0].library, trained[0].weights, memory={"kind": "last_bend"})


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_act_on_values_refuses_non_finite_road_values(trained, bad):
    controller = trained[0]
    with pytest.raises(ValueError, match="road_values contain NaN or infinite"):
        controller.act_on_values(np.full(40, bad))
    values = np.full(40, 0.5)
    values[17] = bad
    with pytest.raises(ValueError, match="road_values contain NaN or infinite"):
        controller.act_on_values(values)


@pytest.mark.parametrize("shape", [(39,), (41,), (1, 40), ()])
def test_act_on_values_checks_the_shape(trained, shape):
    with pytest.raises(ValueError, match=r"road_values must have shape \(40,\)"):
        trained[0].act_on_values(np.zeros(shape))


def test_act_on_values_still_takes_float32_and_lists(trained):
    controller = Controller(trained[0].library, trained[0].weights)
    values = np.linspace(-0.2, 0.9, 40)
    expected = controller.act_on_values(values)
    controller.reset()
    assert controller.act_on_values(values.astype(np.float32).tolist()) == expected
