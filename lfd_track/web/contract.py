"""The contract between the web app and the teaching session it drives.

The app knows nothing of robots, libraries or learners: it forwards what the controlling page
asks for to a :class:`TeachingSession` and streams what the session publishes (a :class:`View`
and a status dict). The session holds the *lease* (:class:`Lease`): commands move the robot only
while the controlling page keeps sending heartbeats.

The WebSocket's message types (:class:`ClientMessage`, :class:`ServerMessage`, :class:`ViewTag`)
and the heartbeat period are defined here once: the app dispatches on them and the page reads
them from :func:`page_contract`, which the server writes into the page (``static/app.js`` has no
copy of them).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from enum import Enum, StrEnum
from typing import Any, Protocol

from ..core.commands import Command

LEASE_S = 1.0
"""[s] the robot stops when the controlling page sent no heartbeat for this long."""

COMMAND_NAMES: dict[str, Command] = {c.name.lower(): c for c in Command}
"""Wire names of the drive commands: ``forward``, ``left``, ``right``."""

STATUS_FIELDS = (
    "cases",
    "mode",
    "learning_paused",
    "library_models",
    "generation",
    "best_fitness",
    "agreement",
)
"""Fields ``GET /api/status`` always returns (more may follow)."""

HEARTBEAT_S = 0.25
"""[s] the controlling page sends a heartbeat this often (four per :data:`LEASE_S`)."""


class ClientMessage(StrEnum):
    """The ``type`` of the JSON text messages ``{"type": ...}`` a page sends.

    ==================  =========================================================================
    ``claim``           take control if no other page holds it, or its holder's lease ran out
                        (every page claims on connect, so the first one gets control)
    ``heartbeat``       the controlling page is alive (every :data:`HEARTBEAT_S`; :data:`LEASE_S`
                        without one stops the robot)
    ``press``           ``{"command": "forward"|"left"|"right"}``: run it now and while held
    ``release``         the command button was let go
    ``stop``            stop at once (any page may stop the robot, watching or controlling)
    ``pause-learning``  ``{"paused": true|false}``
    ``takeover``        let the policy drive (``--online``)
    ==================  =========================================================================
    """

    CLAIM = "claim"
    HEARTBEAT = "heartbeat"
    PRESS = "press"
    RELEASE = "release"
    STOP = "stop"
    PAUSE_LEARNING = "pause-learning"
    TAKEOVER = "takeover"


class ServerMessage(StrEnum):
    """The ``type`` of the JSON text messages the server sends a page.

    ``status``: the session's status (:data:`STATUS_FIELDS` and more) plus ``role``
    (``"controller"`` or ``"watcher"``), ``control_free`` and ``clients``; ``error``:
    ``{"message": ...}``, why the page's last message was refused.
    """

    STATUS = "status"
    ERROR = "error"


class ViewTag(bytes, Enum):
    """The first byte of the server's binary messages, a JPEG after it: the camera view (with
    the road-value overlay) at the page's frame rate, or the simulator's top-down view when it
    changed."""

    CAMERA = b"C"
    TOPDOWN = b"T"


def page_contract() -> dict[str, Any]:
    """What the page needs of this protocol, JSON-ready: message types by member name (the
    page's script refers to them by name), view tags as byte values, the heartbeat period."""
    return {
        "to_server": {member.name: member.value for member in ClientMessage},
        "to_page": {member.name: member.value for member in ServerMessage},
        "view_tags": {member.name: member.value[0] for member in ViewTag},
        "heartbeat_ms": round(HEARTBEAT_S * 1000),
    }


@dataclass(frozen=True)
class View:
    """What the page shows of one published frame.

    ``seq`` counts published frames (1, 2, ...); ``camera_jpeg`` is the camera frame with the
    road-value grid and safe box drawn in; ``topdown_jpeg`` the simulator's map view (None on the
    real robot).
    """

    seq: int
    camera_jpeg: bytes
    topdown_jpeg: bytes | None = None


class TeachingSession(Protocol):
    """The robot, its learner and its recorder as one teaching station (thread-safe).

    Every method returns at once; the robot moves in the session's own thread.
    """

    backend: str
    """``"sim"`` or ``"hardware"``."""
    online: bool
    """True when a policy evolves during the demonstration and may take over."""

    def heartbeat(self) -> None:
        """The controlling page is alive: renew the lease for another ``LEASE_S``."""

    def end_lease(self) -> None:
        """The controlling page left: its lease ends now (the caller stops the robot)."""

    def press(self, command: Command) -> None:
        """A human command: run it once now, and again each control period until ``release``.

        While the policy drives, this takes control back; the command is then recorded as a
        correction. Ignored (robot stays still) when the lease has expired.
        """

    def release(self) -> None:
        """The human let go of the command button (the pressed command still runs once)."""

    def stop(self, reason: str = "stop") -> None:
        """Stop the robot at once (e-stop on hardware), drop queued commands, human mode."""

    def set_learning_paused(self, paused: bool) -> None:
        """Pause or resume road-library learning (careful training by hand)."""

    def take_over(self) -> None:
        """Let the policy drive (``online`` only; raises ``ValueError`` without a policy)."""

    def status(self) -> dict[str, Any]:
        """JSON-friendly status; holds at least :data:`STATUS_FIELDS`."""

    def latest_view(self) -> View | None:
        """The newest published view, or None before the first frame."""

    def close(self) -> None:
        """Stop the robot, finish the recording, release devices (idempotent)."""


class Lease:
    """A renewable deadline with a watchdog: ``on_expire`` runs once when it lapses.

    Like the firmware's motor lease: ``renew()`` pushes the deadline ``duration_s`` ahead; a
    watchdog thread calls ``on_expire()`` (from that thread) once the deadline passes without a
    renewal, then waits for the next renewal. ``alive`` tells whether commands may move the robot.
    """

    def __init__(
        self,
        on_expire: Callable[[], None],
        duration_s: float = LEASE_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        if not duration_s > 0:
            raise ValueError(f"lease duration must be positive, got {duration_s}")
        self.duration_s = float(duration_s)
        self._on_expire = on_expire
        self._clock = clock
        self._deadline: float | None = None  # None: not held (never renewed, expired, revoked)
        self._changed = threading.Condition()
        self._closed = False
        self._thread = threading.Thread(target=self._watch, name="lfd-track lease", daemon=True)
        self._thread.start()

    @property
    def alive(self) -> bool:
        """True while the holder renewed within the last ``duration_s``."""
        with self._changed:
            return self._deadline is not None and self._clock() < self._deadline

    def renew(self) -> None:
        """Push the deadline ``duration_s`` ahead of now."""
        with self._changed:
            self._deadline = self._clock() + self.duration_s
            self._changed.notify_all()

    def revoke(self) -> None:
        """End the lease now without calling ``on_expire`` (the holder left; caller stops)."""
        with self._changed:
            self._deadline = None
            self._changed.notify_all()

    def close(self) -> None:
        """Stop the watchdog thread."""
        with self._changed:
            self._closed = True
            self._changed.notify_all()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)

    def _watch(self) -> None:
        with self._changed:
            while not self._closed:
                if self._deadline is None:
                    self._changed.wait()
                    continue
                remaining = self._deadline - self._clock()
                if remaining > 0:
                    self._changed.wait(remaining)
                    continue
                self._deadline = None
                self._changed.release()
                try:
                    self._on_expire()
                finally:
                    self._changed.acquire()
