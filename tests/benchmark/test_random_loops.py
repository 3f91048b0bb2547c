"""Procedural loops in a benchmark run: each repetition draws its own loops of the chosen split,
admits one only once the scripted human laps it both ways (the rule in
``lfd_track/benchmark/loops.py``), laps it once each way, and results.json and report.md give the
laps pooled, by sharpest turn and by strip width, with the teacher's exclusions."""

from __future__ import annotations

import itertools
import json

import pytest

from lfd_track.benchmark import runner
from lfd_track.benchmark.config import BenchmarkConfig, config_dict
from lfd_track.benchmark.loops import loop_draws, random_loop_results
from lfd_track.benchmark.report import write_benchmark_outputs
from lfd_track.benchmark.schema import migrate_results, read_results
from lfd_track.benchmark.tables import TrialOutcome
from lfd_track.cli import main
from lfd_track.learning.ga import GAConfig
from lfd_track.policy.controller import Controller
from lfd_track.teaching.scripted import HumanConfig
from lfd_track.world.loops import TURN_BIN_LABELS, WIDTH_BIN_LABELS, parse_loop_name

TINY = dict(
    repetitions=1,
    trials_per_direction=1,
    ga=GAConfig(generations=2),
    human=HumanConfig(legs=1),
    test_tracks=(),
)


@pytest.fixture(scope="module")
def loop_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("loops")
    config = BenchmarkConfig(**TINY, random_loops=2, random_split="train")
    reps = runner.run_benchmark(config, out)
    write_benchmark_outputs(out, config, reps, wall_s=1.0, workers=1)
    return config, reps, out


def test_settings_are_checked_in_one_line():
    with pytest.raises(ValueError, match="random_split must be one of train, validation, test"):
        BenchmarkConfig(random_split="holdout")
    with pytest.raises(ValueError, match="random_loops"):
        BenchmarkConfig(random_loops=-1)
    with pytest.raises(ValueError, match="random_loops"):
        BenchmarkConfig(random_loops=10_001)
    config = BenchmarkConfig(random_loops=40, random_split="test")
    assert BenchmarkConfig.from_dict(config_dict(config)) == config


def test_draws_are_the_repetitions_own_and_stay_in_their_split():
    first = [name for name, _ in itertools.islice(loop_draws(7, "test"), 50)]
    again = [name for name, _ in itertools.islice(loop_draws(7, "test"), 50)]
    other = [name for name, _ in itertools.islice(loop_draws(8, "test"), 50)]
    assert first == again
    assert first != other
    assert len(set(first)) == 50
    assert {parse_loop_name(n)[0] for n in first} == {"test"}
    validation = [name for name, _ in itertools.islice(loop_draws(7, "validation"), 5)]
    assert {parse_loop_name(n)[0] for n in validation} == {"validation"}


def test_each_admitted_loop_is_lapped_once_each_way(loop_run):
    config, reps, out = loop_run
    loops = [o for o in reps[0].outcomes if o.track.startswith("random:")]
    assert len(loops) == 2 * config.random_loops
    assert {(o.direction, o.trial) for o in loops} == {("ccw", 0), ("cw", 0)}
    assert {parse_loop_name(o.track)[0] for o in loops} == {"train"}
    record = reps[0].random_loops
    assert record["drawn"] == config.random_loops + len(record["excluded"])

    results = read_results(out / "results.json")
    section = results["random_loops"]
    assert section["loops"] == 2 and section["laps"] == 4
    assert section["ccw"]["laps"] == section["cw"]["laps"] == 2
    assert set(section["by_sharpest_turn"]) == set(TURN_BIN_LABELS)
    assert set(section["by_width"]) == set(WIDTH_BIN_LABELS)
    assert sum(row["laps"] for row in section["by_sharpest_turn"].values()) == 4
    assert sum(row["loops"] for row in section["by_width"].values()) == 2
    assert "test_tracks" not in results  # drawn loops are pooled, not tabled loop by loop
    assert results["config"]["random_loops"] == 2
    report = (out / "report.md").read_text(encoding="utf-8")
    assert "## Procedural loops (train split)" in report
    assert "| sharpest turn | loops | laps |" in report


def test_a_loop_the_teacher_cannot_lap_is_excluded_and_replaced(monkeypatch, loop_run):
    """The first loop drawn fails the teacher's check: it is recorded with the teacher's outcome
    and the next loop drawn takes its place."""
    calls = []
    real = runner.teacher_lap

    def teacher(env, world):
        calls.append(env.track.name)
        if len(set(calls)) == 1:  # both directions of the first loop drawn
            return {"success": False, "failure": "off_track", "steps": 3}
        return real(env, world)

    monkeypatch.setattr(runner, "teacher_lap", teacher)
    config = BenchmarkConfig(**TINY, random_loops=1, random_split="validation")
    controller = _controller(loop_run[2])
    outcomes, record = runner.run_loop_trials(controller, trial_seed=11, config=config)
    first, second = [name for name, _ in itertools.islice(loop_draws(11, "validation"), 2)]
    assert record["drawn"] == 2
    assert [e["track"] for e in record["excluded"]] == [first]
    assert record["excluded"][0]["teacher"]["ccw"]["failure"] == "off_track"
    assert {o.track for o in outcomes} == {second}


def test_a_named_loop_among_the_test_tracks_is_tabled_as_a_track():
    """``test_tracks = ["random:test:17"]`` scores that loop like any named loop; only loops
    drawn per repetition are pooled."""
    named = TrialOutcome(
        track="random:test:17",
        direction="ccw",
        corner_order=("1", "2", "3"),
        corners_reached=("1", "2", "3"),
        corners_negotiated=("1", "2", "3"),
        failure=None,
        success=True,
        repetition=0,
        trial=0,
        steps=100,
    )
    from lfd_track.benchmark.tables import build_results

    results = build_results(
        [named], repetitions=1, seed=0, timing_s={}, test_tracks=["random:test:17"]
    )
    assert "random:test:17" in results["test_tracks"]
    assert "random_loops" not in results
    pooled = build_results([named], repetitions=1, seed=0, timing_s={})
    assert pooled["random_loops"]["laps"] == 1
    assert random_loop_results([named])["by_sharpest_turn"]


def test_a_schema_2_run_lapped_no_procedural_loops():
    old = {"schema": 2, "config": {"method": "paper"}, "outcomes": []}
    config = migrate_results(json.loads(json.dumps(old)), "old.json")["config"]
    assert config["random_loops"] == 0 and config["random_split"] == "validation"


def _controller(out):
    """The controller the module's run learned (one leg, two generations)."""
    return Controller.load(out / "rep_00" / "controller.json")


def test_the_command_line_takes_the_loops_and_their_split(monkeypatch, tmp_path):
    seen = []

    def capture(config, work_dir, **kwargs):
        seen.append(config)
        raise KeyboardInterrupt  # stop here: only the settings are under test

    monkeypatch.setattr(runner, "run_benchmark", capture)
    args = ["--quiet", "benchmark", "--random-loops", "40", "--random-split", "test"]
    main([*args, "--workers", "1", "--out", str(tmp_path / "out")])
    assert (seen[0].random_loops, seen[0].random_split) == (40, "test")
    with pytest.raises(SystemExit):
        main(["--quiet", "benchmark", "--random-split", "holdout", "--out", str(tmp_path / "x")])
