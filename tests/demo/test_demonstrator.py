"""The scripted human and the demonstration protocol meet DESIGN §6's calibration targets."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.demo.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig, run_demonstration


@pytest.fixture(scope="module")
def default_demo(tmp_path_factory):
    path = tmp_path_factory.mktemp("demo") / "d.lfdemo"
    summary = run_demonstration(path, seed=3, fsync=False)
    return summary, load_demonstration(path)


def test_default_demonstration_meets_the_calibration_targets(default_demo):
    summary, demo = default_demo
    assert 120 <= demo.n_cases <= 200
    assert summary.library_models >= 40
    counts = demo.command_counts
    assert counts["forward"] > demo.n_cases / 2
    assert summary.turnarounds == ("left", "right", "left", "right")
    assert summary.learned_off_felt == 0
    assert (
        summary.off_felt_frames > 0
    )  # the box did leave the felt (turn-arounds): the pause mattered
    # No case marked as learned was recorded with the box off the felt.
    assert demo.metadata["complete"] is True
    assert demo.metadata["road_library"]["bins"] == demo.bins


def test_library_only_commands_are_not_recorded_and_turnarounds_are(default_demo):
    summary, demo = default_demo
    assert summary.commands == demo.n_cases + 10
    assert demo.steps[0] == 10
    phases = set(demo.phases.tolist())
    assert phases == {"drive", "turnaround"}
    turn_cmds = demo.commands[demo.phases == "turnaround"]
    assert set(turn_cmds.tolist()) == {1, 2}
    # As many left as right turn-around commands, within one turn-around's worth.
    assert abs(int((turn_cmds == 1).sum()) - int((turn_cmds == 2).sum())) <= 4


def test_record_time_values_come_from_the_stored_histograms(default_demo):
    _, demo = default_demo
    assert demo.road_values.shape == (demo.n_cases, 40)
    assert demo.histograms.shape == (demo.n_cases, 40, 5, 32)
    assert np.all(np.abs(demo.road_values) <= 1.0 + 1e-9)
    assert np.isfinite(demo.poses).all()


def test_careless_demonstrator_learns_carpet(tmp_path):
    summary = run_demonstration(
        tmp_path / "careless.lfdemo", seed=3, human=HumanConfig(careful=False), fsync=False
    )
    assert summary.learned_off_felt > 0


def test_same_seed_same_demonstration(tmp_path):
    a = run_demonstration(tmp_path / "a.lfdemo", seed=5, fsync=False)
    b = run_demonstration(tmp_path / "b.lfdemo", seed=5, fsync=False)
    da, db = load_demonstration(tmp_path / "a.lfdemo"), load_demonstration(tmp_path / "b.lfdemo")
    assert a.n_cases == b.n_cases
    assert np.array_equal(da.commands, db.commands)
    assert np.array_equal(da.road_values, db.road_values)


def test_human_traits_are_validated():
    with pytest.raises(ValueError, match="lapse_prob"):
        HumanConfig(lapse_prob=1.5)
    with pytest.raises(ValueError, match="first_turnaround"):
        HumanConfig(first_turnaround="up")


def test_loop_tracks_are_refused(tmp_path):
    with pytest.raises(ValueError, match="open track"):
        run_demonstration(tmp_path / "x.lfdemo", seed=0, track="testing", fsync=False)
