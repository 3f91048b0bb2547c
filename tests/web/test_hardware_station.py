"""The teaching station on the hardware backend: the real firmware in simavr, a loopback camera.

Closing the page while a command is held must stop the robot within 1 s: the firmware's motor
log (its pins, in simulated time) shows the motors off, and nothing drives them again.

The deadline is asserted in the board's own time: from a mark the harness writes into the motor
log just before the page is closed to the motors' last switch-off there. The simulated board
keeps the wall clock's pace at best, and falls behind it when the host's cores are busy (simavr
drops the time it lost): its own clock is what a robot's motors run by, the host's wall clock
then is not.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from lfd_test_support import load_test_module

pytestmark = [pytest.mark.browser, pytest.mark.simavr]

HARDWARE_TESTS = Path(__file__).resolve().parents[1] / "hardware"


def _hardware_module(name: str):
    """A module of tests/hardware (its board fixture and loopback camera)."""
    return load_test_module(HARDWARE_TESTS / f"{name}.py", f"_lfd_web_hw_{name}")


def _sibling(name: str):
    """A module of this folder (the page helpers of test_station)."""
    return load_test_module(Path(__file__).with_name(f"{name}.py"), f"_lfd_web_{name}")


as_controller = _sibling("test_station").as_controller
wait_until = _sibling("test_station").wait_until
simulated_board = _hardware_module("conftest").simulated_board
MjpegServer = _hardware_module("test_camera").MjpegServer


STOP_DEADLINE_S = 1.0
"""[s, board time] closing the page stops the motors within this long (the page's lease)."""
SLOW_BOARD_ACK_TIMEOUT_S = 1.0
"""[s] how long the station's link waits for a reply from the simulated board.

A real board answers within the link's 150 ms (``RobotLink.ack_timeout_s``), three misses in a
row being a lost link. The simulated board answers as fast in its own time, but that time falls
behind the wall clock when the host's cores are busy, and then three slow replies in a row would
be taken for a lost link, which stops the robot for another reason than the one under test. The
wait for a reply is not the stop's deadline: the e-stop frame is written at once, and the
deadline is asserted in the board's time."""


def _motors_on(sample) -> bool:
    return sample.left_pwm != 0 or sample.right_pwm != 0


def _switched_off_at(samples) -> float:
    """The board time of the motors' last switch from on to off in ``samples``."""
    for before, after in reversed(list(zip(samples, samples[1:], strict=False))):
        if _motors_on(before) and not _motors_on(after):
            return after.t_s
    raise AssertionError(f"the motors never switched off: {samples[-3:]}")


@pytest.fixture(scope="module")
def felt_frame() -> np.ndarray:
    """A rendered camera frame of the training track (BGR, as a phone's stream encodes it)."""
    from lfd_track.envs.track_env import LfDTrackEnv

    env = LfDTrackEnv(track="training")
    frame, _ = env.reset(seed=0)
    env.close()
    return np.ascontiguousarray(frame[..., ::-1])


def test_closing_the_page_stops_the_robot_within_1_s(
    browser, open_station, simulated_board, felt_frame
) -> None:
    with MjpegServer(make_frame=lambda i: felt_frame, period_s=0.05) as camera:
        station = open_station(
            "--backend", "hardware", "--camera", camera.url,
            "--serial", simulated_board.serial_url, "--period", "0.2",
        )  # fmt: skip
        station.session.loop.env.link.ack_timeout_s = SLOW_BOARD_ACK_TIMEOUT_S
        page = as_controller(browser, station.url)
        # Standing still, the page still shows the live camera (without taking its frames).
        seq = station.session.latest_view().seq
        wait_until(lambda: station.session.latest_view().seq >= seq + 5, "live frames")
        assert station.session.status()["steps"] == 0
        log_start = len(simulated_board.motor_log())
        page.locator('[data-command="forward"]').hover()
        page.mouse.down()  # held: the robot drives on, period after period
        wait_until(lambda: station.session.status()["steps"] >= 3, "three periods of forward")
        assert any(_motors_on(s) for s in simulated_board.motor_log()[log_start:])
        closing_at = simulated_board.mark()  # board time, before the close begins
        page.close()  # the tab goes away mid-command
        # The board acknowledges the e-stop once its motors are off (its state becomes X).
        wait_until(lambda: station.session.loop.env.link.state == "X", "the board's e-stop")
        status = station.session.status()
        assert "page closed" in status["stopped_reason"], status["stopped_reason"]
        wait_until(
            lambda: not _motors_on(simulated_board.motor_log()[-1]), "the motor log to show it"
        )
        log = simulated_board.motor_log()[log_start:]
        stopped_after = _switched_off_at(log) - closing_at
        print(f"motors off {stopped_after:.3f} s (board time) after the page began to close")
        # (Negative: the motors were off between two periods at the mark, and stayed off.)
        assert stopped_after < STOP_DEADLINE_S, f"stopped {stopped_after:.2f} s after"
        # A period already under way when the page closed is refused by the e-stop and ends.
        steps = wait_until(
            lambda: not (s := station.session.status())["driving"] and s, "the loop to idle"
        )["steps"]
        # Bounded look for a restart: two control periods later the motors are still off.
        settle = time.monotonic() + 0.4
        wait_until(lambda: time.monotonic() > settle, "two periods")
        assert station.session.status()["steps"] == steps
        assert not _motors_on(simulated_board.motor_log()[-1])
        assert station.session.status()["cases"] >= 3
