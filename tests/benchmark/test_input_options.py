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
