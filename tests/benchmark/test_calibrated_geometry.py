"""``geometry = "calibrated"``: the ``fresh_felt`` map's motion per command is what a calibration
of the simulated rover measures in the world the policy is taught in, before teaching, from the
repetition's own stream; the teacher's map and the controller's assume it, results.json records
the measurement, and a calibration that cannot converge is one failed repetition.

The world is the paper's with a rover that pivots 15 % faster: the map's nominal pivot would be
22.9°, the world's is 26.4°. The benchmark is tiny (one repetition, a one-leg demonstration, two
GA generations, one trial each way on the training track)."""

from __future__ import annotations

import dataclasses
import json
import math
from pathlib import Path

import pytest

import lfd_track.hardware.calibrate as calibrate_module
from lfd_track.benchmark import runner
from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.report import write_benchmark_outputs
from lfd_track.benchmark.runner import repetition_seeds
from lfd_track.benchmark.schema import read_results
from lfd_track.benchmark.tables import NO_CONTROLLER
from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.envs.presets import load_preset
from lfd_track.errors import CalibrationFailed
from lfd_track.learning.ga import GAConfig
from lfd_track.methods.common import calibration_for
from lfd_track.policy.controller import Controller
from lfd_track.policy.map_geometry import MapGeometry
from lfd_track.policy.memory import FreshFeltConfig, memory_config
from lfd_track.study.spec import load_study
from lfd_track.teaching.scripted import HumanConfig

PAPER_PRESET = Path(__file__).resolve().parents[2] / "envs" / "paper.toml"
TOLERANCE = 0.05  # the acceptance: the measured pivot within 5 % of the world's
ROUNDED = 1e-6  # absolute: results.json keeps six decimals
SAME_FLOATS = 1e-9  # relative: the same seed measures the same numbers (BLAS may round apart)
CALIBRATED = FreshFeltConfig(geometry="calibrated")


@pytest.fixture(scope="module")
def fast_pivot(tmp_path_factory: pytest.TempPathFactory) -> str:
    """The paper world with a rover that pivots 15 % faster (pivot rate 1.15 rad/s)."""
    path = tmp_path_factory.mktemp("preset") / "fast_pivot.toml"
    text = PAPER_PRESET.read_text(encoding="utf-8").replace('name = "paper"', 'name = "fast_pivot"')
    text = text.replace("pivot_rate_radps = 1.0 ", "pivot_rate_radps = 1.15")
    assert "pivot_rate_radps = 1.15" in text
    path.write_text(text, encoding="utf-8")
    return str(path)


def tiny(preset: str, **changes: object) -> BenchmarkConfig:
    base = BenchmarkConfig(
        preset=preset,
        repetitions=1,
        trials_per_direction=1,
        ga=GAConfig(generations=2),
        human=HumanConfig(legs=1),
        test_tracks=(),
        memory=CALIBRATED,
    )
    return dataclasses.replace(base, **changes)  # type: ignore[arg-type]


@pytest.fixture(scope="module")
def calibrated_run(
    fast_pivot: str, tmp_path_factory: pytest.TempPathFactory
) -> tuple[Path, dict[str, object]]:
    out = tmp_path_factory.mktemp("calibrated")
    config = tiny(fast_pivot)
    reps = runner.run_benchmark(config, out / "reps")
    write_benchmark_outputs(out, config, reps, wall_s=1.0, workers=1)
    return out, read_results(out / "results.json")


def test_the_setting_takes_calibrated_and_names_its_values() -> None:
    assert memory_config({"kind": "fresh_felt", "geometry": "calibrated"}) == CALIBRATED
    with pytest.raises(ValueError, match="world, paper, calibrated"):
        memory_config({"kind": "fresh_felt", "geometry": "measured"})


def test_the_measured_pivot_is_the_worlds_and_the_controller_records_it(
    fast_pivot: str, calibrated_run: tuple[Path, dict[str, object]]
) -> None:
    out, results = calibrated_run
    truth = MapGeometry.from_preset(load_preset(fast_pivot))
    assert truth.pivot_deg == pytest.approx(
        1.15 * MapGeometry.from_preset(load_preset("paper")).pivot_deg
    )
    assert "failed_repetitions" not in results
    [record] = results["calibrations"]  # type: ignore[misc]
    assert record["repetition"] == 0
    assert abs(record["pivot_deg"] / truth.pivot_deg - 1.0) <= TOLERANCE, record["pivot_deg"]
    assert abs(record["step_m"] / truth.step_m - 1.0) <= TOLERANCE, record["step_m"]
    assert record["true_pivot_deg"] == pytest.approx(truth.pivot_deg, abs=ROUNDED)
    assert 0.0 <= record["pivot_spread"] <= 0.10 and 0.0 <= record["step_spread"] <= 0.10
    assert len(record["runs"]["forward_step_m"]) == 3
    # The controller's map and the teacher's assume the measured motion and the world's camera.
    controller = Controller.load(out / "reps" / "rep_00" / "controller.json")
    assert controller.memory == CALIBRATED
    measured = controller.map_geometry
    assert measured is not None and measured != truth  # measured, not read from the preset
    assert measured.step_m == pytest.approx(record["step_m"], abs=ROUNDED)
    assert measured.pivot_deg == pytest.approx(record["pivot_deg"], abs=ROUNDED)
    assert dataclasses.replace(measured, step_m=truth.step_m, pivot_deg=truth.pivot_deg) == truth
    demo = load_demonstration(out / "reps" / "rep_00" / "demonstration.lfdemo")
    assert MapGeometry.from_dict(demo.metadata["map_geometry"]) == measured


def test_the_same_seed_measures_the_same_values(
    fast_pivot: str, calibrated_run: tuple[Path, dict[str, object]]
) -> None:
    _, results = calibrated_run
    [record] = results["calibrations"]  # type: ignore[misc]
    config = tiny(fast_pivot)
    seed = repetition_seeds(config.seed, 1)[0]
    first, again = (calibration_for(config.memory, fast_pivot, seed) for _ in range(2))
    assert first is not None and again is not None
    # Decisions exact (how many runs of each command were kept), floats within SAME_FLOATS.
    for key in ("forward_step_m", "left_pivot_deg", "right_pivot_deg"):
        values, repeated = getattr(first.calibration, key), getattr(again.calibration, key)
        assert len(values) == len(repeated) == len(record["runs"][key])
        for a, b, stored in zip(values, repeated, record["runs"][key], strict=True):
            assert math.isclose(a, b, rel_tol=SAME_FLOATS)
            assert stored == pytest.approx(a, abs=ROUNDED)  # the benchmark's own, as written
    for key in ("step_m", "pivot_deg", "step_spread", "pivot_spread"):
        a, b = first.record()[key], again.record()[key]
        assert math.isclose(a, b, rel_tol=SAME_FLOATS, abs_tol=1e-12)
        assert record[key] == pytest.approx(a, abs=ROUNDED)
    # Another repetition seed draws another stream: another measurement.
    other = calibration_for(config.memory, fast_pivot, seed + 1)
    assert other is not None and other.calibration != first.calibration


def test_other_maps_run_no_calibration_and_write_no_trace_of_it() -> None:
    seed = repetition_seeds(0, 1)[0]
    for memory in (None, FreshFeltConfig(), FreshFeltConfig(geometry="paper")):
        assert calibration_for(memory, "paper", seed) is None


def test_a_preset_that_redraws_its_world_is_calibrated_in_one_world_with_its_nominal_camera() -> (
    None
):
    nominal = MapGeometry.from_preset(load_preset("randomized"))
    result = calibration_for(CALIBRATED, "randomized", repetition_seeds(0, 1)[0])
    assert result is not None
    # The map's camera is the preset's nominal one, as with geometry = "world"; only the motion
    # is measured, in the world drawn for the calibration (its rates are not randomized).
    assert result.geometry == dataclasses.replace(
        nominal, step_m=result.calibration.step_m, pivot_deg=result.calibration.pivot_deg
    )
    assert (result.true_step_m, result.true_pivot_deg) == (nominal.step_m, nominal.pivot_deg)


def _fail(*args: object, **kwargs: object) -> None:
    raise CalibrationFailed("the floor is too uniform to see the robot move")


def test_a_failed_calibration_is_one_failed_repetition(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(calibrate_module, "calibrate", _fail)
    config = tiny("paper")
    reps = runner.run_benchmark(config, tmp_path / "reps")
    write_benchmark_outputs(tmp_path, config, reps, wall_s=1.0, workers=1)
    why = "calibration failed: the floor is too uniform to see the robot move"
    assert [r.failed for r in reps] == [why]
    assert not (tmp_path / "reps" / "rep_00" / "demonstration.lfdemo").exists()  # before teaching
    assert all(o.failure == NO_CONTROLLER and o.steps == 0 for o in reps[0].outcomes)
    results = read_results(tmp_path / "results.json")
    assert results["failed_repetitions"] == [{"repetition": 0, "failed": why}]
    assert results["calibrations"] == []
    assert f"| 0 | {why} |" in (tmp_path / "report.md").read_text(encoding="utf-8")


def test_a_kept_room_is_calibrated_in_that_room(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    seen: list[tuple[object, object]] = []

    def record(robot: object, camera: object, **kwargs: object) -> None:
        seen.append((robot.base_preset, camera))  # type: ignore[attr-defined]
        _fail()

    monkeypatch.setattr(calibrate_module, "calibrate", record)
    config = tiny("randomized", room="per_repetition")
    seed = repetition_seeds(config.seed, 1)[0]
    result = runner.run_repetition(0, seed, config, str(tmp_path))
    room = runner.repetition_preset(config, seed)
    assert not isinstance(room, str)
    assert seen == [(room, room.camera)]
    assert result.failed is not None and result.failed.startswith("calibration failed: ")


STUDY = """
[study]
schema = 3
name = "calibrated"
description = "a map whose calibration fails beside one in the paper world"
seeds = [0]
repetitions = 1

[defaults]
trials_per_direction = 1
test_tracks = []

[[conditions]]
name = "calibrated"
method = "paper"
[conditions.human]
legs = 1
[conditions.ga]
generations = 2
[conditions.memory]
kind = "fresh_felt"
geometry = "calibrated"
"""


def test_a_study_with_calibrated_geometry_loads_and_finishes_when_it_fails(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    path = tmp_path / "calibrated.toml"
    path.write_text(STUDY, encoding="utf-8")
    [job] = load_study(path).jobs()
    assert job.config.memory == CALIBRATED
    monkeypatch.setattr(calibrate_module, "calibrate", _fail)
    out = tmp_path / "out"
    assert main(["--quiet", "study", str(path), "--out", str(out)]) == 0
    summary = json.loads((out / "study.json").read_text(encoding="utf-8"))
    [condition] = summary["conditions"]
    assert condition["failed_repetitions"] == [
        {
            "seed": 0,
            "repetition": 0,
            "failed": "calibration failed: the floor is too uniform to see the robot move",
        }
    ]


class _Stop(Exception):
    pass


def test_the_teaching_station_in_simulation_calibrates_its_map_first(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from lfd_track.web.session import TeachConfig, open_session

    seen: list[object] = []

    def perception(*args: object, geometry: object = None, **kwargs: object) -> None:
        seen.append(geometry)
        raise _Stop

    monkeypatch.setattr("lfd_track.web.session.Perception", perception)
    config = TeachConfig(out=tmp_path / "t.lfdemo", backend="sim", memory=CALIBRATED, seed=3)
    with pytest.raises(_Stop):
        open_session(config)
    expected = calibration_for(CALIBRATED, "paper", 3)
    assert expected is not None and seen == [expected.geometry]
