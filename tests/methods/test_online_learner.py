"""The ``online`` method's learner: the GA by default (its files unchanged), or backprop while
the human demonstrates, ending with the controller the ``bc`` learner writes for those cases."""

import dataclasses

import numpy as np
import pytest

from lfd_track.benchmark.runner import repetition_seeds, repetition_streams
from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.errors import FileFormatError
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.learners import learner_for
from lfd_track.learning.mirror import with_mirrored
from lfd_track.methods import MethodContext, OnlineConfig, learn_baseline, learn_online
from lfd_track.methods.baseline import controller_of_fit
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import FreshFeltConfig
from lfd_track.study.spec import load_study

BC = BCConfig(epochs=300, bias=True)
"""Backprop of the goal's chosen learner (biases), fewer epochs for a quick final fit."""
ONLINE_BC = OnlineConfig(learner="bc")


def _seeds() -> tuple[int, int]:
    """(demo, ga) seeds of repetition 0 of benchmark seed 0, as the runner draws them."""
    demo_seed, ga_seed, _ = repetition_streams(repetition_seeds(0, 1)[0])
    return demo_seed, ga_seed


def _context() -> dict:
    """The human-taught goal's inputs: the centreline human with its delays and lapses, the
    fresh_felt map afresh per leg read alone by the network, cases mirrored too."""
    demo_seed, ga_seed = _seeds()
    return dict(
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(clear_memory_per_leg=True),
        memory=FreshFeltConfig(),
        features="none",
        mirror=True,
        bc=BC,
    )


@pytest.fixture(scope="module")
def bc_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("online_bc")
    return out, learn_online(out, online=ONLINE_BC, **_context())


def test_online_by_backprop_learns_while_the_human_demonstrates(bc_run):
    """The policy refitted by backprop after every case earns the wheel, and the controller
    fits the demonstration's cases well above always driving forward."""
    out, learned = bc_run
    demo = load_demonstration(out / "demonstration.lfdemo")
    commands = np.asarray(demo.commands)
    forward_share = float((commands == 0).mean())
    # training accuracy on its own cases (the unmirrored ones): 0.84 on this run
    assert learned.training_accuracy >= 0.7
    assert learned.training_accuracy >= forward_share + 0.1
    assert learned.effort["takeovers"] >= 1 and learned.effort["autonomous_drive_s"] > 0
    assert learned.effort["corrections"] >= 1
    assert learned.demo["correction_cases"] >= 1
    # epochs_per_case Adam epochs after every case, no GA generations
    assert learned.demo["epochs_while_teaching"] == ONLINE_BC.epochs_per_case * demo.n_cases
    assert "generations" not in learned.demo
    assert len(learned.fitness_best) == BC.epochs and learned.fitness_mean == []


def test_online_by_backprop_writes_the_bc_fit_of_its_cases(bc_run, tmp_path):
    """The controller is the bc learner's fit on all cases and their mirror images (generator
    ga_seed), made by the helper the bc and hg-dagger methods use, relabelled as online's."""
    out, learned = bc_run
    context = _context()
    demo = load_demonstration(out / "demonstration.lfdemo")
    memory, features = context["memory"], context["features"]
    x, a = with_mirrored(demo.policy_inputs(features), demo.commands, memory, features)
    fit = learner_for(BC).fit(x, a, np.random.default_rng(context["ga_seed"]))
    controller = learned.controller
    np.testing.assert_allclose(controller.weights, fit.weights, rtol=0, atol=1e-9)
    expected = controller_of_fit(
        MethodContext(tmp_path, settings=ONLINE_BC, **context), controller.library, fit, BC
    ).relabelled("online", {**ONLINE_BC.to_dict(), "bc": BC.to_dict()})
    assert controller.learner == "online" and controller.bias and controller.n_inputs == 3
    assert controller.learner_config == {**ONLINE_BC.to_dict(), "bc": BC.to_dict()}
    assert controller.learner_config["learner"] == "bc"
    mine, theirs = controller.to_dict(), expected.to_dict()
    assert set(mine) == set(theirs)
    assert {k: v for k, v in mine.items() if k not in ("weights", "fitness_history")} == {
        k: v for k, v in theirs.items() if k not in ("weights", "fitness_history")
    }


def test_online_by_backprop_is_deterministic(bc_run, tmp_path):
    _, first = bc_run
    again = learn_online(tmp_path, online=ONLINE_BC, **_context())
    assert again.effort == first.effort and again.demo == first.demo
    np.testing.assert_allclose(again.controller.weights, first.controller.weights, atol=1e-9)


def test_online_learner_setting_defaults_to_the_ga_and_refuses_what_it_cannot_use():
    # "ga", the default, is left out of the settings (files written before it still match)
    assert set(OnlineConfig().to_dict()) == {
        "generations_per_case",
        "window",
        "threshold",
        "intervention",
    }
    assert OnlineConfig.from_dict(ONLINE_BC.to_dict()) == ONLINE_BC
    assert ONLINE_BC.to_dict()["learner"] == "bc"
    bc = OnlineConfig(learner="bc", epochs_per_case=5)
    assert OnlineConfig.from_dict(bc.to_dict()) == bc
    with pytest.raises(ValueError, match="online learner must be one of ga, bc, got 'cma-es'"):
        OnlineConfig(learner="cma-es")
    with pytest.raises(ValueError, match="online epochs_per_case is for learner 'bc'"):
        OnlineConfig(epochs_per_case=5)
    with pytest.raises(ValueError, match="online generations_per_case is for learner 'ga'"):
        OnlineConfig(learner="bc", generations_per_case=4)
    with pytest.raises(ValueError, match="epochs_per_case"):
        dataclasses.replace(ONLINE_BC, epochs_per_case=0)


def test_online_by_backprop_needs_the_mlp(tmp_path):
    from lfd_track.methods import online

    context = MethodContext(
        tmp_path, demo_seed=1, ga_seed=2, settings=ONLINE_BC, policy_kind="elman-sigmoid"
    )
    with pytest.raises(ValueError, match="online learner 'bc' fits an MLP"):
        online.learn(context)


def test_a_study_condition_names_the_online_learner(tmp_path):
    body = (
        '[study]\nseeds = [0]\nrepetitions = 1\n[[conditions]]\nname = "o"\nmethod = "online"\n'
        '[conditions.online]\nlearner = "bc"\n'
    )
    path = tmp_path / "s.toml"
    path.write_text(body)
    study = load_study(path)
    assert study.conditions[0].config.settings_of() == ONLINE_BC
    path.write_text(body.replace('"bc"', '"sgd"'))
    with pytest.raises(FileFormatError, match="online learner must be one of ga, bc"):
        load_study(path)


def test_the_benchmark_flags_run_the_chosen_learner_online(tmp_path, capsys, monkeypatch):
    """``--method online --online-learner bc --bc-bias``: backprop with biases, the learner of
    the goal taught by the paper's human model; the flag is refused without ``--method
    online``."""
    from lfd_track.benchmark import runner

    class Stop(Exception):
        """The settings reached the run: stop before any work."""

    def fake_run_benchmark(config, work, *, workers, progress):
        raise Stop(config.settings_of(), config.bc)

    monkeypatch.setattr(runner, "run_benchmark", fake_run_benchmark)
    out = str(tmp_path / "out")
    assert main(["benchmark", "--online-learner", "bc", "--out", out]) == 2
    assert "--online-learner needs --method online" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["benchmark", "--method", "online", "--online-learner", "sgd", "--out", out])
    assert "invalid choice: 'sgd'" in capsys.readouterr().err
    # --bc-bias with a learner that does not use backprop is refused, not ignored.
    for method in (["--method", "online"], ["--method", "paper"], ["--method", "hg-dagger"]):
        assert main(["benchmark", *method, "--bc-bias", "--out", out]) == 2
        assert "--bc-bias is for learners that use backprop" in capsys.readouterr().err
        assert main(["benchmark", *method, "--bc-class-balance", "0.5", "--out", out]) == 2
        assert "--bc-class-balance is for learners that use backprop" in capsys.readouterr().err
        assert main(["benchmark", *method, "--bc-ensemble", "5", "--out", out]) == 2
        assert "--bc-ensemble is for learners that use backprop" in capsys.readouterr().err
    for wrong, problem in (("0", "must be at least 1, got 0"), ("65", "must be at most 64")):
        with pytest.raises(SystemExit):
            main(["benchmark", "--method", "bc", "--bc-ensemble", wrong, "--out", out])
        assert problem in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["benchmark", "--method", "bc", "--bc-class-balance", "1.5", "--out", out])
    assert "must be in 0..1, got 1.5" in capsys.readouterr().err
    balanced = ["--bc-bias", "--bc-class-balance", "0.5"]  # round 15's learner
    for flags, settings, bc in (
        (["--online-learner", "bc", *balanced], ONLINE_BC, BCConfig(bias=True, class_balance=0.5)),
        (
            ["--online-learner", "bc", "--bc-class-balance", "0"],
            ONLINE_BC,
            BCConfig(class_balance=0),
        ),
        (["--online-learner", "bc", "--bc-bias"], ONLINE_BC, BCConfig(bias=True)),
        (
            ["--online-learner", "bc", *balanced, "--bc-ensemble", "5"],  # round 20's learner
            ONLINE_BC,
            BCConfig(bias=True, class_balance=0.5, ensemble=5),
        ),
        ([], OnlineConfig(), BCConfig()),
    ):
        with pytest.raises(Stop) as stopped:
            main(["--quiet", "benchmark", "--method", "online", *flags, "--out", out])
        assert stopped.value.args == (settings, bc)


def test_online_by_backprop_learns_the_goal_map_with_its_branch_side(tmp_path):
    """The human-taught goal's chosen map (the branch side as a fourth input, expiring while the
    rover only pivots) runs on the learner the robot can run while it is taught: a 4-5-3 network,
    the demonstration recording the fourth input, the controller file its settings."""
    memory = FreshFeltConfig(branch_side=True, branch_window="commands")
    learned = learn_online(tmp_path, online=ONLINE_BC, **{**_context(), "memory": memory})
    controller = learned.controller
    assert controller.n_inputs == 4 and controller.memory == memory
    assert len(controller.weights) == 4 * 5 + 5 + 5 * 3 + 3
    demo = load_demonstration(tmp_path / "demonstration.lfdemo")
    sides = np.asarray(demo.policy_inputs("none"))[:, 3]
    assert set(np.unique(sides)) <= {0.0, 0.5, 1.0}
    assert (sides != 0.5).any()  # the side speaks at the demonstration's corners
    assert learned.training_accuracy >= 0.6


def test_online_by_backprop_learns_the_map_with_the_turn_toward_the_branch_side(tmp_path):
    """Round 17's map of the human-taught goal (a fifth input, the turn toward the branch side
    since it was set) on the same learner: a 5-5-3 network, the demonstration recording both
    inputs, the turn moving off 0.5 only while a side is known."""
    memory = FreshFeltConfig(branch_side=True, branch_window="commands", branch_turn=True)
    learned = learn_online(tmp_path, online=ONLINE_BC, **{**_context(), "memory": memory})
    controller = learned.controller
    assert controller.n_inputs == 5 and controller.memory == memory
    assert len(controller.weights) == 5 * 5 + 5 + 5 * 3 + 3
    inputs = np.asarray(load_demonstration(tmp_path / "demonstration.lfdemo").policy_inputs("none"))
    sides, turns = inputs[:, 3], inputs[:, 4]
    assert ((turns == 0.5) | (sides != 0.5)).all()  # no side, no turn
    assert (turns != 0.5).any()  # the demonstrator pivots while a side is known
    assert learned.training_accuracy >= 0.6


def test_an_ensemble_of_backprop_fits_is_the_controller_online_and_offline(tmp_path):
    """Round 20's learner: the final fit is k networks from their own starting weights (the
    first the single fit's), written in the controller file and driving by their mean outputs;
    the bc method (offline, after the demonstration) writes the same ensemble for its cases."""
    ensemble = BCConfig(epochs=300, bias=True, class_balance=0.5, ensemble=3)
    context = {**_context(), "bc": ensemble}
    learned = learn_online(tmp_path / "online", online=ONLINE_BC, **context)
    controller = learned.controller
    assert controller.members == 3 and controller.weights.shape == (3, 3 * 5 + 5 + 5 * 3 + 3)
    assert controller.learner_config["bc"]["ensemble"] == 3
    demo = load_demonstration(tmp_path / "online" / "demonstration.lfdemo")
    x, a = with_mirrored(demo.policy_inputs("none"), demo.commands, context["memory"], "none")
    single = learner_for(dataclasses.replace(ensemble, ensemble=1)).fit(
        x, a, np.random.default_rng(context["ga_seed"])
    )
    np.testing.assert_allclose(controller.weights[0], single.weights, rtol=0, atol=1e-9)
    assert learned.training_accuracy >= 0.6
    controller.save(tmp_path / "ensemble.json")
    loaded = Controller.load(tmp_path / "ensemble.json")
    assert loaded.members == 3
    rest = {k: v for k, v in context.items() if k != "bc"}
    offline = learn_baseline(tmp_path / "bc", **rest, learner=ensemble)
    assert offline.controller.members == 3 and offline.controller.learner == "bc"
    assert offline.controller.learner_config["ensemble"] == 3
