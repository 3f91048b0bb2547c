"""The benchmark methods learn and drive with the colour features and the previous-command
memory, and every file they write says so."""

from __future__ import annotations

import numpy as np

from lfd_track.benchmark.methods import HGDaggerConfig, learn_baseline, learn_hg_dagger
from lfd_track.benchmark.runner import BenchmarkConfig, config_dict, repetition_seeds
from lfd_track.cli import main
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import BCConfig
from lfd_track.learning.ga import GAConfig
from lfd_track.policy.controller import Controller
from lfd_track.policy.memory import MemoryConfig

COLOUR = "road_values+colour"
PREVIOUS = MemoryConfig(kind="previous_command")


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
    assert evolved.to_dict()["schema_version"] == 4


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
    assert "features" not in config_dict(BenchmarkConfig())


def test_dagger_learns_and_drives_a_network_that_reads_its_memory_alone(tmp_path, capsys):
    """Features "none": DAgger's demonstration, labels and controller hold the memory inputs
    only (the picture human's three map inputs, the bearing spread over +-30 deg), and the
    command line refuses the features without a memory in one line."""
    from lfd_track.benchmark.dagger import DaggerConfig, learn_dagger

    demo_seed, ga_seed = _seeds()
    narrow = MemoryConfig(kind="fresh_felt", blank_bearing="last", bearing_range_deg=30.0)
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
