"""The benchmark methods learn and drive with the colour features and the previous-command
memory, and every file they write says so."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict, repetition_seeds
from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.cmaes import CMAESConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.methods import (
    HGDaggerConfig,
    learn_baseline,
    learn_hg_dagger,
    learn_paper,
)
from lfd_track.policy.controller import Controller
from lfd_track.policy.elman import elman_sequence
from lfd_track.policy.memory import FreshFeltConfig, PreviousCommandConfig

COLOUR = "road_values+colour"
PREVIOUS = PreviousCommandConfig()


def _seeds() -> tuple[int, int]:
    rng = np.random.default_rng(repetition_seeds(0, 1)[0])
    demo_seed, ga_seed, _ = (int(x) for x in rng.integers(0, 2**62, size=3))
    return demo_seed, ga_seed


def test_hg_dagger_learns_and_drives_with_colour_and_the_previous_command(tmp_path):
    demo_seed, ga_seed = _seeds()
    learned = learn_hg_dagger(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(legs=1),
        ga=GAConfig(generations=5),
        hg=HGDaggerConfig(rounds=1),
        memory=PREVIOUS,
        mirror=True,
        features=COLOUR,
    )
    controller = learned.controller
    assert controller.features == COLOUR and controller.memory == PREVIOUS
    assert controller.n_inputs == 163 and controller.weights.shape == (5 * 163 + 15,)
    for name in ("demonstration.lfdemo", "interventions_r1.lfdemo"):
        demo = load_demonstration(tmp_path / name)
        assert demo.memory_settings() == PREVIOUS
        assert demo.policy_inputs(COLOUR).shape == (demo.n_cases, 163)
    path = tmp_path / "controller.json"
    controller.save(path)
    loaded = Controller.load(path)
    x = load_demonstration(tmp_path / "demonstration.lfdemo").policy_inputs(COLOUR)
    assert [loaded.act_on_values(v) for v in x] == [controller.act_on_values(v) for v in x]
    # The command line evolves the same inputs from the recording.
    out = tmp_path / "evolved.json"
    args = ["--quiet", "evolve", str(tmp_path / "demonstration.lfdemo"), "--generations", "2"]
    assert main([*args, "--features", COLOUR, "--out", str(out)]) == 0
    evolved = Controller.load(out)
    assert evolved.features == COLOUR and evolved.memory == PREVIOUS
    assert evolved.to_dict()["schema_version"] == 8


def test_bc_learns_the_colour_features_and_the_run_records_them(tmp_path):
    demo_seed, ga_seed = _seeds()
    learned = learn_baseline(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(legs=1),
        learner=BCConfig(epochs=200),
        features=COLOUR,
    )
    assert learned.controller.features == COLOUR and learned.controller.memory is None
    assert learned.training_accuracy > 0.6
    config = BenchmarkConfig(method="bc", features=COLOUR)
    assert config_dict(config)["features"] == COLOUR
    assert config_dict(BenchmarkConfig())["features"] == "road_values"  # every setting written


def test_dagger_learns_and_drives_a_network_that_reads_its_memory_alone(tmp_path, capsys):
    """Features "none": DAgger's demonstration, labels and controller hold the memory inputs
    only (the picture human's three map inputs, the bearing spread over +-30 deg), and the
    command line refuses the features without a memory in one line."""
    from lfd_track.methods.dagger import DaggerConfig, learn_dagger

    demo_seed, ga_seed = _seeds()
    narrow = FreshFeltConfig.plain(blank_bearing="last", bearing_range_deg=30.0)
    learned = learn_dagger(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(legs=1, steers_by="picture", reaction_delay_prob=0.0, lapse_prob=0.0),
        ga=GAConfig(generations=5),
        bc=BCConfig(epochs=100, bias=True),
        dagger=DaggerConfig(learner="bc", rounds=1),
        memory=narrow,
        features="none",
    )
    controller = learned.controller
    assert controller.features == "none" and controller.memory == narrow
    assert controller.n_inputs == 3 and controller.weights.shape == (5 * 3 + 5 + 3 * 5 + 3,)
    labels = load_demonstration(tmp_path / "labels_r1.lfdemo")
    assert labels.policy_inputs("none").shape == (labels.n_cases, 3)
    assert labels.memory_settings() == narrow
    path = tmp_path / "controller.json"
    controller.save(path)
    loaded = Controller.load(path)
    x = labels.policy_inputs("none")
    assert [loaded.act_on_values(v) for v in x] == [controller.act_on_values(v) for v in x]
    plain = tmp_path / "plain.lfdemo"
    args = ["--quiet", "evolve", str(plain), "--generations", "2", "--features", "none"]
    from lfd_track.demo.demonstrator import run_demonstration

    run_demonstration(plain, seed=demo_seed, human=HumanConfig(legs=1), fsync=False)
    assert main([*args, "--out", str(tmp_path / "none.json")]) != 0
    assert not (tmp_path / "none.json").exists()
    assert "--features none reads the memory inputs alone" in capsys.readouterr().err


def test_both_learners_train_an_elman_network_and_the_run_records_it(tmp_path):
    """method "paper" evolves an Elman network and method "bc" trains one by backprop through
    time, over the demonstration's cases in order; the controller files say so and drive."""
    demo_seed, ga_seed = _seeds()
    common = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", human=HumanConfig(legs=1))
    evolved = learn_paper(
        tmp_path / "ga", ga=GAConfig(generations=5), policy_kind="elman-sigmoid", **common
    )
    trained = learn_baseline(
        tmp_path / "bc", learner=BCConfig(epochs=30), policy_kind="elman-sigmoid", **common
    )
    for learned, learner in ((evolved, "ga"), (trained, "bc")):
        controller = learned.controller
        assert controller.policy_kind == "elman-sigmoid" and controller.learner == learner
        assert controller.to_dict()["layer_sizes"] == [45, 5, 3]
        assert 0.0 <= learned.training_accuracy <= 1.0
    # The training accuracy is the sequence run's: the context carried from case to case.
    demo = load_demonstration(tmp_path / "bc" / "demonstration.lfdemo")
    controller = trained.controller
    controller.reset()
    decisions = np.array([controller.act_on_values(v) for v in demo.inputs])
    out = elman_sequence(controller.weights[None], demo.inputs, bias=False)[0]
    assert trained.training_accuracy == pytest.approx((out.argmax(axis=1) == demo.commands).mean())
    assert decisions.shape == (demo.n_cases,)
    with pytest.raises(ValueError, match="not CMA-ES"):
        learn_baseline(
            tmp_path / "cma", learner=CMAESConfig(), policy_kind="elman-sigmoid", **common
        )


def test_the_policy_kind_is_a_benchmark_option_of_the_paper_and_bc_methods():
    assert config_dict(BenchmarkConfig(policy_kind="elman-sigmoid"))["policy_kind"] == (
        "elman-sigmoid"
    )
    assert config_dict(BenchmarkConfig())["policy_kind"] == "mlp-sigmoid"
    BenchmarkConfig(method="bc", policy_kind="elman-sigmoid")
    for method in ("online", "hg-dagger", "dagger", "cma-es"):
        with pytest.raises(ValueError, match="trained by the methods paper"):
            BenchmarkConfig(method=method, policy_kind="elman-sigmoid")
    with pytest.raises(ValueError, match="unknown policy_kind 'lstm'"):
        BenchmarkConfig(policy_kind="lstm")
    with pytest.raises(ValueError, match="shifted_views have no place"):
        BenchmarkConfig(policy_kind="elman-sigmoid", shifted_views=True)


def test_benchmark_takes_the_policy_kind_from_the_command_line(tmp_path):
    out = tmp_path / "bench"
    argv = ["--quiet", "benchmark", "--quick", "--workers", "1", "--out", str(out)]
    assert main([*argv, "--policy-kind", "elman-sigmoid"]) == 0
    results = json.loads((out / "results.json").read_text())
    assert results["config"]["policy_kind"] == "elman-sigmoid"
    controller = Controller.load(out / "repetitions" / "rep_00" / "controller.json")
    assert controller.policy_kind == "elman-sigmoid"
    assert "an Elman network" in (out / "report.md").read_text()
