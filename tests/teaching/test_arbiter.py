import pytest

from lfd_track.core.commands import Command
from lfd_track.teaching.arbiter import Arbiter

F, L, R = Command.FORWARD, Command.LEFT, Command.RIGHT


def test_human_and_policy_modes_execute_their_commander():
    assert Arbiter("human").decide(L, R).command == L
    assert Arbiter("human").decide(None, R).command is None
    decision = Arbiter("policy").decide(L, R)
    assert decision.command == R and decision.driver == "policy"


def test_policy_takes_over_after_agreeing_on_k_of_the_last_k():
    arbiter = Arbiter("takeover", window=4, threshold=0.75)
    # 2 of 3 agree: window not full yet
    for human, policy in [(F, F), (L, R), (F, F)]:
        assert arbiter.decide(human, policy).driver == "human"
    assert arbiter.agreement_count == 3 and arbiter.agreement == pytest.approx(2 / 3)
    decision = arbiter.decide(F, F)  # 3 of the last 4 = 0.75: earned
    assert decision.takeover and decision.command == F and arbiter.driving == "policy"
    decision = arbiter.decide(None, L)
    assert decision.driver == "policy" and decision.command == L and not decision.correction


def test_a_human_command_while_the_policy_drives_is_a_correction():
    arbiter = Arbiter("takeover", window=2, threshold=1.0)
    arbiter.decide(F, F)
    assert arbiter.decide(F, F).takeover
    decision = arbiter.decide(R, F)
    assert decision.correction and decision.command == R and decision.driver == "human"
    assert arbiter.driving == "human" and arbiter.agreement_count == 0
    assert arbiter.corrections == 1 and arbiter.takeovers == 1
    # it has to earn the wheel again from scratch
    assert not arbiter.decide(F, F).takeover
    assert arbiter.decide(F, F).takeover


def test_disagreement_keeps_the_human_driving():
    arbiter = Arbiter("takeover", window=3, threshold=1.0)
    for _ in range(10):
        arbiter.decide(F, F)
        arbiter.decide(L, F)
    assert arbiter.driving == "human" and arbiter.takeovers == 0


def test_an_offer_waits_for_acceptance_without_auto_accept():
    arbiter = Arbiter("takeover", window=2, threshold=1.0, auto_accept=False)
    arbiter.decide(F, F)
    assert not arbiter.decide(F, F).takeover and arbiter.offer
    arbiter.accept()
    assert arbiter.decide(F, F).takeover and arbiter.driving == "policy"


def test_policy_may_start_driving_and_reset_restores_it():
    arbiter = Arbiter("takeover", initial_driver="policy")
    assert arbiter.decide(None, L).driver == "policy"
    assert arbiter.decide(R, L).correction
    arbiter.reset()
    assert arbiter.driving == "policy"


def test_bad_settings():
    with pytest.raises(ValueError, match="mode"):
        Arbiter("robot")
    with pytest.raises(ValueError, match="threshold"):
        Arbiter("takeover", threshold=0)
    with pytest.raises(ValueError, match="window"):
        Arbiter("takeover", window=0)
