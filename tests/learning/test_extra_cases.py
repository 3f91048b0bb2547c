"""``extra_cases``: saved cases an offline learner fits after its own demonstration's, their file
format, their checks, and their way through a study file, the benchmark command and a method."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from lfd_track.benchmark.config import BenchmarkConfig, config_dict
from lfd_track.cli import main
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.errors import FileFormatError
from lfd_track.learning import learners
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.extra_cases import case_files, load_cases, save_cases, with_extra_cases
from lfd_track.methods import baseline, learn_baseline
from lfd_track.study.spec import load_study

TINY_STUDY = """
[study]
name = "tiny"
description = "one condition that names saved cases"
seeds = [0]
repetitions = 1

[defaults]
trials_per_direction = 1

[[conditions]]
name = "bc"
method = "bc"
"""


def write_study(folder: Path, text: str, name: str = "tiny.toml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def _cases(n: int, inputs: int = 3, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.random((n, inputs)), rng.integers(0, 3, size=n)


def test_saved_cases_round_trip_and_a_folder_is_read_in_the_order_of_its_names(tmp_path):
    first, second = _cases(4, seed=1), _cases(6, seed=2)
    save_cases(tmp_path / "b", *first)  # written first, read second: the names decide
    assert save_cases(tmp_path / "a.npz", *second) == tmp_path / "a.npz"
    assert [f.name for f in case_files(tmp_path)] == ["a.npz", "b.npz"]
    x, a = load_cases(tmp_path)
    np.testing.assert_array_equal(x, np.concatenate([second[0], first[0]]))
    np.testing.assert_array_equal(a, np.concatenate([second[1], first[1]]))
    assert x.dtype == np.float64 and a.dtype == np.int64
    one_x, one_a = load_cases(tmp_path / "b.npz")
    np.testing.assert_array_equal(one_x, first[0])
    np.testing.assert_array_equal(one_a, first[1])


def test_a_learners_own_cases_come_first(tmp_path):
    own, saved = _cases(5, seed=3), _cases(2, seed=4)
    save_cases(tmp_path / "s.npz", *saved)
    x, a = with_extra_cases(tmp_path / "s.npz", *own)
    np.testing.assert_array_equal(x, np.concatenate([own[0], saved[0]]))
    np.testing.assert_array_equal(a, np.concatenate([own[1], saved[1]]))
    with pytest.raises(FileFormatError, match="saved cases have 3 inputs a case, the learner's 4"):
        with_extra_cases(tmp_path / "s.npz", np.zeros((5, 4)), own[1])


@pytest.mark.parametrize(
    ("arrays", "problem"),
    [
        ({"x": np.zeros((3, 2))}, "need arrays 'x' and 'a'"),
        ({"x": np.zeros(3), "a": np.zeros(3, dtype=int)}, "'x' must be (cases, inputs)"),
        ({"x": np.zeros((0, 2)), "a": np.zeros(0, dtype=int)}, "'x' must be (cases, inputs)"),
        ({"x": np.full((2, 2), np.nan), "a": np.zeros(2, dtype=int)}, "finite numbers"),
        ({"x": np.zeros((2, 2)), "a": np.zeros(3, dtype=int)}, "one command a case"),
        ({"x": np.zeros((2, 2)), "a": np.array([0, 3])}, "commands 0..2"),
        ({"x": np.zeros((2, 2)), "a": np.array([0.0, 1.0])}, "commands 0..2"),
    ],
)
def test_a_bad_saved_cases_file_is_refused_in_one_line_naming_it(tmp_path, arrays, problem):
    bad = tmp_path / "bad.npz"
    np.savez(bad, **arrays)
    with pytest.raises(FileFormatError) as caught:
        load_cases(tmp_path)
    message = str(caught.value)
    assert message.startswith(f"{bad}: ") and problem in message and "\n" not in message


def test_missing_empty_foreign_and_mismatched_files_are_refused(tmp_path):
    with pytest.raises(FileFormatError, match="no such file or folder"):
        load_cases(tmp_path / "nowhere")
    with pytest.raises(FileFormatError, match=r"no saved cases \(\*\.npz\)"):
        load_cases(tmp_path)
    (tmp_path / "notes.txt").write_text("cases")
    with pytest.raises(FileFormatError, match="saved cases are .npz files"):
        load_cases(tmp_path / "notes.txt")
    (tmp_path / "broken.npz").write_text("not an archive")
    with pytest.raises(FileFormatError, match="not a saved-cases file"):
        load_cases(tmp_path / "broken.npz")
    (tmp_path / "broken.npz").unlink()
    save_cases(tmp_path / "a.npz", *_cases(2, inputs=3))
    save_cases(tmp_path / "b.npz", *_cases(2, inputs=4))
    with pytest.raises(FileFormatError) as caught:
        load_cases(tmp_path)
    assert (
        str(caught.value) == f"{tmp_path / 'b.npz'}: 4 inputs a case, where the files before have 3"
    )


def test_the_setting_is_for_offline_learners_and_written_only_when_set(tmp_path):
    assert "extra_cases" not in config_dict(BenchmarkConfig())
    config = BenchmarkConfig(method="bc", extra_cases="cases")
    assert config_dict(config)["extra_cases"] == "cases"
    assert BenchmarkConfig.from_dict(config_dict(config)) == config
    for method in ("paper", "cma-es"):
        BenchmarkConfig(method=method, extra_cases="cases")
    with pytest.raises(ValueError, match="extra_cases apply to the methods paper, bc, cma-es"):
        BenchmarkConfig(method="online", extra_cases="cases")
    with pytest.raises(ValueError, match="driven sequence an Elman network"):
        BenchmarkConfig(method="bc", policy_kind="elman-sigmoid", extra_cases="cases")


def test_a_study_names_saved_cases_relative_to_its_folder_and_checks_them(tmp_path, capsys):
    save_cases(tmp_path / "prior" / "r0.npz", *_cases(3))
    path = write_study(tmp_path, TINY_STUDY + 'extra_cases = "prior"\n')
    (condition,) = load_study(path).conditions
    assert condition.config.extra_cases == str(tmp_path / "prior")
    bad = write_study(tmp_path, TINY_STUDY + 'extra_cases = "missing"\n', name="bad.toml")
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(bad), "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith(f"lfd-track study: {bad}: "), err
    assert f"extra_cases: {tmp_path / 'missing'}: no such file or folder" in err, err
    assert not out.exists()


def test_the_benchmark_command_refuses_a_bad_file_before_anything_is_written(tmp_path, capsys):
    bad = tmp_path / "bad.npz"
    np.savez(bad, x=np.zeros((2, 2)))
    out = tmp_path / "out"
    code = main(
        ["--quiet", "benchmark", "--method", "bc", "--extra-cases", str(bad), "--out", str(out)]
    )
    err = capsys.readouterr().err
    assert code != 0 and err.count("\n") == 1 and str(bad) in err, err
    assert not out.exists()


def test_the_bc_method_fits_its_own_cases_followed_by_the_saved_ones(tmp_path, monkeypatch):
    seen: list[tuple[np.ndarray, np.ndarray]] = []
    made = learners.learner_for

    def spying(config):
        learner = made(config)
        fit = learner.fit

        def recording(inputs, actions, rng):
            seen.append((np.array(inputs), np.array(actions)))
            return fit(inputs, actions, rng)

        learner.fit = recording
        return learner

    monkeypatch.setattr(baseline, "learner_for", spying)
    saved = _cases(7, inputs=40, seed=5)
    save_cases(tmp_path / "prior" / "one.npz", *saved)
    kwargs = dict(demo_seed=11, ga_seed=12, preset="paper", human=HumanConfig())
    learner = BCConfig(epochs=20)
    with_saved = learn_baseline(
        tmp_path / "with", learner=learner, extra_cases=str(tmp_path / "prior"), **kwargs
    )
    alone = learn_baseline(tmp_path / "alone", learner=learner, **kwargs)
    (x, a), (own_x, own_a) = seen
    assert with_saved.demo["cases"] == alone.demo["cases"] == len(own_a)  # the room's own count
    np.testing.assert_array_equal(x, np.concatenate([own_x, saved[0]]))
    np.testing.assert_array_equal(a, np.concatenate([own_a, saved[1]]))
    assert with_saved.effort == alone.effort  # the same demonstration, the same human effort
    assert not np.array_equal(with_saved.controller.weights, alone.controller.weights)


def test_saved_cases_of_another_width_fail_the_fit_naming_them(tmp_path):
    save_cases(tmp_path / "narrow.npz", *_cases(3, inputs=2))
    with pytest.raises(FileFormatError, match="saved cases have 2 inputs a case, the learner's 40"):
        learn_baseline(
            tmp_path / "rep",
            learner=dataclasses.replace(BCConfig(), epochs=5),
            extra_cases=str(tmp_path / "narrow.npz"),
            demo_seed=1,
            ga_seed=2,
        )
