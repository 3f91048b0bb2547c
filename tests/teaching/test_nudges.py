"""The teacher's deliberate nudges (``HumanConfig.nudge_prob``): pivots pressed on purpose while
the human drives, executed but not recorded, so the recovery that follows is taught."""

from __future__ import annotations

import dataclasses

import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.dataset import load_demonstration
from lfd_track.demo.demonstrator import run_demonstration
from lfd_track.teaching.scripted import HumanConfig


def _demo(tmp_path, name: str, human: HumanConfig):
    out = tmp_path / f"{name}.lfdemo"
    summary = run_demonstration(out, seed=3, human=human, fsync=False)
    return summary, load_demonstration(out)


def test_nudges_are_executed_not_recorded_and_the_demonstration_still_finishes(tmp_path):
    plain_summary, plain = _demo(tmp_path, "plain", HumanConfig())
    nudged_summary, nudged = _demo(tmp_path, "nudged", HumanConfig(nudge_prob=0.2))
    library_only = HumanConfig().library_only_commands
    # Without nudges every command after the library-only start is a case; with them, the
    # nudges are the difference (each counted as a command, none recorded).
    assert plain_summary.commands - library_only == len(plain.commands)
    missing = nudged_summary.commands - library_only - len(nudged.commands)
    assert 0.1 * nudged_summary.commands < missing < 0.3 * nudged_summary.commands
    # The robot was knocked off the human's line and brought back: the demonstration is longer.
    assert nudged_summary.commands > plain_summary.commands


def test_no_nudges_draw_nothing_and_are_left_out_of_results(tmp_path):
    """``nudge_prob = 0`` (the default) draws nothing from the human's stream, so a run without
    nudges is the run it was before the setting existed, and its results omit the setting."""
    _, first = _demo(tmp_path, "a", HumanConfig())
    _, again = _demo(tmp_path, "b", HumanConfig(nudge_prob=0.0))
    assert (first.commands == again.commands).all() and (first.steps == again.steps).all()
    assert "nudge_prob" not in config_dict(BenchmarkConfig())["human"]
    nudged = dataclasses.replace(BenchmarkConfig(), human=HumanConfig(nudge_prob=0.1))
    assert config_dict(nudged)["human"]["nudge_prob"] == 0.1
    assert BenchmarkConfig.from_dict(config_dict(nudged)).human.nudge_prob == 0.1


@pytest.mark.parametrize("bad", [-0.1, 0.6, float("nan")])
def test_bad_nudge_chances_are_refused(bad):
    with pytest.raises(ValueError, match="nudge_prob"):
        HumanConfig(nudge_prob=bad)


def test_nudges_on_the_last_pivot_press_the_pivot_the_human_last_gave(tmp_path, monkeypatch):
    """``nudge_side = "last_pivot"``: a nudge presses the pivot the human itself last gave while
    driving the leg (a random side before its first), so at a corner it turns the robot on past
    where the human would stop; the setting is written to results only when not "random"."""
    from lfd_track.core.commands import Command
    from lfd_track.teaching.scripted import PHASE_DRIVE, ProtocolHuman

    pressed: list[tuple[Command, bool, str, int]] = []
    propose = ProtocolHuman.propose

    def logged(self, moment):
        command = propose(self, moment)
        if command is not None:
            pressed.append((command, self._nudged, self.phase, self.leg))
        return command

    monkeypatch.setattr(ProtocolHuman, "propose", logged)
    human = HumanConfig(nudge_prob=0.2, nudge_side="last_pivot")
    summary, demo = _demo(tmp_path, "last", human)
    followed, first = 0, 0
    last: dict[int, Command] = {}  # per leg: the human's own last pivot while driving it
    for command, nudged, phase, leg in pressed:
        if nudged:
            if leg in last:
                assert command == last[leg]
                followed += 1
            else:
                first += 1
        elif phase == PHASE_DRIVE and command != Command.FORWARD:
            last[leg] = command
    assert followed > 10 and summary.commands - len(demo.commands) >= followed + first
    assert {c for c, nudged, _, _ in pressed if nudged} == {Command.LEFT, Command.RIGHT}
    assert "nudge_side" not in config_dict(BenchmarkConfig())["human"]
    config = dataclasses.replace(BenchmarkConfig(), human=human)
    assert config_dict(config)["human"]["nudge_side"] == "last_pivot"
    assert BenchmarkConfig.from_dict(config_dict(config)).human == human
    with pytest.raises(ValueError, match="nudge_side"):
        HumanConfig(nudge_side="left")
