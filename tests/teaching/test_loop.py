import threading
import time

import gymnasium as gym
import numpy as np
import pytest
from lfd_test_support import library_with_road

from lfd_track.core.commands import Command
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.teaching import (
    Arbiter,
    Perception,
    PolicyCommander,
    QueueCommander,
    TeachingLoop,
    TrajectoryObserver,
)
from lfd_track.teaching.observers import CaseBuffer
from lfd_track.vision.road_library import RoadLibrary


def test_look_never_mutates_but_perceive_does():
    library, frame = library_with_road()
    before = library.to_dict()
    perception = Perception(library, "careful")
    values = perception.look(frame)
    assert library.to_dict() == before
    perception.rule = "paused"
    percept = perception.perceive(frame, box_on_felt=True)
    np.testing.assert_array_equal(percept.values, values)
    assert not percept.learned and library.to_dict() != before  # selections were counted


@pytest.mark.parametrize(
    ("rule", "box_on_felt", "learns"),
    [
        ("careful", True, True),
        ("careful", False, False),
        ("careful", None, True),
        ("paused", True, False),
        ("frozen", True, False),
        ("always", False, True),
    ],
)
def test_learning_rules(rule, box_on_felt, learns):
    library, frame = library_with_road()
    n = library.n_models
    stats = library.type_statistics()
    percept = Perception(library, rule).perceive(frame, box_on_felt=box_on_felt)
    assert percept.learned == learns
    assert (library.n_models > n) == learns
    if rule == "frozen":
        assert library.type_statistics() == stats  # not even the selection counts
    if rule == "paused":
        assert library.type_statistics() != stats  # selections still count while teaching


def test_bad_rule():
    with pytest.raises(ValueError, match="careful"):
        Perception(RoadLibrary(), "sometimes")


def test_queue_commander_fed_from_another_thread_drives_the_loop_one_step_at_a_time():
    library, _ = library_with_road()
    keys = QueueCommander()
    cases = CaseBuffer()
    trajectory = TrajectoryObserver()
    env = LfDTrackEnv(track="training")
    loop = TeachingLoop(
        env,
        Perception(library, "careful"),
        Arbiter("human"),
        human=keys,
        observers=[cases, trajectory],
    )
    loop.reset(seed=3)
    before = library.to_dict()
    assert loop.step().command is None  # nobody pressed anything: the robot waits
    assert loop.counts.steps == 0
    assert library.to_dict() == before  # ... and waiting neither learns nor counts
    pusher = threading.Thread(target=keys.push, args=(Command.LEFT,))
    pusher.start()
    pusher.join()
    step = loop.step()
    assert step.command == Command.LEFT and step.is_case
    assert loop.step().command is None  # one push is one command
    assert loop.counts.human_commands == 1 and cases.commands == [1]
    assert trajectory.array().shape == (2, 2)
    env.close()


def test_policy_commander_without_weights_has_no_opinion():
    policy = PolicyCommander(None)
    assert policy.act_on_values(np.zeros(40)) is None
    policy.weights = np.zeros(215)  # every output ties: first index with no previous command
    assert policy.act_on_values(np.linspace(-1, 1, 40)) == Command.FORWARD


def test_a_release_during_perception_still_runs_the_command_the_frame_was_perceived_for():
    """The browser's button comes up while the loop perceives (another thread): the perceived
    frame still gets its command, so no frame is learned or counted without one."""
    from lfd_track.web.commander import BrowserCommander

    library, _ = library_with_road()
    buttons = BrowserCommander()

    class ReleasingPerception(Perception):
        def perceive(self, frame, box_on_felt=None):
            percept = super().perceive(frame, box_on_felt)
            buttons.release()  # the page's button-up arrives mid-step
            return percept

    env = LfDTrackEnv(track="training")
    loop = TeachingLoop(
        env, ReleasingPerception(library, "paused"), Arbiter("human"), human=buttons
    )
    loop.reset(seed=3)
    buttons.press(Command.FORWARD)
    assert loop.step().command == Command.FORWARD  # the queued press
    buttons.press(Command.LEFT)
    buttons.next_command()  # the tap already ran; the button is still held when the loop looks
    before = library.type_statistics()
    step = loop.step()
    assert step.command == Command.LEFT  # claimed while held, run although released since
    after = library.type_statistics()
    assert sum(n for _, n in after) - sum(n for _, n in before) == 40  # one frame, one count
    assert loop.step().command is None and not buttons.pending  # released: the robot waits
    assert library.type_statistics() == after
    env.close()


class _SlowPolicy:
    """A policy commander that takes ``seconds`` of wall clock to propose FORWARD."""

    def __init__(self, seconds: float) -> None:
        self.seconds = seconds

    def reset(self) -> None:
        pass

    def propose(self, moment):
        end = time.perf_counter() + self.seconds
        while time.perf_counter() < end:
            pass
        return Command.FORWARD


class _SlowSteps(gym.Wrapper):
    """An env whose every step takes 0.3 s more of wall clock."""

    def step(self, action):
        time.sleep(0.3)
        return self.env.step(action)


def test_a_step_records_the_time_from_its_frame_to_its_command():
    # The step's decision time covers the perception and the commanders' proposals (here a
    # policy that spins for 30 ms), not the env's execution of the command (here 0.3 s more).
    library, _ = library_with_road()
    env = _SlowSteps(LfDTrackEnv(track="training"))
    loop = TeachingLoop(
        env, Perception(library, "frozen"), Arbiter("policy"), policy=_SlowPolicy(0.03)
    )
    loop.reset(seed=3)
    step = loop.step()
    env.close()
    assert step.command == Command.FORWARD and step.decision_ms is not None
    assert 30.0 <= step.decision_ms < 300.0
