"""Backprop's ``hidden``: the width of the network the ``bc`` method fits (the paper's 5 by
default), recorded in the controller file and refused where another width rules."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.benchmark.config import BenchmarkConfig, config_dict
from lfd_track.cli import main
from lfd_track.dataset.reader import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import BCConfig, fit_bc
from lfd_track.learning.fitness import training_accuracy
from lfd_track.methods import OnlineConfig, learn_baseline, learn_online
from lfd_track.policy.controller import Controller
from lfd_track.policy.mlp import n_weights
from lfd_track.study.spec import load_study
from lfd_track.teaching.commanders import PolicyCommander
from lfd_track.teaching.learner_feed import BCLearnerFeed


def _cases(n: int, inputs: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    return rng.uniform(0, 1, (n, inputs)), rng.integers(0, 3, n)


def test_hidden_is_written_only_when_not_the_papers_and_is_checked():
    assert "hidden" not in BCConfig().to_dict()
    wide = BCConfig(hidden=10)
    assert wide.to_dict()["hidden"] == 10
    assert BCConfig.from_dict(wide.to_dict()) == wide
    for bad in (0, 1001, True, 2.5, "10"):
        with pytest.raises(ValueError, match="hidden"):
            BCConfig(hidden=bad)


def test_the_fit_takes_its_width_from_the_settings_unless_told():
    x, a = _cases(40, inputs=4)
    config = BCConfig(epochs=3, bias=True, ensemble=2, hidden=10)
    fit = fit_bc(x, a, config, np.random.default_rng(0))
    assert fit.weights.shape == (2, n_weights(True, 4, 10))
    told = fit_bc(x, a, config, np.random.default_rng(0), hidden=7)
    assert told.weights.shape == (2, n_weights(True, 4, 7))
    paper = fit_bc(x, a, BCConfig(epochs=3), np.random.default_rng(0))
    assert paper.weights.shape == (n_weights(False, 4, 5),)


def test_hidden_is_refused_where_another_width_rules():
    assert "hidden" not in config_dict(BenchmarkConfig(method="bc"))["bc"]
    config = BenchmarkConfig(method="bc", bc=BCConfig(hidden=10))
    assert config_dict(config)["bc"]["hidden"] == 10
    assert BenchmarkConfig.from_dict(config_dict(config)) == config
    with pytest.raises(ValueError, match="an Elman network has 5 hidden nodes"):
        BenchmarkConfig(method="bc", policy_kind="elman-sigmoid", bc=BCConfig(hidden=10))
    with pytest.raises(ValueError, match="width from dagger hidden, not bc hidden"):
        BenchmarkConfig(method="dagger", bc=BCConfig(hidden=10))


def test_a_study_condition_sets_the_width(tmp_path):
    path = tmp_path / "wide.toml"
    path.write_text(
        '[study]\nname = "wide"\ndescription = "a wider network"\nseeds = [0]\nrepetitions = 1\n'
        '[[conditions]]\nname = "bc"\nmethod = "bc"\n[conditions.bc]\nhidden = 10\n',
        encoding="utf-8",
    )
    assert load_study(path).conditions[0].config.bc.hidden == 10
    path.write_text(path.read_text(encoding="utf-8").replace("10", "0"), encoding="utf-8")
    with pytest.raises(ValueError, match="hidden must be in 1..1000, got 0"):
        load_study(path)


def test_the_bc_method_writes_a_wider_controller_that_loads_and_drives(tmp_path):
    learner = BCConfig(epochs=20, bias=True, ensemble=2, hidden=10)
    rep = tmp_path / "rep"
    learned = learn_baseline(
        rep, learner=learner, demo_seed=11, ga_seed=12, preset="paper", human=HumanConfig()
    )
    controller = learned.controller
    assert controller.hidden == 10 and controller.members == 2
    assert controller.to_dict()["layer_sizes"][1] == 10
    assert controller.learner_config["hidden"] == 10
    # Its training accuracy is the wide networks' own on the demonstration's cases.
    (recording,) = rep.glob("*.lfdemo")
    demo = load_demonstration(recording)
    x = demo.policy_inputs(controller.features)
    assert learned.training_accuracy == training_accuracy(
        controller.weights, x, demo.commands, hidden=10
    )
    controller.save(tmp_path / "wide.json")
    again = Controller.load(tmp_path / "wide.json")
    assert again.hidden == 10
    values = np.random.default_rng(3).uniform(0, 1, (5, controller.n_inputs))
    assert [again.act_on_values(v) for v in values] == [controller.act_on_values(v) for v in values]


def test_the_benchmark_flag_is_refused_in_one_line_where_it_has_no_place(tmp_path, capsys):
    out = str(tmp_path / "out")
    assert main(["benchmark", "--method", "paper", "--bc-hidden", "10", "--out", out]) == 2
    err = capsys.readouterr().err
    assert "--bc-hidden" in err and len(err.splitlines()) == 1, err
    argv = ["benchmark", "--method", "dagger", "--dagger-learner", "bc", "--bc-hidden", "10"]
    assert main([*argv, "--out", out]) == 2
    err = capsys.readouterr().err
    assert "dagger hidden, not bc hidden" in err and len(err.splitlines()) == 1, err
    for wrong, problem in (("0", "at least 1"), ("1001", "at most")):
        with pytest.raises(SystemExit):
            main(["benchmark", "--method", "bc", "--bc-hidden", wrong, "--out", out])
        assert problem in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def test_the_online_learner_teaches_and_writes_a_network_of_that_width(tmp_path):
    feed_policy = PolicyCommander(None, hidden=10)
    feed = BCLearnerFeed(
        BCConfig(bias=True, hidden=10), np.random.default_rng(0), 2, feed_policy, n_inputs=4
    )
    feed.update(*_cases(12, inputs=4))
    assert feed.weights.shape == (n_weights(True, 4, 10),)
    assert feed_policy.act_on_values(np.full(4, 0.5)) in (0, 1, 2)  # drives with the wide weights
    learned = learn_online(
        tmp_path / "rep",
        online=OnlineConfig(learner="bc", epochs_per_case=2),
        bc=BCConfig(epochs=20, bias=True, hidden=10),
        demo_seed=11,
        ga_seed=12,
        preset="paper",
        human=HumanConfig(),
    )
    assert learned.controller.hidden == 10
    assert learned.controller.learner_config["bc"]["hidden"] == 10
