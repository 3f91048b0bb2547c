"""Learning methods behind one interface: a method defined here, outside the package, registered
with one entry, runs through the benchmark runner, a study file and the command line; the
registry refuses a second method of the same name, and an unknown method fails in one line."""

from __future__ import annotations

import json
from dataclasses import dataclass

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict, run_benchmark
from lfd_track.cli import main
from lfd_track.core.config import DictConfig
from lfd_track.errors import FileFormatError
from lfd_track.learning.ga import GAConfig
from lfd_track.methods import (
    Learned,
    Method,
    MethodContext,
    get_method,
    method_names,
    register_method,
    registered,
    unregister_method,
)
from lfd_track.methods.common import demonstrate, demonstration_record, effort_record
from lfd_track.policy.controller import Controller
from lfd_track.policy.mlp import n_weights
from lfd_track.study.run import load_finished, run_study
from lfd_track.study.spec import load_study
from lfd_track.teaching.scripted import HumanConfig


@dataclass(frozen=True)
class FixedConfig(DictConfig):
    """Settings of the toy method: every weight of the network."""

    settings_name = "fixed"

    weight: float = 0.0


def learn_fixed(context: MethodContext) -> Learned:
    """The toy method: the paper's demonstration, then a network that learned nothing (every
    weight ``context.settings.weight``) with the demonstration's road library."""
    summary, _, library, _ = demonstrate(context)
    weights = np.full(n_weights(False, 40), context.settings.weight)
    controller = Controller(
        library,
        weights,
        learner="fixed",
        learner_config=context.settings.to_dict(),
        seed=context.ga_seed,
    )
    return Learned(
        controller=controller,
        demo=demonstration_record(summary),
        fitness_best=[],
        fitness_mean=[],
        training_accuracy=0.0,
        effort=effort_record(context.period_s, demonstration_commands=summary.commands),
    )


FIXED = Method("fixed", learn_fixed, FixedConfig, summary="demonstrate, then learn nothing")

STUDY = """
[study]
name = "toy"
seeds = [0]
repetitions = 1

[[conditions]]
name = "fixed"
method = "fixed"
trials_per_direction = 1
[conditions.human]
legs = 1
[conditions.fixed]
weight = 0.5
"""


@pytest.fixture
def fixed_method():
    with registered(FIXED):
        yield FIXED
    assert "fixed" not in method_names()


def test_a_method_registered_from_outside_runs_through_the_benchmark(fixed_method, tmp_path):
    settings = FixedConfig(weight=0.5)
    config = BenchmarkConfig(
        method="fixed",
        repetitions=1,
        trials_per_direction=1,
        human=HumanConfig(legs=1),
        test_tracks=(),  # the training track's two directions only
        method_settings={"fixed": settings},
    )
    assert config.settings_of() == settings
    (rep,) = run_benchmark(config, tmp_path / "work", workers=1)
    assert len(rep.outcomes) == 2 and rep.effort["commands"] > 0
    saved = Controller.load(tmp_path / "work" / "rep_00" / "controller.json")
    assert saved.learner == "fixed" and saved.learner_config == {"weight": 0.5}
    np.testing.assert_array_equal(saved.weights, np.full(215, 0.5))
    # results.json holds its settings table beside the built-in methods', and reads back
    data = config_dict(config)
    assert data["fixed"] == {"weight": 0.5} and data["dagger"] == config.dagger.to_dict()
    assert BenchmarkConfig.from_dict(data) == config
    # defaults need no table: the default settings are what a missing table means
    plain = BenchmarkConfig(method="fixed", method_settings={"fixed": FixedConfig()})
    assert plain.method_settings == {} and plain.settings_of() == FixedConfig()
    assert BenchmarkConfig.from_dict(config_dict(plain)) == plain


def test_a_method_registered_from_outside_runs_in_a_study(fixed_method, tmp_path):
    path = tmp_path / "toy.toml"
    path.write_text(STUDY, encoding="utf-8")
    study = load_study(path)
    (condition,) = study.conditions
    assert condition.method == "fixed"
    assert condition.config.settings_of() == FixedConfig(weight=0.5)
    out = tmp_path / "out"
    run = run_study(study, out, executor="local", workers=1)
    assert (run.total, run.ran) == (1, 1)
    ((job, results),) = load_finished(study, out)
    assert results["config"]["method"] == "fixed" and results["config"]["fixed"] == {"weight": 0.5}
    assert len(results["outcomes"]) == 4
    # its table is checked key by key like a built-in method's
    path.write_text(STUDY.replace("weight = 0.5", "wieght = 0.5"), encoding="utf-8")
    with pytest.raises(FileFormatError, match="unknown key 'fixed.fixed.wieght'"):
        load_study(path)


def test_the_command_line_offers_a_registered_method(fixed_method, tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["benchmark", "--help"])
    assert "fixed (demonstrate, then learn nothing)" in " ".join(capsys.readouterr().out.split())


def test_the_registry_refuses_a_second_method_of_a_name_or_table(fixed_method):
    with pytest.raises(ValueError, match="a method named 'fixed' is registered already"):
        register_method(FIXED)
    with pytest.raises(ValueError, match="a method named 'paper' is registered already"):
        register_method(Method("paper", learn_fixed))
    with pytest.raises(ValueError, match="the settings table 'fixed' is method 'fixed's"):
        register_method(Method("fixed-too", learn_fixed, FixedConfig, table="fixed"))
    with pytest.raises(ValueError, match="lower-case letters"):
        Method("Fixed", learn_fixed)
    assert method_names()[:6] == ("paper", "online", "hg-dagger", "bc", "cma-es", "dagger")


def test_unregistering_removes_the_method_everywhere(tmp_path, capsys):
    register_method(FIXED)
    assert unregister_method("fixed") is FIXED
    with pytest.raises(ValueError, match="unknown method 'fixed'"):
        get_method("fixed")
    with pytest.raises(ValueError, match="unknown method 'fixed'"):
        BenchmarkConfig(method="fixed")


def test_an_unknown_method_fails_in_one_line(tmp_path, capsys):
    path = tmp_path / "toy.toml"
    path.write_text(STUDY, encoding="utf-8")  # "fixed" is not registered here
    with pytest.raises(FileFormatError) as caught:
        load_study(path)
    assert len(str(caught.value).splitlines()) == 1 and "unknown" in str(caught.value)
    with pytest.raises(SystemExit) as stopped:
        main(["benchmark", "--method", "fixed", "--out", str(tmp_path / "out")])
    assert stopped.value.code == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "--method" in err and "'fixed'" in err


def test_the_capabilities_of_a_method_are_its_entry(fixed_method):
    """shifted_views and policy_kind are refused by what the entry declares."""
    with pytest.raises(ValueError, match="shifted_views applies to the methods paper, bc, cma-es"):
        BenchmarkConfig(method="fixed", shifted_views=True)
    with pytest.raises(ValueError, match="trained by the methods paper, bc, not 'fixed'"):
        BenchmarkConfig(method="fixed", policy_kind="elman-sigmoid")
    with pytest.raises(ValueError, match="must be FixedConfig"):
        BenchmarkConfig(method="fixed", method_settings={"fixed": GAConfig()})
    with pytest.raises(ValueError, match="no registered method's table"):
        BenchmarkConfig(method_settings={"ga": GAConfig()})


def test_every_built_in_setting_round_trips_through_results():
    config = BenchmarkConfig(
        method="dagger",
        repetitions=2,
        human=HumanConfig(legs=1, steers_by="centreline"),
        ga=GAConfig(generations=7),
        test_tracks=("testing",),
        mirror=True,
    )
    data = json.loads(json.dumps(config_dict(config)))
    assert {"online", "hg_dagger", "bc", "cmaes", "dagger", "memory"} <= set(data)
    assert BenchmarkConfig.from_dict(data) == config
    assert BenchmarkConfig.from_dict({"method": "bc"}) == BenchmarkConfig(method="bc")
    with pytest.raises(ValueError, match="unknown benchmark setting 'methd'"):
        BenchmarkConfig.from_dict({"methd": "bc"})
