"""The demonstrator's turn-around rules used by the corner-4 ablation."""

from __future__ import annotations

import pytest

from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import HumanConfig, run_demonstration


def test_one_sided_turnarounds_all_go_the_first_way(tmp_path):
    path = tmp_path / "d.lfdemo"
    summary = run_demonstration(
        path, seed=3, human=HumanConfig(turnarounds="one_sided"), fsync=False
    )
    assert summary.turnarounds == ("left", "left", "left", "left")
    demo = load_demonstration(path)
    turn_cmds = demo.commands[demo.phases == "turnaround"]
    assert len(turn_cmds) > 0 and set(turn_cmds.tolist()) == {1}  # left only


def test_unrecorded_turnarounds_are_driven_but_not_cases(tmp_path):
    path = tmp_path / "d.lfdemo"
    summary = run_demonstration(
        path, seed=3, human=HumanConfig(turnarounds="unrecorded"), fsync=False
    )
    demo = load_demonstration(path)
    assert summary.turnarounds == ("left", "right", "left", "right")  # still driven, alternating
    assert "turnaround" not in set(demo.phases.tolist())
    assert summary.commands > demo.n_cases + 10  # the turn-around commands were given
    assert demo.metadata["human"]["turnarounds"] == "unrecorded"


def test_unknown_turnaround_rule_is_rejected():
    with pytest.raises(ValueError, match="turnarounds must be one of"):
        HumanConfig(turnarounds="never")
