"""The real rover as a Gymnasium environment: ``LfDTrack-Hardware-v0``.

Same observation and action contract as the simulated ``LfDTrack-v0``, so one controller file
drives both: frames come from the phone's camera stream (``camera.py``), commands go to the
board over the serial link (``link.py``).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from ..core.commands import Command
from .camera import FRAME_SHAPE, CameraError, CameraTimeout, FrameSource, open_camera
from .link import Ack, LinkError, RobotLink

LINK_LOST = "link_lost"
CAMERA_TIMEOUT = "camera_timeout"
CAMERA_ERROR = "camera_error"
ESTOPPED = "estopped"

HOLD = "hold"
STOP_BETWEEN = "stop"

_POLL_S = 0.02  # how often the hold loop checks the link and the camera [s]


class HardwareEnv(gym.Env):
    """A real tracked rover: phone camera frames in, forward/left/right commands out.

    ## Description
    The paper's robot (a Rover 5 chassis, an Arduino-class board running our firmware, a phone
    camera) behind the Gymnasium API. Each step sends one drive command over the serial link,
    holds it for ``control_period_s`` while re-sending it at 10 Hz (the board's motor watchdog
    stops the motors if no drive frame arrives for ``watchdog_ms``), then returns the newest camera
    frame.

    Between steps (``between_steps="hold"``, the default) the command keeps running while the
    controller thinks, as the paper's robot kept moving until its next command; the host stops
    refreshing it ``camera_timeout_s`` after the period, so a program that stops calling ``step``
    stops the robot within ``control_period_s + camera_timeout_s`` plus the watchdog period.
    ``between_steps="stop"`` stops the motors at the end of every period instead (the frame is
    then taken at rest, at the cost of stop-and-go motion).

    ## Action Space
    ``Discrete(3)``: 0 forward, 1 left (pivot counter-clockwise), 2 right (pivot clockwise).

    ## Observation Space
    ``Box(0, 255, (480, 640, 3), uint8)``: the phone camera's RGB frame, resized to 640 × 480 if
    the phone streams another size.

    ## Rewards
    Always 0: there is no ground truth on the real floor.

    ## Starting State
    Wherever the robot stands. ``reset`` connects on first use, stops the motors and returns a
    fresh frame. ``reset(options={"clear_estop": True})`` clears a latched e-stop first.

    ## Episode End
    Never by itself on success (use a time limit). Terminated, after the motors are stopped, when
    the link is lost (``info["failure"] == "link_lost"``: serial error, missed acks, corrupt
    replies), the camera stalls (``"camera_timeout"``) or fails (``"camera_error"``), or the board
    refuses to drive because its e-stop is latched (``"estopped"``). Any other exception and
    ``KeyboardInterrupt`` stop the motors and propagate.

    ## Info
    ``link``: link counters (``acks``, ``missed``, ``rtt_ms``, … see ``LinkStats``);
    ``failure``: None or one of the reasons above; ``command``: the letter sent;
    ``board_state``: the motor state the board acknowledged; ``step``; ``frame_age_s``; after a
    failure ``error``, one line naming the device and the problem (also kept in ``last_error``
    until the next ``reset``).

    ## Arguments
    ``gym.make("LfDTrack-Hardware-v0", camera_url=..., serial_url=..., watchdog_ms=300,
    control_period_s=0.4, render_mode=None)``; further keyword arguments: ``camera_timeout_s``
    (1.0), ``between_steps`` (``"hold"``/``"stop"``), ``link_options`` and ``camera_options``
    (dicts passed to ``RobotLink`` and ``open_camera``).
    ``render_mode="rgb_array"`` returns the latest camera frame.

    ## Version History
    * v0: initial version.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 2.5}

    def __init__(
        self,
        camera_url: str,
        serial_url: str,
        watchdog_ms: int = 300,
        control_period_s: float = 0.4,
        render_mode: str | None = None,
        *,
        camera_timeout_s: float = 1.0,
        between_steps: str = HOLD,
        link_options: Mapping[str, Any] | None = None,
        camera_options: Mapping[str, Any] | None = None,
    ) -> None:
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode must be one of {self.metadata['render_modes']} or None")
        if between_steps not in (HOLD, STOP_BETWEEN):
            raise ValueError(f"between_steps must be '{HOLD}' or '{STOP_BETWEEN}'")
        if control_period_s <= 0 or camera_timeout_s <= 0:
            raise ValueError("control_period_s and camera_timeout_s must be positive")
        self.camera_url = camera_url
        self.serial_url = serial_url
        self.watchdog_ms = int(watchdog_ms)
        self.control_period_s = float(control_period_s)  # [s]
        self.camera_timeout_s = float(camera_timeout_s)  # [s]
        self.between_steps = between_steps
        self.render_mode = render_mode
        self.action_space = spaces.Discrete(3)
        self.observation_space = spaces.Box(0, 255, FRAME_SHAPE, dtype=np.uint8)
        self.link = RobotLink(serial_url, watchdog_ms=self.watchdog_ms, **dict(link_options or {}))
        self.camera: FrameSource = open_camera(camera_url, **dict(camera_options or {}))
        self._camera_open = False
        self._frame = np.zeros(FRAME_SHAPE, np.uint8)
        self._steps = 0
        self._ended = True  # step() needs a reset() first
        self._last_ack: Ack | None = None
        self.last_error: str | None = None  # the one-line error that ended the last episode

    # ------------------------------------------------------------------ gymnasium API
    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        super().reset(seed=seed)
        options = options or {}
        try:
            if self.link.failure is not None:
                self.link.close()  # reconnect after a lost link
            if not self.link.is_open:
                self.link.connect()
            if options.get("clear_estop"):
                self.link.clear_estop()
            self.link.stop()
            if not self._camera_open:
                self.camera.open()
                self._camera_open = True
            self._frame = self.camera.read(timeout_s=self.camera_timeout_s)
        except BaseException:
            self.link.stop()
            raise
        self._steps = 0
        self._ended = False
        self._last_ack = None
        self.last_error = None
        return self._frame, self._info(None, "S")

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        if self._ended:
            raise RuntimeError("the episode has ended: call reset() before step()")
        if not self.action_space.contains(action):
            raise ValueError(f"action must be 0 (forward), 1 (left) or 2 (right), got {action!r}")
        command = Command(int(action))
        started = time.monotonic()
        self._steps += 1
        try:
            lease_s = self.control_period_s + self.camera_timeout_s
            ack = self.link.drive(command, lease_s=lease_s)
            self._last_ack = ack
            if ack.estopped:
                message = f"{self.serial_url}: the board's e-stop is latched"
                return self._end(ESTOPPED, command.letter, message)
            self._hold_until(started + self.control_period_s)
            if self.between_steps == STOP_BETWEEN:
                self._last_ack = self.link.drive("S")
            wait_s = max(self.camera_timeout_s - self.camera.seconds_since_frame(), _POLL_S)
            self._frame = self.camera.read(timeout_s=wait_s)
        except LinkError as exc:
            return self._end(LINK_LOST, command.letter, exc)
        except CameraTimeout as exc:
            return self._end(CAMERA_TIMEOUT, command.letter, exc)
        except CameraError as exc:
            return self._end(CAMERA_ERROR, command.letter, exc)
        except BaseException:
            # KeyboardInterrupt or a bug: the robot must not keep driving while it propagates.
            self._ended = True
            self.link.stop()
            raise
        return self._frame, 0.0, False, False, self._info(None, command.letter)

    def render(self) -> np.ndarray | None:
        if self.render_mode != "rgb_array":
            return None
        return self._frame.copy()

    def close(self) -> None:
        """Stop the motors, close the link and the camera (safe to call more than once)."""
        self._ended = True
        try:
            self.link.close()
        finally:
            self.camera.close()
            self._camera_open = False
        super().close()

    # ------------------------------------------------------------------ internals
    def _hold_until(self, deadline: float) -> None:
        """Wait out the control period while the keep-alive thread refreshes the lease.

        Polls so a lost link or a stalled camera ends the step early instead of letting the robot
        drive on without fresh frames.
        """
        while True:
            if self.link.failure is not None:
                raise self.link.failure
            if self.camera.seconds_since_frame() > self.camera_timeout_s:
                raise CameraTimeout(
                    f"{self.camera_url}: no new frame for {self.camera.seconds_since_frame():.1f}"
                    f" s; is the phone's camera app streaming?"
                )
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return
            time.sleep(min(remaining, _POLL_S))

    def _end(
        self, failure: str, letter: str, error: object
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]:
        self._ended = True
        self.link.stop()
        info = self._info(failure, letter)
        info["error"] = self.last_error = str(error)  # one line naming the device and problem
        return self._frame, 0.0, True, False, info

    def _info(self, failure: str | None, letter: str) -> dict[str, Any]:
        info: dict[str, Any] = {
            "link": self.link.stats().as_dict(),
            "failure": failure,
            "command": letter,
            "board_state": self.link.state,
            "step": self._steps,
            "frame_age_s": self.camera.seconds_since_frame(),
        }
        return info
