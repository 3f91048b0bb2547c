"""A repetition whose demonstration cannot finish is recorded as failed and scored as failures on
every trial it would have run; the other repetitions run as ever; any other error propagates.

The failing repetition goes through the real paper method and demonstrator with a command budget
too small to finish (``max_commands``); the repetitions that learn get a stand-in controller that
always drives forward (learning a real one would take a minute)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any

import pytest
from lfd_test_support import stand_in_learned

import lfd_track.benchmark.runner as runner
from lfd_track.benchmark.report import write_benchmark_outputs
from lfd_track.benchmark.runner import BenchmarkConfig, run_benchmark
from lfd_track.benchmark.schema import read_results
from lfd_track.benchmark.tables import NO_CONTROLLER
from lfd_track.demo.demonstrator import HumanConfig, run_demonstration
from lfd_track.errors import DemonstrationUnfinished
from lfd_track.methods.common import Learned
from lfd_track.teaching.loop import TeachingLoop

LOST = HumanConfig(max_commands=5)
"""A human who gives up after 5 commands: the protocol's 10 library-only commands alone are more."""


def patch_learning(monkeypatch: pytest.MonkeyPatch, lost: set[int]) -> None:
    """Repetitions in ``lost`` demonstrate for real with :data:`LOST`; the others learn
    :func:`stand_in_learned` at once."""
    real = runner.learn_repetition

    def learn(config: BenchmarkConfig, rep_dir: Path, **kwargs: Any) -> Learned:
        if int(rep_dir.name.split("_")[1]) in lost:
            return real(dataclasses.replace(config, human=LOST), rep_dir, **kwargs)
        return stand_in_learned()

    monkeypatch.setattr(runner, "learn_repetition", learn)


def test_the_loop_over_budget_raises_demonstration_unfinished_with_its_counts(tmp_path):
    with pytest.raises(DemonstrationUnfinished, match="demonstration exceeded 5 commands") as err:
        run_demonstration(tmp_path / "d.lfdemo", seed=0, human=LOST, fsync=False)
    assert isinstance(err.value, RuntimeError)  # callers that caught RuntimeError still do
    assert err.value.counts.steps == err.value.counts.human_commands == 6


def test_another_runtime_error_in_the_demonstration_is_not_called_a_lost_human(
    tmp_path, monkeypatch
):
    def broken(self, max_steps=None):
        raise RuntimeError("no commander proposed a command")

    monkeypatch.setattr(TeachingLoop, "run", broken)
    with pytest.raises(RuntimeError, match="no commander proposed") as err:
        run_demonstration(tmp_path / "d.lfdemo", seed=0, fsync=False)
    assert not isinstance(err.value, DemonstrationUnfinished)


def test_a_lost_demonstration_is_one_failed_repetition(tmp_path, monkeypatch):
    patch_learning(monkeypatch, lost={0})
    config = BenchmarkConfig(repetitions=2, seed=0, trials_per_direction=1)
    reps = run_benchmark(config, tmp_path / "reps")
    assert [r.failed for r in reps] == ["demonstration exceeded 5 commands", None]
    failed, learned = reps
    assert not (tmp_path / "reps" / "rep_00" / "controller.json").exists()
    assert (tmp_path / "reps" / "rep_01" / "controller.json").exists()
    # Every trial it would have run (training and testing, both ways) is a failure, undriven.
    assert [(o.track, o.direction) for o in failed.outcomes] == [
        (o.track, o.direction) for o in learned.outcomes
    ]
    assert all(o.failure == NO_CONTROLLER and o.steps == 0 for o in failed.outcomes)
    assert all(o.failure != NO_CONTROLLER and o.steps > 0 for o in learned.outcomes)
    assert failed.effort["commands"] == 6  # the 5-command budget, exceeded by one
    assert failed.effort["learning_drive_s"] == pytest.approx(6 * 0.4, abs=1e-9)

    out = tmp_path / "out"
    out.mkdir()
    write_benchmark_outputs(out, config, reps, wall_s=1.0, workers=1)
    results = read_results(out / "results.json")
    assert results["failed_repetitions"] == [
        {
            "repetition": 0,
            "failed": "demonstration exceeded 5 commands",
            "commands": 6,
            "learning_drive_s": pytest.approx(2.4, abs=1e-6),
        }
    ]
    # Per learned repetition only; the failed one's effort counts in the totals.
    assert [d["repetition"] for d in results["demonstrations"]] == [1]
    assert results["training_accuracy"] == [0.8]
    assert results["human_effort"]["total"]["commands"] == 6 + 160
    # Its trials are failures in every rate: 1 trial per direction and repetition.
    testing = results["testing_track"]
    assert testing["laps"] == 4
    assert testing["cw"]["failure_kinds"][NO_CONTROLLER] == 1
    first = testing["cw"]["corner_order"][0]
    assert testing["cw"]["corners"][first]["failure_kinds"][NO_CONTROLLER] == 1
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "## Failed repetitions" in report
    assert "| 0 | demonstration exceeded 5 commands | 6 | 2.4 |" in report
    assert "1 no controller" in report


def test_a_run_without_a_failed_repetition_writes_no_trace_of_the_feature(tmp_path, monkeypatch):
    patch_learning(monkeypatch, lost=set())
    config = BenchmarkConfig(repetitions=1, seed=0, trials_per_direction=1, test_tracks=())
    reps = run_benchmark(config, tmp_path / "reps")
    write_benchmark_outputs(tmp_path, config, reps, wall_s=1.0, workers=1)
    text = (tmp_path / "results.json").read_text(encoding="utf-8")
    assert "failed_repetitions" not in text and NO_CONTROLLER not in text
    assert "Failed repetitions" not in (tmp_path / "report.md").read_text(encoding="utf-8")


@pytest.mark.parametrize(
    "error", [ValueError("a bug"), RuntimeError("no commander proposed a command")]
)
def test_any_other_error_in_a_repetition_propagates(tmp_path, monkeypatch, error):
    def learn(config: BenchmarkConfig, rep_dir: Path, **kwargs: Any) -> Learned:
        if rep_dir.name == "rep_01":
            raise error
        return stand_in_learned()

    monkeypatch.setattr(runner, "learn_repetition", learn)
    config = BenchmarkConfig(repetitions=2, seed=0, trials_per_direction=1, test_tracks=())
    with pytest.raises(type(error), match=str(error)):
        run_benchmark(config, tmp_path / "reps")


def test_a_failed_repetition_scores_its_procedural_loops_as_the_teacher_admits_them():
    config = BenchmarkConfig(repetitions=1, seed=0, trials_per_direction=1, random_loops=1)
    outcomes, record = runner.run_loop_trials(None, trial_seed=7, config=config, repetition=2)
    assert [(o.direction, o.failure, o.steps, o.repetition) for o in outcomes] == [
        ("ccw", NO_CONTROLLER, 0, 2),
        ("cw", NO_CONTROLLER, 0, 2),
    ]
    assert outcomes[0].track == outcomes[1].track  # one admitted loop, both ways
    assert record["drawn"] == 1 + len(record["excluded"])
