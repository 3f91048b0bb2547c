"""The ``bc`` method's fits chosen by watching them drive (``lfd_track/methods/watched.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.benchmark.config import BenchmarkConfig
from lfd_track.benchmark.runner import repetition_streams
from lfd_track.cli import main
from lfd_track.demo.demonstrator import HumanConfig
from lfd_track.learning.bc import MAX_WATCHED_FITS, BCConfig
from lfd_track.methods import baseline, learn_baseline, watched


def test_watched_fits_is_recorded_only_when_it_chooses():
    assert "watched_fits" not in BCConfig().to_dict()  # files written before it match theirs
    assert BCConfig(watched_fits=3).to_dict()["watched_fits"] == 3
    assert BCConfig.from_dict(BCConfig(watched_fits=3).to_dict()) == BCConfig(watched_fits=3)
    for bad in (0, MAX_WATCHED_FITS + 1, 2.0):
        with pytest.raises(ValueError, match="watched_fits"):
            BCConfig(watched_fits=bad)


def test_only_the_bc_method_watches_its_fits():
    BenchmarkConfig(method="bc", bc=BCConfig(watched_fits=2))
    with pytest.raises(ValueError, match="watched_fits .* not with method 'paper'"):
        BenchmarkConfig(method="paper", bc=BCConfig(watched_fits=2))
    with pytest.raises(ValueError, match="policy_kind 'elman-sigmoid'"):
        BenchmarkConfig(method="bc", bc=BCConfig(watched_fits=2), policy_kind="elman-sigmoid")


@pytest.mark.parametrize(
    ("laps", "fits", "chosen"),
    [
        ([4], 3, 0),  # every watched lap lapped: no second fit
        ([2, 4], 3, 1),
        ([1, 3, 2], 3, 1),  # the most laps, not the last fit
        ([2, 2], 2, 0),  # ties go to the earlier fit; no more than `fits`
        ([3, 1, 3], 3, 0),
    ],
)
def test_the_fit_that_lapped_most_is_kept(monkeypatch, laps, fits, chosen):
    told = iter(laps)
    monkeypatch.setattr(watched, "watched_laps", lambda context, controller, counts: next(told))
    drawn = iter(range(1, 10))
    got = watched.choose_by_watching(
        None, fits, lambda: f"fit {next(drawn)}", lambda fit: ("controller", fit), "fit 0"
    )
    assert got.lapped == tuple(laps) and got.chosen == chosen
    assert got.fit == f"fit {chosen}" and got.controller == ("controller", f"fit {chosen}")
    assert got.laps == 2 * watched.WATCHED_LAPS * len(laps)
    assert got.record() == {"laps_each": 4, "lapped": laps, "chosen": chosen}


def test_the_bc_method_watches_on_the_demonstration_track(monkeypatch, tmp_path):
    """Real laps of the demonstration track: the first fit watched is the unwatched fit, the
    record says what was watched, and the watched laps are robot time, not human commands."""
    demo_seed, ga_seed, _ = repetition_streams(0)
    kwargs = dict(demo_seed=demo_seed, ga_seed=ga_seed, preset="paper", human=HumanConfig(legs=1))
    plain = learn_baseline(tmp_path / "plain", **kwargs, learner=BCConfig(epochs=50))
    firsts = []

    def spy(context, fits, fit_again, controller_of, first):
        firsts.append(first)
        return watched.choose_by_watching(context, fits, fit_again, controller_of, first)

    monkeypatch.setattr(baseline, "choose_by_watching", spy)
    seen = learn_baseline(
        tmp_path / "watched", **kwargs, learner=BCConfig(epochs=50, watched_fits=2)
    )
    np.testing.assert_allclose(firsts[0].weights, plain.controller.weights, rtol=0, atol=1e-12)
    record = seen.demo["watched"]
    assert record["laps_each"] == 4 and 1 <= len(record["lapped"]) <= 2
    assert all(0 <= n <= 4 for n in record["lapped"])
    assert record["lapped"][record["chosen"]] == max(record["lapped"])
    assert (len(record["lapped"]) == 1) == (record["lapped"][0] == 4)
    assert seen.effort["watched_laps"] == 4 * len(record["lapped"])
    assert seen.effort["commands"] == plain.effort["commands"]  # no human command more
    assert seen.effort["autonomous_drive_s"] > 0 == plain.effort["autonomous_drive_s"]
    assert seen.controller.learner_config["watched_fits"] == 2


def test_the_benchmark_flag_is_refused_in_one_line_where_nothing_is_watched(tmp_path, capsys):
    out = str(tmp_path / "out")
    for method in ("paper", "online", "hg-dagger"):
        assert main(["benchmark", "--method", method, "--bc-watched-fits", "2", "--out", out]) == 2
        err = capsys.readouterr().err
        assert "watched_fits" in err and f"method '{method}'" in err and len(err.splitlines()) == 1
    for wrong, problem in (("0", "at least 1"), (str(MAX_WATCHED_FITS + 1), "at most")):
        with pytest.raises(SystemExit):
            main(["benchmark", "--method", "bc", "--bc-watched-fits", wrong, "--out", out])
        assert problem in capsys.readouterr().err
    assert not (tmp_path / "out").exists()
