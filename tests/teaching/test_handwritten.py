"""The hand-written road-value rule and the scripted human's model options."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.core.commands import Command
from lfd_track.policy.memory import UNKNOWN_SIDE, TurnMemory
from lfd_track.teaching.handwritten import RoadRule, RoadRuleConfig
from lfd_track.teaching.scripted import HumanConfig, ScriptedHuman

CARPET, FELT = 0.2, 0.7


def view(columns: list[int]) -> np.ndarray:
    """Road values (40,) with felt in the given grid columns of every row, carpet elsewhere."""
    grid = np.full((5, 8), CARPET)
    grid[:, columns] = FELT
    return grid.ravel()


BLANK = np.full(40, CARPET)


def test_reactive_rule_steers_toward_the_felt():
    rule = RoadRule(RoadRuleConfig())
    assert rule.act(view([3, 4])) == Command.FORWARD
    assert rule.act(view([0, 1])) == Command.LEFT
    assert rule.act(view([6, 7])) == Command.RIGHT
    assert rule.blank_frames == 0


def test_reactive_rule_on_a_blank_view_turns_to_the_fainter_felt_side():
    rule = RoadRule(RoadRuleConfig())
    faint_right = BLANK.copy().reshape(5, 8)
    faint_right[:, 7] = 0.28  # below the carpet level: no felt in view, only a hint
    assert rule.act(faint_right.ravel()) == Command.RIGHT
    assert rule.act(BLANK) == Command.LEFT  # no hint: the default turn
    assert RoadRule(RoadRuleConfig(default_turn="right")).act(BLANK) == Command.RIGHT
    assert rule.blank_frames == 2


def test_latch_flips_on_a_bend_and_decides_blank_views():
    cfg = RoadRuleConfig(latch=True, default_turn="left")
    memory = TurnMemory(cfg.memory)
    rule = RoadRule(cfg)
    faint_left = BLANK.copy().reshape(5, 8)
    faint_left[:, 0] = 0.28
    faint_left = faint_left.ravel()
    assert memory.side == UNKNOWN_SIDE
    assert rule.act(faint_left, memory.side) == Command.LEFT  # no bend yet: like the reactive
    for _ in range(3):
        memory.note(Command.RIGHT)  # a right bend
    assert memory.side == 0.0
    assert rule.act(faint_left, memory.side) == Command.RIGHT  # the latch wins over the hint
    memory.note(Command.LEFT)  # one pivot back: a wobble, not a bend
    assert rule.act(BLANK, memory.side) == Command.RIGHT
    memory.note(Command.LEFT)
    assert memory.side == 1.0  # two net pivots left: a left bend
    assert rule.act(BLANK, memory.side) == Command.LEFT
    assert rule.act(view([3, 4]), memory.side) == Command.FORWARD  # felt in view: no latch
    # Without the latch option the side input is ignored.
    assert RoadRule(RoadRuleConfig()).act(BLANK, 0.0) == Command.LEFT


def test_seen_latch_turns_toward_where_the_felt_was_last_seen():
    rule = RoadRule(RoadRuleConfig(seen_latch=True))
    faint_left = BLANK.copy().reshape(5, 8)
    faint_left[:, 0] = 0.28
    faint_left = faint_left.ravel()
    assert rule.act(BLANK) == Command.LEFT  # nothing seen yet: the default turn
    assert rule.act(view([5, 6])) == Command.RIGHT  # felt right of centre
    assert rule.act(faint_left) == Command.RIGHT  # the last-seen side wins over the hint
    assert rule.act(BLANK) == Command.RIGHT
    assert rule.act(view([3, 4])) == Command.FORWARD  # centred: no side is noted
    assert rule.act(BLANK) == Command.RIGHT
    assert rule.act(view([2, 3])) == Command.FORWARD  # slightly left: noted, not steered
    assert rule.act(BLANK) == Command.LEFT
    rule.reset()
    assert rule.last_seen is None
    # The same views without the option: the blank views go the fainter-felt or default way.
    plain = RoadRule(RoadRuleConfig())
    assert plain.act(view([5, 6])) == Command.RIGHT
    assert plain.act(faint_left) == Command.LEFT


def test_rule_reads_the_latch_from_the_policy_inputs():
    class Moment:
        policy_inputs = np.concatenate([BLANK, [0.0]])

    assert RoadRule(RoadRuleConfig(latch=True)).propose(Moment()) == Command.RIGHT
    assert RoadRule(RoadRuleConfig()).propose(Moment()) == Command.LEFT


@pytest.mark.parametrize(
    "kwargs",
    [
        {"carpet": 0.6, "felt": 0.5},
        {"row_weights": (1.0, 1.0)},
        {"row_weights": (1.0, 1.0, 1.0, 1.0, -1.0)},
        {"turn_at": -1.0},
        {"default_turn": "up"},
        {"latch": True, "seen_latch": True},
    ],
)
def test_bad_rule_settings_are_refused(kwargs):
    with pytest.raises(ValueError):
        RoadRuleConfig(**kwargs)


class ScriptedDriver:
    """Stands in for the centreline driver: intends the given commands in turn."""

    def __init__(self, commands: list[Command]) -> None:
        self.commands = iter(commands)

    def act(self, pose, progress_m):
        return next(self.commands)


INTENDED = [Command.FORWARD, Command.LEFT, Command.LEFT, Command.FORWARD, Command.FORWARD] * 80


def drive(config: HumanConfig, seed: int = 0) -> list[Command]:
    person = ScriptedHuman(config, np.random.default_rng(seed))
    driver = ScriptedDriver(INTENDED)
    return [person.decide(driver, np.zeros(3), 0.0) for _ in INTENDED]


def test_noise_free_human_never_lapses_or_answers_late():
    quiet = HumanConfig(reaction_delay_prob=0.0, lapse_prob=0.0)
    for seed in range(5):
        assert drive(quiet, seed) == INTENDED


def test_default_human_is_noisy_and_its_defaults_are_the_papers():
    assert drive(HumanConfig()) != INTENDED
    assert drive(HumanConfig()) == drive(HumanConfig())  # same stream, same answers
    cfg = HumanConfig()
    assert (cfg.dead_band_deg, cfg.lookahead_m) == (15.0, 0.35)
    assert (cfg.reaction_delay_prob, cfg.lapse_prob, cfg.turnarounds) == (0.10, 0.03, "alternate")
    noisier = HumanConfig(reaction_delay_prob=0.3, lapse_prob=0.1)
    differs = sum(a != b for a, b in zip(drive(noisier), INTENDED, strict=True))
    assert differs > sum(a != b for a, b in zip(drive(cfg), INTENDED, strict=True))


def test_turnarounds_toward_the_next_bend_mirror_the_last_bend_rule(tmp_path):
    from lfd_track.demo.demonstrator import run_demonstration

    summaries = {
        rule: run_demonstration(
            tmp_path / f"{rule}.lfdemo",
            seed=0,
            human=HumanConfig(turnarounds=rule, legs=2),
            fsync=False,
        ).turnarounds
        for rule in ("toward_last_bend", "toward_next_bend")
    }
    assert summaries["toward_last_bend"] == ("right", "left")
    assert summaries["toward_next_bend"] == ("left", "right")
