"""The ``dagger`` method: every visited state labelled by the (noise-free) human, cases aggregated,
the learner re-fitted after each round, the learning curve and the effort recorded."""

import dataclasses
import json

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict, repetition_seeds
from lfd_track.core.commands import Command
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.methods.dagger import DaggerConfig, labelling_human, learn_dagger
from lfd_track.policy.controller import Controller
from lfd_track.policy.mlp import n_weights
from lfd_track.world.driver import CentrelineDriver
from lfd_track.world.track import load_track


def _seeds():
    rng = np.random.default_rng(repetition_seeds(0, 1)[0])
    return tuple(int(x) for x in rng.integers(0, 2**62, size=3))


def _learn(folder, **settings):
    demo_seed, ga_seed, _ = _seeds()
    return learn_dagger(
        folder,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(legs=1),
        ga=GAConfig(generations=5),
        bc=BCConfig(epochs=30),
        dagger=DaggerConfig(**settings),
    )


@pytest.fixture(scope="module")
def two_rounds(tmp_path_factory):
    folder = tmp_path_factory.mktemp("dagger")
    return folder, _learn(folder, rounds=2)


def test_the_labeller_is_noise_free_unless_noise_is_kept():
    human = HumanConfig(reaction_delay_prob=0.3, lapse_prob=0.2, dead_band_deg=20.0)
    quiet = labelling_human(human, label_noise=False)
    assert quiet.reaction_delay_prob == 0.0 and quiet.lapse_prob == 0.0
    assert quiet.dead_band_deg == 20.0 and quiet.legs == 1 and quiet.library_only_commands == 0
    noisy = labelling_human(human, label_noise=True)
    assert (noisy.reaction_delay_prob, noisy.lapse_prob) == (0.3, 0.2)


def test_labels_are_what_the_noise_free_human_says_in_those_states(two_rounds):
    folder, learned = two_rounds
    driver_config = HumanConfig().driver
    for entry in learned.demo["rounds"][1:]:
        cases = load_demonstration(folder / f"labels_r{entry['round']}.lfdemo")
        assert cases.n_cases == entry["labels"] and (cases.rounds == entry["round"]).all()
        assert set(cases.phases) <= {"label", "intervention"} and "label" in set(cases.phases)
        # the two runs (one each way): the episode's step count starts again at 0
        starts = [0, *np.flatnonzero(np.diff(cases.steps) < 0) + 1]
        assert len(starts) == 2
        bounds = [*starts, cases.n_cases]
        for run, reverse in enumerate((False, True)):
            driver = CentrelineDriver(load_track("training", reverse=reverse), driver_config)
            previous = Command.FORWARD
            for i in range(bounds[run], bounds[run + 1]):
                expected = driver.act(cases.poses[i], float(cases.progress_m[i]))
                if {expected, previous} == {Command.LEFT, Command.RIGHT}:
                    expected = Command.FORWARD  # the human goes through forward
                assert cases.commands[i] == expected, f"round {entry['round']} case {i}"
                previous = Command(int(cases.commands[i]))


def test_every_round_aggregates_its_labels_and_records_the_curve(two_rounds):
    folder, learned = two_rounds
    curve = learned.demo["rounds"]
    assert [r["round"] for r in curve] == [0, 1, 2]
    demo_cases = load_demonstration(folder / "demonstration.lfdemo").n_cases
    assert curve[0]["cases"] == demo_cases
    for before, after in zip(curve, curve[1:], strict=False):
        assert after["labels"] > 0 and after["cases"] == before["cases"] + after["labels"]
        assert sum(after["interventions"].values()) == after["corrections"]
        assert len(after["runs"]) == 2 and 0 <= after["unaided_runs"] <= 2
    assert learned.demo["cases"] == curve[-1]["cases"]
    assert all(0.0 <= r["training_accuracy"] <= 1.0 for r in curve)
    assert learned.training_accuracy == curve[-1]["training_accuracy"]
    # fitted 1 + R times (5 GA generations each), the last fit on all cases is the controller
    assert len(learned.fitness_best) == 5 * len(curve)
    assert learned.controller.learner == "dagger"
    assert learned.controller.learner_config["rounds"] == 2
    assert learned.controller.learner_config["ga"] == GAConfig(generations=5).to_dict()


def test_effort_counts_every_label_as_a_human_command(two_rounds):
    folder, learned = two_rounds
    from lfd_track.envs.presets import load_preset

    demo = load_demonstration(folder / "demonstration.lfdemo")
    demo_commands = demo.metadata["commands"]  # library-only commands included
    effort = learned.effort
    labels = sum(r["labels"] for r in learned.demo["rounds"][1:])
    assert effort["labels"] == labels and effort["commands"] == demo_commands + labels
    assert labels >= effort["corrections"] >= 0
    autonomous = sum(r["autonomous_drive_s"] for r in learned.demo["rounds"][1:])
    assert effort["autonomous_drive_s"] == pytest.approx(autonomous)
    # every label is one command the robot executed (the policy's, or the human's when it
    # intervened): the robot drove one period per command of the demonstration and per label
    period = load_preset("paper").rover.control_period_s
    assert effort["learning_drive_s"] == pytest.approx((demo_commands + labels) * period)
    assert effort["learning_drive_s"] > effort["autonomous_drive_s"] > 0


def test_backprop_fits_a_wider_network_whose_file_drives_the_same(tmp_path):
    learned = _learn(tmp_path, rounds=1, learner="bc", hidden=8)
    controller = learned.controller
    assert controller.hidden == 8 and controller.weights.shape == (n_weights(False, 40, 8),)
    assert len(learned.fitness_best) == 30 * 2 and learned.demo["hidden"] == 8
    path = tmp_path / "controller.json"
    controller.save(path)
    assert json.loads(path.read_text())["layer_sizes"] == [40, 8, 3]
    again = Controller.load(path)
    assert again.hidden == 8
    values = np.random.default_rng(1).uniform(-1, 1, (20, 40))
    assert [again.act_on_values(v) for v in values] == [controller.act_on_values(v) for v in values]


def test_a_paper_width_controller_file_is_written_as_before(tmp_path):
    learned = _learn(tmp_path, rounds=1)
    path = tmp_path / "controller.json"
    learned.controller.save(path)
    data = json.loads(path.read_text())
    assert data["layer_sizes"] == [40, 5, 3] and len(data["weights"]) == 215
    assert Controller.load(path).hidden == 5


def test_dagger_settings_are_checked():
    assert DaggerConfig.from_dict(DaggerConfig(rounds=4).to_dict()) == DaggerConfig(rounds=4)
    with pytest.raises(ValueError, match="dagger hidden 20 needs learner 'bc'"):
        DaggerConfig(hidden=20)
    with pytest.raises(ValueError, match="dagger learner must be one of ga, bc"):
        DaggerConfig(learner="cma-es")
    with pytest.raises(ValueError, match="dagger hidden must be an integer in 1..1000"):
        DaggerConfig(learner="bc", hidden=0)
    with pytest.raises(ValueError, match="dagger rounds"):
        DaggerConfig(rounds=0)
    with pytest.raises(ValueError, match="label_noise"):
        DaggerConfig(label_noise=1)
    with pytest.raises(ValueError, match="unknown dagger setting 'noise'"):
        DaggerConfig.from_dict({"noise": True})


def test_every_run_records_the_dagger_settings():
    # results.json holds every setting, whichever method ran (older files are migrated on reading)
    assert config_dict(BenchmarkConfig())["dagger"] == DaggerConfig().to_dict()
    config = BenchmarkConfig(method="dagger", dagger=DaggerConfig(learner="bc", hidden=20))
    assert config_dict(config)["dagger"]["hidden"] == 20


def test_a_study_condition_names_dagger_settings(tmp_path):
    from lfd_track.errors import FileFormatError
    from lfd_track.study.spec import load_study

    body = (
        '[study]\nseeds = [0]\nrepetitions = 1\n[[conditions]]\nname = "d"\nmethod = "dagger"\n'
        '[conditions.dagger]\nlearner = "bc"\nhidden = 20\nrounds = 4\n'
    )
    path = tmp_path / "s.toml"
    path.write_text(body)
    study = load_study(path)
    assert study.conditions[0].config.dagger == DaggerConfig(learner="bc", hidden=20, rounds=4)
    path.write_text(body.replace('learner = "bc"\n', ""))
    with pytest.raises(FileFormatError, match="needs learner 'bc'"):
        load_study(path)
    path.write_text(body + "label_nois = true\n")
    with pytest.raises(FileFormatError, match="label_nois"):
        load_study(path)


def test_the_command_line_documents_and_checks_the_dagger_options(tmp_path, capsys):
    from lfd_track.cli import main

    with pytest.raises(SystemExit):
        main(["benchmark", "--help"])
    text = " ".join(capsys.readouterr().out.split())
    assert "dagger (rounds of runs where the human labels every visited state" in text
    assert "--hidden" in text and "--label-noise" in text
    out = str(tmp_path / "out")
    assert main(["benchmark", "--hidden", "20", "--out", out]) == 2
    assert "--hidden needs --method dagger" in capsys.readouterr().err
    assert main(["benchmark", "--method", "dagger", "--hidden", "20", "--out", out]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "needs learner 'bc'" in err
    assert not (tmp_path / "out").exists()


def test_dataclass_replace_keeps_dagger_checks():
    with pytest.raises(ValueError, match="needs learner 'bc'"):
        dataclasses.replace(DaggerConfig(learner="bc", hidden=20), learner="ga")
