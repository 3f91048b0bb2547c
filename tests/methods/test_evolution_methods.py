"""The methods without a teacher, ``direct`` and ``mu-plus-one``: each runs through the benchmark
runner, a study file and the command line with tiny settings, reports robot time and put-backs in
results.json and the report, and learns the same controller from the same seeds."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd_track.benchmark.report import write_benchmark_outputs
from lfd_track.benchmark.runner import (
    BenchmarkConfig,
    config_dict,
    repetition_seeds,
    repetition_streams,
    run_benchmark,
)
from lfd_track.benchmark.schema import migrate_results
from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.errors import FileFormatError
from lfd_track.learning.direct import DirectConfig, MuPlusOneConfig
from lfd_track.methods import get_method, learn_evolved
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory_config import memory_config
from lfd_track.study.run import load_finished, run_study
from lfd_track.study.spec import load_study
from lfd_track.teaching.scripted import HumanConfig

#: Tiny settings: a few hundred commands of evolution at most.
TINY = {
    "direct": DirectConfig(population_size=2, generations=2),
    "mu-plus-one": MuPlusOneConfig(mu=2, tau=30, recovery=2, evaluations=4),
}
HUMAN = HumanConfig(legs=1)


def _config(method: str) -> BenchmarkConfig:
    return BenchmarkConfig(
        method=method,
        repetitions=1,
        trials_per_direction=1,
        human=HUMAN,
        test_tracks=(),  # the training track's two directions only
        method_settings={get_method(method).table: TINY[method]},
    )


@pytest.mark.parametrize("method", ["direct", "mu-plus-one"])
def test_a_method_without_a_teacher_runs_through_the_benchmark(method, tmp_path):
    config = _config(method)
    (rep,) = run_benchmark(config, tmp_path / "work", workers=1)
    evolution = rep.demo["evolution"]
    assert rep.demo["cases_learned"] is False and evolution["steps"] > 0
    period = 0.4  # the paper preset's control period [s]
    demonstration = rep.effort["commands"]  # the human drove only the library's demonstration
    assert rep.effort["corrections"] == rep.effort["takeovers"] == 0
    assert rep.effort["learning_steps"] == demonstration + evolution["steps"]
    assert rep.effort["learning_drive_s"] == pytest.approx(rep.effort["learning_steps"] * period)
    assert rep.effort["autonomous_drive_s"] == pytest.approx(evolution["robot_s"])
    expected_put_backs = evolution["put_backs"] if method == "mu-plus-one" else 0
    assert rep.effort["put_backs"] == expected_put_backs
    if method == "direct":
        assert evolution["generations"] == 2 and evolution["evaluations"] == 2 * 2 * 2
    else:
        assert evolution["evaluations"] == 4 and evolution["steps"] == 4 * (30 + 2)
    saved = Controller.load(tmp_path / "work" / "rep_00" / "controller.json")
    assert saved.learner == method and saved.learner_config == TINY[method].to_dict()
    assert len(rep.outcomes) == 2  # scored by the runner's trials like any controller

    write_benchmark_outputs(tmp_path / "out", config, [rep], wall_s=1.0, workers=1)
    results = json.loads((tmp_path / "out" / "results.json").read_text())
    assert results["method"] == method
    total = results["human_effort"]["total"]
    assert total["put_backs"] == expected_put_backs
    assert total["learning_drive_s"] == pytest.approx(rep.effort["learning_drive_s"])
    assert results["human_effort"]["repetitions"][0]["learning_steps"] > 0
    assert results["config"][get_method(method).table] == TINY[method].to_dict()
    assert BenchmarkConfig.from_dict(results["config"]) == config
    report = (tmp_path / "out" / "report.md").read_text()
    assert "| put back by hand |" in report
    assert f"| {total['learning_drive_s']:.1f} | {total['autonomous_drive_s']:.1f} " in report


@pytest.mark.parametrize("method", ["direct", "mu-plus-one"])
def test_the_same_seeds_learn_the_same_controller(method, tmp_path):
    demo_seed, ga_seed, _ = repetition_streams(repetition_seeds(3, 1)[0])
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, human=HUMAN, settings=TINY[method])
    first = learn_evolved(tmp_path / "a", **kwargs)
    again = learn_evolved(tmp_path / "b", **kwargs)
    assert first.effort == again.effort and first.demo == again.demo
    np.testing.assert_allclose(first.controller.weights, again.controller.weights, atol=1e-12)
    # Decisions compared exactly: the commands both give on the demonstration's road values.
    demo = load_demonstration(tmp_path / "a" / "demonstration.lfdemo")
    x = demo.policy_inputs(first.controller.features)
    decide = [[c.act_on_values(v) for v in x] for c in (first.controller, again.controller)]
    assert decide[0] == decide[1]
    if method == "mu-plus-one":  # the seed does decide
        other = learn_evolved(tmp_path / "c", **{**kwargs, "ga_seed": ga_seed + 1})
        assert not np.allclose(other.controller.weights, first.controller.weights)


def test_options_the_network_would_ignore_are_refused(tmp_path):
    demo_seed, ga_seed, _ = repetition_streams(0)
    for option, words in (
        ({"memory": memory_config({"kind": "last_bend"})}, "without memory inputs"),
        ({"features": "road_values+colour"}, "road values alone"),
        ({"mirror": True}, "mirror does not apply"),
    ):
        with pytest.raises(ValueError, match=words):
            learn_evolved(
                tmp_path, demo_seed=demo_seed, ga_seed=ga_seed, settings=DirectConfig(), **option
            )
    assert not (tmp_path / "demonstration.lfdemo").exists()  # refused before driving


def test_settings_are_checked_and_round_trip():
    for settings in (DirectConfig(), MuPlusOneConfig(), *TINY.values()):
        assert type(settings).from_dict(settings.to_dict()) == settings
    with pytest.raises(ValueError, match="direct generations must be at most"):
        DirectConfig(generations=10**7)
    with pytest.raises(ValueError, match="mu-plus-one tau must be at least 1"):
        MuPlusOneConfig(tau=0)
    with pytest.raises(ValueError, match="unknown mu-plus-one setting 'track'"):
        MuPlusOneConfig.from_dict({"track": "training"})


STUDY = """
[study]
name = "no-teacher"
seeds = [0]
repetitions = 1

[defaults]
trials_per_direction = 1
test_tracks = []
[defaults.human]
legs = 1

[[conditions]]
name = "direct"
method = "direct"
[conditions.direct]
population_size = 2
generations = 1

[[conditions]]
name = "mu-plus-one"
method = "mu-plus-one"
[conditions.mu_plus_one]
mu = 2
tau = 10
recovery = 1
evaluations = 3
"""


def test_a_study_runs_both_methods(tmp_path):
    path = tmp_path / "no_teacher.toml"
    path.write_text(STUDY, encoding="utf-8")
    study = load_study(path)
    direct, online = study.conditions
    assert direct.config.settings_of() == DirectConfig(population_size=2, generations=1)
    assert online.config.settings_of() == MuPlusOneConfig(mu=2, tau=10, recovery=1, evaluations=3)
    run = run_study(study, tmp_path / "out", executor="local", workers=1)
    assert (run.total, run.ran) == (2, 2)
    finished = {job.condition: results for job, results in load_finished(study, tmp_path / "out")}
    for name, results in finished.items():
        assert results["method"] == name and len(results["outcomes"]) == 2
        assert {"learning_drive_s", "put_backs"} <= set(results["human_effort"]["total"])
    assert finished["mu-plus-one"]["demonstrations"][0]["evolution"]["evaluations"] == 3
    path.write_text(STUDY.replace("tau = 10", "tau = 0"), encoding="utf-8")
    with pytest.raises(FileFormatError, match="mu-plus-one tau must be at least 1"):
        load_study(path)


def test_the_command_line_runs_a_method_without_a_teacher(tmp_path, capsys, monkeypatch):
    out = tmp_path / "out"
    code = main(
        [
            "benchmark",
            "--method",
            "mu-plus-one",
            "--mu-plus-one-evaluations",
            "2",
            "--quick",
            "--out",
            str(out),
        ]
    )
    assert code == 0
    results = json.loads((out / "results.json").read_text())
    assert results["method"] == "mu-plus-one"
    assert results["config"]["mu_plus_one"]["evaluations"] == 2
    assert "put back by hand" in (out / "report.md").read_text()
    assert main(["benchmark", "--direct-generations", "2", "--out", str(tmp_path / "x")]) == 2
    assert "--direct-generations needs --method direct" in capsys.readouterr().err
    monkeypatch.setenv("COLUMNS", "400")  # one line per option: argparse breaks at hyphens
    with pytest.raises(SystemExit):
        main(["benchmark", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert "direct (no teacher:" in shown and "mu-plus-one (no teacher:" in shown


def test_an_older_results_json_reads_with_the_new_tables_and_no_put_backs():
    config = json.loads(json.dumps(config_dict(BenchmarkConfig())))  # as a file holds it
    older = {k: v for k, v in config.items() if k not in ("direct", "mu_plus_one")}
    effort = {"total": {"commands": 5}, "repetitions": [{"commands": 5, "repetition": 0}]}
    data = {"schema": 2, "config": older, "human_effort": effort}
    migrated = migrate_results(data, "results.json")
    assert migrated["config"] == config
    assert migrated["human_effort"]["total"]["put_backs"] == 0
    assert migrated["human_effort"]["repetitions"][0]["put_backs"] == 0
    assert "direct" not in data["config"]  # the input is left as it was
