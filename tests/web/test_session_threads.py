"""The teaching session's loop thread against calls from the web side (no browser, a fake robot)."""

from __future__ import annotations

import sys
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from lfd_test_support import library_with_road

from lfd_track.core.commands import Command
from lfd_track.teaching import Arbiter, Perception, PolicyCommander, TeachingLoop
from lfd_track.web.commander import BrowserCommander
from lfd_track.web.session import CaseTally, LoopSession


class FakeRobot:
    """A world that always shows the same frame; records resets (their options) and commands."""

    def __init__(self, frame: np.ndarray) -> None:
        self.frame = frame
        self.resets: list[dict[str, Any] | None] = []
        self.commands: list[int] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        self.resets.append(options)
        return self.frame, {}

    def step(self, action: int):
        self.commands.append(action)
        return self.frame, 0.0, False, False, {}

    def close(self) -> None:
        pass


class FakeWriter:
    n_cases = 0

    def close(self, final_metadata: dict[str, Any] | None = None) -> None:
        pass


def _session(
    *, online: bool = False, lease_s: float = 5.0, **options: Any
) -> tuple[LoopSession, FakeRobot]:
    library, frame = library_with_road()
    robot = FakeRobot(frame)
    commander = BrowserCommander()
    tally = CaseTally()
    policy = None
    if online:
        policy = PolicyCommander(np.random.default_rng(0).normal(size=40 * 5 + 5 + 5 * 3 + 3))
    loop = TeachingLoop(
        robot,
        Perception(library, "paused"),
        Arbiter("takeover" if online else "human", auto_accept=False),
        human=commander,
        policy=policy,
        observers=[tally],
        stop_on_episode_end=False,
    )
    session = LoopSession(
        loop,
        commander,
        FakeWriter(),  # type: ignore[arg-type]
        tally,
        backend="hardware",
        period_s=0.02,
        policy=policy,
        lease_s=lease_s,
        **options,
    )
    return session.start(), robot


def _wait_for(condition: Callable[[], bool], timeout_s: float = 3.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.005)
    return condition()


def test_letting_it_drive_after_a_stop_clears_the_e_stop_and_the_policy_drives() -> None:
    """On the real robot a stop latches the e-stop; the re-arm before the next step must not
    hand the wheel back to the human that "let it drive" just took it from."""
    stops: list[str] = []
    session, robot = _session(
        online=True, stop_robot=stops.append, rearm_options={"clear_estop": True}
    )
    try:
        session.heartbeat()
        session.stop("stop button")
        session.take_over()
        assert _wait_for(lambda: session.loop.counts.policy_commands >= 3)
        assert {"clear_estop": True} in robot.resets
        assert session.status()["mode"] == "autonomous"
    finally:
        session.close()


def test_a_stop_during_the_re_arm_is_not_undone() -> None:
    """A stop that comes while the robot is being re-armed for the policy leaves the human
    driving (nothing moves)."""
    reset = threading.Event()
    session, robot = _session(
        online=True, stop_robot=lambda reason: None, rearm_options={"clear_estop": True}
    )
    original_reset = robot.reset

    def reset_then_stop(**kwargs: Any):
        result = original_reset(**kwargs)
        if kwargs.get("options"):
            session.stop("stop button")  # the page's stop, while the board is being re-armed
            reset.set()
        return result

    robot.reset = reset_then_stop  # type: ignore[method-assign]
    try:
        session.heartbeat()
        session.stop("stop button")
        session.take_over()
        assert reset.wait(3.0)
        time.sleep(0.2)
        assert session.loop.counts.policy_commands == 0
        assert session.status()["mode"] == "human"
    finally:
        session.close()


def test_a_failure_publishing_the_view_is_shown_and_the_loop_keeps_serving() -> None:
    calls = {"n": 0}

    def topdown() -> np.ndarray:
        calls["n"] += 1
        if calls["n"] == 2:  # the view after the first command
            raise RuntimeError("the map cannot be drawn")
        return np.zeros((60, 80, 3), np.uint8)

    session, robot = _session(topdown=topdown)
    try:
        session.heartbeat()
        session.press(Command.FORWARD)
        session.release()
        assert _wait_for(lambda: session.status()["error"] is not None)
        assert "the map cannot be drawn" in session.status()["error"]
        session.press(Command.LEFT)
        session.release()
        assert _wait_for(lambda: len(robot.commands) == 2)
        assert robot.commands == [int(Command.FORWARD), int(Command.LEFT)]
        assert _wait_for(lambda: session.status()["error"] is None)
    finally:
        session.close()


def test_a_failing_live_preview_is_shown_and_the_loop_keeps_serving() -> None:
    def live_frame() -> tuple[int, np.ndarray] | None:
        raise OSError("the camera went away")

    session, robot = _session(live_frame=live_frame, preview_fps=50.0)
    try:
        assert _wait_for(lambda: session.status()["error"] is not None)
        assert "the camera went away" in session.status()["error"]
        session.heartbeat()
        session.press(Command.RIGHT)
        session.release()
        assert _wait_for(lambda: robot.commands == [int(Command.RIGHT)])
    finally:
        session.close()


def test_a_stop_that_fails_on_a_lapsed_lease_does_not_end_the_lease_watchdog() -> None:
    """The lease's stop raised once (a lost serial link); the next lapse still stops."""
    stops: list[str] = []

    def stop_robot(reason: str) -> None:
        stops.append(reason)
        if len(stops) == 1:
            raise OSError("the serial link is gone")

    session, _ = _session(stop_robot=stop_robot, lease_s=0.05)
    try:
        session.heartbeat()
        assert _wait_for(lambda: len(stops) == 1)
        assert _wait_for(lambda: session.status()["error"] is not None)
        session.heartbeat()
        assert _wait_for(lambda: len(stops) == 2), "the second lapse did not stop the robot"
    finally:
        session.close()


def test_the_agreement_is_readable_while_the_loop_clears_it() -> None:
    arbiter = Arbiter("takeover", window=4)
    done = threading.Event()

    def churn() -> None:
        while not done.is_set():
            arbiter.decide(Command.FORWARD, Command.FORWARD)
            arbiter.reset()

    thread = threading.Thread(target=churn)
    interval = sys.getswitchinterval()
    sys.setswitchinterval(1e-6)
    thread.start()
    try:
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            assert 0.0 <= arbiter.agreement <= 1.0
    finally:
        done.set()
        thread.join()
        sys.setswitchinterval(interval)


@pytest.mark.parametrize("online", [False, True])
def test_close_ends_the_thread(online: bool) -> None:
    session, _ = _session(online=online)
    session.close()
    assert not session._thread.is_alive()
