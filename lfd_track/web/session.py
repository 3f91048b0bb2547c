"""The teaching session the web app drives: the teaching loop stepped in a background thread.

:class:`LoopSession` arranges the one teaching loop for a browser: the human commander is a
:class:`~lfd_track.web.commander.BrowserCommander` fed by the server, the loop is stepped from a
background thread at most once per control period (only when someone has a command: the human a
press, or the policy while it drives), and the page sees what observers publish after each step:
the annotated camera view, the simulator's top-down map, counts. Nothing here moves the robot
unless the controlling page holds the lease (:class:`~lfd_track.web.protocol.Lease`).
"""

from __future__ import annotations

import argparse
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..commands import Command
from .commander import BrowserCommander
from .protocol import LEASE_S, Lease, View
from .view import make_view

HUMAN = "human"
AUTONOMOUS = "autonomous"


class LoopSession:
    """A teaching station on the sim or the real robot (see the module docstring).

    Args:
        env: the robot: ``LfDTrackEnv`` (sim) or ``HardwareEnv``.
        loop: the teaching loop arranged for this station (see :func:`open_session`).
        backend: ``"sim"`` or ``"hardware"``.
        online: whether a policy evolves and may take over.
        period_s: [s] control period; the loop steps at most once per period.
        stop_robot: stops the real robot at once (e-stop), None in the simulator.
        rearm_options: ``reset`` options that make the robot drive again after a stop (the
            real robot's e-stop is cleared by the next command the human gives), or None.
        topdown: returns the simulator's map picture, None on the real robot.
        lease_s: [s] heartbeat lease of the controlling page.
    """

    def __init__(
        self,
        env: Any,
        loop: Any,
        *,
        backend: str,
        online: bool,
        period_s: float,
        stop_robot: Callable[[str], None] | None = None,
        rearm_options: dict[str, Any] | None = None,
        topdown: Callable[[], np.ndarray] | None = None,
        lease_s: float = LEASE_S,
    ) -> None:
        self.env = env
        self.loop = loop
        self.backend = backend
        self.online = online
        self.period_s = float(period_s)
        self.commander = BrowserCommander()
        self._stop_robot = stop_robot
        self._rearm_options = rearm_options
        self._rearm = False
        self._driving = False
        self._topdown = topdown
        self._cond = threading.Condition()
        self._closed = False
        self._mode = HUMAN
        self._stopped_reason: str | None = None
        self._view: View | None = None
        self._view_seq = 0
        self._steps = 0
        self._error: str | None = None
        self.lease = Lease(lambda: self.stop("no heartbeat from the page for 1 s"), lease_s)
        self._thread = threading.Thread(target=self._run, name="lfd-track teaching loop")
        self._thread.daemon = True

    # ----------------------------------------------------------------------------- commands
    def start(self) -> LoopSession:
        """Reset the robot, publish the first view and start stepping."""
        self.loop.reset(None)
        self._publish()
        self._thread.start()
        return self

    def heartbeat(self) -> None:
        self.lease.renew()

    def press(self, command: Command) -> None:
        if not self.lease.alive:
            return
        with self._cond:
            if self._mode == AUTONOMOUS:
                self._mode = HUMAN  # any human command takes control back
                self.loop.human_takes_back()
            self._stopped_reason = None
            self.commander.press(command)
            self._cond.notify_all()

    def release(self) -> None:
        self.commander.release()

    def stop(self, reason: str = "stop") -> None:
        with self._cond:
            self.commander.clear()
            was_moving = self._mode == AUTONOMOUS or self._steps > 0
            if self._mode == AUTONOMOUS:
                self.loop.human_takes_back(record=False)
            self._mode = HUMAN
            if was_moving:
                self._stopped_reason = reason
            self._rearm = self._rearm_options is not None
            self._cond.notify_all()
        if self._stop_robot is not None:
            self._stop_robot(reason)

    def set_learning_paused(self, paused: bool) -> None:
        self.loop.set_learning_paused(bool(paused))

    def take_over(self) -> None:
        if not self.online:
            raise ValueError("no policy to drive: start the station with --online")
        if not self.lease.alive:
            return
        with self._cond:
            if not self.loop.policy_ready:
                raise ValueError("no policy yet: demonstrate a few commands first")
            self.commander.clear()
            self._mode = AUTONOMOUS
            self._stopped_reason = None
            self.loop.policy_takes_over()
            self._cond.notify_all()

    # ----------------------------------------------------------------------------- reading
    def status(self) -> dict[str, Any]:
        with self._cond:
            status = {
                "mode": self._mode,
                "steps": self._steps,
                "driving": self._driving,
                "stopped_reason": self._stopped_reason,
                "error": self._error,
                "lease_alive": self.lease.alive,
            }
        status.update(self.loop.status())
        return status

    def latest_view(self) -> View | None:
        with self._cond:
            return self._view

    # ----------------------------------------------------------------------------- lifecycle
    def close(self) -> None:
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self.commander.clear()
            self._cond.notify_all()
        if self._thread.is_alive():
            self._thread.join(timeout=10.0)
        self.lease.close()
        self.loop.close()

    def __enter__(self) -> LoopSession:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------------------- the thread
    def _has_work(self) -> bool:
        return self._mode == AUTONOMOUS or self.commander.pending

    def _run(self) -> None:
        next_step_at = 0.0
        while True:
            with self._cond:
                while not self._closed and not (self._has_work() and self.lease.alive):
                    if self._has_work():  # commands but no lease: drop them, robot stays put
                        self.commander.clear()
                        self._mode = HUMAN
                    self._cond.wait()
                if self._closed:
                    return
                # Pace the simulator like the robot: one command per control period.
                remaining = next_step_at - time.monotonic()
                if remaining > 0:
                    self._cond.wait(remaining)
                    continue
                human = self.commander.next_command() if self._mode == HUMAN else None
                if self._mode == HUMAN and human is None:
                    continue
                rearm, self._rearm = self._rearm, False
                self._driving = True
            started = time.monotonic()
            try:
                if rearm:  # a command after a stop: clear the e-stop, take a fresh frame
                    self.loop.reset(self._rearm_options)
                ended = self.loop.step(human)
            except Exception as exc:  # noqa: BLE001 - shown on the page; the station keeps serving
                with self._cond:
                    self._error = f"{type(exc).__name__}: {exc}"
                    self._mode = HUMAN
                    self._driving = False
                    self.commander.clear()
                continue
            with self._cond:
                self._driving = False
                self._steps += 1
                if ended is not None:  # the episode ended (off the felt, link lost, ...)
                    self._stopped_reason = ended
                    self._mode = HUMAN
                    self.commander.clear()
            self._publish()
            next_step_at = started + self.period_s

    def _publish(self) -> None:
        frame, values, caption = self.loop.display()
        topdown = self._topdown() if self._topdown is not None else None
        with self._cond:
            self._view_seq += 1
            seq = self._view_seq
        view = make_view(seq, frame, values, topdown, caption)
        with self._cond:
            self._view = view


def open_session(args: argparse.Namespace) -> LoopSession:
    """The session ``lfd-track teach`` asked for (started; close it when done).

    ``args`` as parsed by :func:`lfd_track.web.cli.add_teach_parser`.
    """
    from .arrangement import TeachArrangement

    out = Path(args.out)
    metadata: dict[str, Any] = {"source": "teach", "backend": args.backend, "online": args.online}
    if args.backend == "sim":
        from ..env import LfDTrackEnv

        env = LfDTrackEnv(
            track=args.track, preset=args.preset, render_mode="rgb_array", max_steps=10**9
        )
        period_s = args.period or env.preset.rover.control_period_s
        metadata.update(kind="simulated", track=args.track, preset=args.preset, seed=args.seed)
        stop_robot = None
        topdown = env.render
    else:
        from ..hardware.env import HardwareEnv

        period_s = args.period or 0.4
        env = HardwareEnv(
            camera_url=args.camera,
            serial_url=args.serial,
            control_period_s=period_s,
            between_steps="stop",
        )
        metadata.update(kind="hardware", camera=args.camera, control_period_s=period_s)

        def stop_robot(reason: str) -> None:
            env.link.estop()  # latched: a drive already on its way is refused by the board

        topdown = None
    try:
        loop = TeachArrangement(
            env,
            out,
            metadata=metadata,
            seed=args.seed if args.backend == "sim" else None,
            simulated=args.backend == "sim",
            library_only=args.library_only,
            overwrite=args.force,
        )
    except BaseException:
        env.close()
        raise
    session = LoopSession(
        env,
        loop,
        backend=args.backend,
        online=args.online,
        period_s=period_s,
        stop_robot=stop_robot,
        rearm_options={"clear_estop": True} if args.backend == "hardware" else None,
        topdown=topdown,
    )
    try:
        return session.start()
    except BaseException:
        session.close()
        raise
