"""hg-dagger's rounds on a track of their own (``HGDaggerConfig.round_track``): a second track the
person lays out to watch the taught robot on."""

import pytest

from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.runner import check_tracks, repetition_seeds, repetition_streams
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.errors import LfdTrackError
from lfd_track.learning.ga import GAConfig
from lfd_track.methods import learn_hg_dagger
from lfd_track.methods.hg_dagger import HGDaggerConfig
from lfd_track.world.track import load_track


def _seeds() -> tuple[int, int]:
    """(demo, ga) seeds of repetition 0 of benchmark seed 0, as the runner draws them."""
    demo_seed, ga_seed, _ = repetition_streams(repetition_seeds(0, 1)[0])
    return demo_seed, ga_seed


def test_hg_dagger_rounds_drive_a_track_of_their_own(tmp_path):
    """``round_track``: the demonstration on one track, the rounds' interventions on another
    (every intervention case lies on the round track's felt, none is a demonstration case);
    the setting is written only when set, and a name that is no track fails before anything
    is learned."""
    demo_seed, ga_seed = _seeds()
    hg = HGDaggerConfig(rounds=1, round_track="testing")
    learned = learn_hg_dagger(
        tmp_path,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset="paper",
        human=HumanConfig(),
        ga=GAConfig(generations=5),
        hg=hg,
    )
    (r,) = learned.demo["rounds"]
    assert r["intervention_cases"] > 0
    poses = load_demonstration(tmp_path / "interventions_r1.lfdemo").poses[:, :2]
    demo_poses = load_demonstration(tmp_path / "demonstration.lfdemo").poses[:, :2]
    testing, training = load_track("testing"), load_track("training")
    assert testing.on_felt(poses).all() and not training.on_felt(poses).all()
    assert training.on_felt(demo_poses).all() and not testing.on_felt(demo_poses).all()
    assert learned.controller.learner_config["round_track"] == "testing"
    assert "round_track" not in HGDaggerConfig().to_dict()
    assert HGDaggerConfig.from_dict(hg.to_dict()) == hg
    with pytest.raises(ValueError, match="round_track must name a track"):
        HGDaggerConfig(round_track=" ")
    config = BenchmarkConfig(method="hg-dagger", hg_dagger=HGDaggerConfig(round_track="nowhere"))
    with pytest.raises(LfdTrackError, match="unknown track 'nowhere'"):
        check_tracks(config)


def test_the_benchmark_flag_gives_the_round_track(tmp_path, capsys, monkeypatch):
    """``--hg-dagger-round-track``: the rounds' track reaches the run's settings; without
    ``--method hg-dagger`` it is refused, and a track that does not load fails in one line before
    anything runs."""
    from lfd_track.benchmark import runner
    from lfd_track.cli import main

    class Stop(Exception):
        """The settings reached the run: stop before any work."""

    def fake_run_benchmark(config, work, *, workers, progress):
        raise Stop(config.settings_of())

    monkeypatch.setattr(runner, "run_benchmark", fake_run_benchmark)
    out = str(tmp_path / "out")
    flags = ["--method", "hg-dagger", "--hg-dagger-round-track", "testing", "--out", out]
    with pytest.raises(Stop) as stopped:
        main(["--quiet", "benchmark", *flags])
    assert stopped.value.args == (HGDaggerConfig(round_track="testing"),)
    assert main(["benchmark", "--hg-dagger-round-track", "testing", "--out", out]) == 2
    assert "--hg-dagger-round-track needs --method hg-dagger" in capsys.readouterr().err
    flags[3] = "nowhere"
    assert main(["benchmark", *flags]) != 0
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "unknown track 'nowhere'" in err[0], err
