"""The teaching station on the hardware backend: the real firmware in simavr, a loopback camera.

Closing the page while a command is held must stop the robot within 1 s: the firmware's motor
log (its pins, in simulated time) shows the motors off, and nothing drives them again.
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


def _motors_on(sample) -> bool:
    return sample.left_pwm != 0 or sample.right_pwm != 0


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
        page.close()  # the tab goes away mid-command
        closed_at = time.monotonic()
        # The board acknowledges the e-stop once its motors are off (its state becomes X).
        wait_until(lambda: station.session.loop.env.link.state == "X", "the board's e-stop")
        stopped_after = time.monotonic() - closed_at
        assert stopped_after < 1.0, f"stopped {stopped_after:.2f} s after the page closed"
        status = station.session.status()
        assert "page closed" in status["stopped_reason"]
        wait_until(
            lambda: not _motors_on(simulated_board.motor_log()[-1]), "the motor log to show it"
        )
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
