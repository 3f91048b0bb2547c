"""Backprop's ensemble (``BCConfig.ensemble``): k networks fitted to the same cases from their
own starting weights, driving by the mean of their outputs; its controller file and commander."""

import json

import numpy as np
import pytest

from lfd_track.errors import FileFormatError
from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.elman import fit_bc_elman
from lfd_track.learning.fitness import training_accuracy
from lfd_track.policy.controller import Controller, checksum
from lfd_track.policy.mlp import MAX_MEMBERS, ensemble_forward, mlp_forward, n_weights
from lfd_track.teaching.commanders import PolicyCommander
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import synthetic_frames

TOL = 1e-9
"""Floats computed two ways (one fit, or the first of an ensemble's) agree this closely."""


def _cases(n: int = 60) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(3)
    x = rng.random((n, 4))
    a = np.where(x[:, 0] > 0.6, 1, np.where(x[:, 0] < 0.4, 2, 0))
    return x, a


def test_an_ensemble_is_k_fits_whose_first_is_the_single_fit():
    x, a = _cases()
    config = BCConfig(epochs=150, bias=True)
    single = fit_bc(x, a, config, np.random.default_rng(7))
    three = fit_bc(x, a, BCConfig(epochs=150, bias=True, ensemble=3), np.random.default_rng(7))
    assert single.weights.shape == (n_weights(True, 4),)
    assert three.weights.shape == (3, n_weights(True, 4))
    np.testing.assert_allclose(three.weights[0], single.weights, rtol=0, atol=TOL)
    assert not np.allclose(three.weights[1], three.weights[0])  # its own starting weights
    assert three.history.shape == (150,) and three.fitness == three.history[-1]
    assert three.config["ensemble"] == 3 and "ensemble" not in single.config


def test_the_ensemble_setting_is_checked_and_left_out_of_files_at_one():
    assert "ensemble" not in BCConfig().to_dict()
    assert BCConfig.from_dict({"ensemble": 5}).ensemble == 5
    for wrong in (0, MAX_MEMBERS + 1, 2.5, True):
        with pytest.raises(ValueError, match="ensemble"):
            BCConfig(ensemble=wrong)


def test_an_ensemble_drives_by_the_mean_of_its_outputs():
    x, a = _cases()
    weights = fit_bc(x, a, BCConfig(epochs=100, bias=True, ensemble=4), np.random.default_rng(1))
    w = weights.weights
    mean = mlp_forward(w, x).mean(axis=0)  # (4, N, 3) -> (N, 3)
    np.testing.assert_allclose(ensemble_forward(w, x), mean, rtol=0, atol=TOL)
    np.testing.assert_allclose(ensemble_forward(w[0], x), mlp_forward(w[0], x), rtol=0, atol=TOL)
    decided = mean.argmax(axis=1)
    assert training_accuracy(w, x, a) == pytest.approx(float((decided == a).mean()))
    commander = PolicyCommander(w)
    for row, expected in zip(x, decided, strict=True):
        if np.sort(ensemble_forward(w, row))[-2] < ensemble_forward(w, row).max() - 1e-6:
            assert int(commander.act_on_values(row)) == expected


@pytest.fixture(scope="module")
def library_and_frames():
    frames = synthetic_frames(np.random.default_rng(5), 8)
    library = RoadLibrary()
    for frame in frames:
        library.learn(frame)
    return library, frames


def test_an_ensemble_controller_saves_loads_and_acts_alike(library_and_frames, tmp_path):
    library, frames = library_and_frames
    rng = np.random.default_rng(4)
    weights = rng.uniform(-2, 2, (3, 215))
    controller = Controller(library, weights, learner="bc", learner_config={"ensemble": 3})
    assert controller.members == 3
    path = tmp_path / "ensemble.json"
    controller.save(path)
    data = json.loads(path.read_text())
    assert data["schema_version"] == 8 and len(data["weights"]) == 3
    assert all(len(w) == 215 for w in data["weights"])
    loaded = Controller.load(path)
    assert loaded.members == 3
    assert loaded.weights.tobytes() == controller.weights.tobytes()
    acts = [controller.act(f) for f in frames]
    assert acts == [loaded.act(f) for f in frames]
    values = [library.road_values(f) for f in frames]
    expected = [int(np.argmax(mlp_forward(weights, v).mean(axis=0))) for v in values]
    assert acts == expected
    one = Controller(library, weights[:1])  # an ensemble of one is its network
    assert one.members == 1 and one.weights.shape == (215,)


def _edited(path, data, edit):
    edit(data)
    data["checksum"] = checksum(data)
    path.write_text(json.dumps(data))


@pytest.mark.parametrize(
    "edit, match",
    [
        (lambda d: d["weights"][1].pop(), "expected 215 weights.*got 214 .network 2 of 2."),
        (lambda d: d["weights"].__setitem__(1, 0.5), "list of finite numbers"),
        (lambda d: d["weights"][0].__setitem__(0, 1e300), r"within \+-1e\+06"),
        (lambda d: d.update(weights=[[0.0] * 215] * (MAX_MEMBERS + 1)), "1..64 networks"),
        (lambda d: d.update(schema_version=7), "a schema 7 controller holds one network"),
        (
            lambda d: (d.pop("map_geometry"), d.update(schema_version=6)),
            "a schema 6 controller holds one network",
        ),
        (
            lambda d: d.update(
                policy_kind="elman-sigmoid", layer_sizes=[45, 5, 3], weights=[[0.0] * 240] * 2
            ),
            "an Elman network is one network",
        ),
    ],
)
def test_a_damaged_ensemble_file_fails_in_one_line(library_and_frames, tmp_path, edit, match):
    library, _ = library_and_frames
    path = tmp_path / "ensemble.json"
    Controller(library, np.zeros((2, 215))).save(path)
    _edited(path, json.loads(path.read_text()), edit)
    with pytest.raises(FileFormatError, match=match) as info:
        Controller.load(path)
    assert str(info.value).startswith(f"{path}: ") and "\n" not in str(info.value)


def test_constructing_a_wrong_ensemble_is_refused(library_and_frames):
    library, _ = library_and_frames
    with pytest.raises(ValueError, match="2..64 networks"):
        Controller(library, np.zeros((MAX_MEMBERS + 1, 215)))
    with pytest.raises(ValueError, match="expected 215 weights"):
        Controller(library, np.zeros((2, 3, 215)))
    with pytest.raises(ValueError, match="Elman network is one network"):
        Controller(library, np.zeros((2, 245)), policy_kind="elman-sigmoid")


def test_a_schema_7_file_of_one_network_still_loads(library_and_frames, tmp_path):
    library, frames = library_and_frames
    weights = np.random.default_rng(9).uniform(-1, 1, 215)
    path = tmp_path / "one.json"
    Controller(library, weights).save(path)
    data = json.loads(path.read_text())
    data["schema_version"] = 7
    data["checksum"] = checksum(data)
    path.write_text(json.dumps(data))
    loaded = Controller.load(path)
    assert loaded.members == 1 and loaded.weights.tobytes() == weights.tobytes()


def test_an_elman_network_is_not_fitted_as_an_ensemble():
    x, a = _cases(12)
    with pytest.raises(ValueError, match="Elman network is one network"):
        fit_bc_elman(
            x, a, BCConfig(epochs=2, ensemble=2), np.random.default_rng(0), episodes=np.array([0])
        )


def test_a_benchmark_refuses_an_elman_ensemble_before_it_runs():
    from lfd_track.benchmark.config import BenchmarkConfig

    with pytest.raises(ValueError, match="Elman network is one network"):
        BenchmarkConfig(method="bc", policy_kind="elman-sigmoid", bc=BCConfig(ensemble=3))
