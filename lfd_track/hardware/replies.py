"""What the robot board answers, as the host sees it: :class:`Ack`, :class:`BoardVersion`, the
link's counters (:class:`LinkStats`), its error (:class:`LinkError`) and the ack flags.

Value types of :mod:`.link` (which re-exports them), kept apart from its state machine; the
frames themselves are :mod:`.wire`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from ..core.commands import Command
from ..errors import LfdTrackError
from . import wire

STOP = "S"
ESTOPPED = "X"  # ack state while the board's e-stop is latched
FLAG_ESTOP = 1  # ack flags are a decimal bitfield
FLAG_LEASE_EXPIRED = 2  # the watchdog stopped the motors since the last accepted drive frame
FLAG_REPLIES_DROPPED = 4  # the board dropped replies (its transmit buffer was full) since
# its last ack (firmware 1.1 and later)


class LinkError(LfdTrackError):
    """The serial link to the robot board failed or was lost."""


@dataclass(frozen=True)
class Ack:
    """The board's answer to one request: what it actually did, not what was asked.

    ``state`` is the motor state the board reports (``F``/``L``/``R``/``S``, or ``X`` while its
    e-stop is latched); ``flags`` is its decimal bitfield (``FLAG_ESTOP``, ``FLAG_LEASE_EXPIRED``).
    A request the board refused (a NAK) has ``rejected`` set to the reason and ``state`` set to
    the last state the board reported (``X`` when refused for an e-stop). ``info`` holds any
    further fields of the ack (the version query's firmware version and reset cause).
    """

    seq: int
    requested: str  # what the host sent: a drive letter, or the frame type for other requests
    state: str
    flags: str = ""
    rejected: str | None = None
    rtt_ms: float = 0.0  # round-trip time [ms]
    info: tuple[str, ...] = ()

    @property
    def accepted(self) -> bool:
        """True if the board acknowledged the request (no NAK)."""
        return self.rejected is None

    @property
    def moving(self) -> bool:
        """True if the board reports its motors running."""
        return self.state in ("F", "L", "R")

    def _flag(self, bit: int) -> bool:
        return self.flags.isdigit() and bool(int(self.flags) & bit)

    @property
    def estopped(self) -> bool:
        """True if the board's e-stop is latched."""
        return self.state == ESTOPPED or self._flag(FLAG_ESTOP) or self.rejected == "ESTOP"

    @property
    def lease_expired(self) -> bool:
        """True if the board's watchdog stopped the motors since its last accepted drive."""
        return self._flag(FLAG_LEASE_EXPIRED)

    @property
    def replies_dropped(self) -> bool:
        """True if the board dropped replies since its last ack (it was sent frames too fast)."""
        return self._flag(FLAG_REPLIES_DROPPED)


@dataclass(frozen=True)
class BoardVersion:
    """The answer to a version query: firmware version, why the board last reset, its ack."""

    version: str
    reset_cause: str  # a key of ``wire.RESET_CAUSES`` (``WDT``, ``PWR``, ...)
    ack: Ack
    boot_count: int | None = None  # firmware 1.2 and later

    @property
    def reset_cause_text(self) -> str:
        """The reset cause in words (``hardware watchdog``, ``power-on``, ...)."""
        return wire.RESET_CAUSES.get(self.reset_cause, f"unknown ({self.reset_cause})")


@dataclass
class LinkStats:
    """Counters of one link (read them through ``RobotLink.stats()``, which returns a copy)."""

    sent: int = 0  # request frames written
    acks: int = 0  # valid acks received for the request waited on
    naks: int = 0  # requests the board refused
    missed: int = 0  # requests with no valid reply before the ack timeout
    corrupt: int = 0  # reply lines that failed to decode (bad CRC, bad framing, too long)
    stale: int = 0  # valid replies for an older sequence number
    consecutive_failures: int = 0  # requests in a row without a valid reply
    watchdog_stops: int = 0  # ``$W`` frames: the board's watchdog stopped the motors
    boots: int = 0  # ``$B`` frames: the board (re)started
    keepalives: int = 0  # drive frames re-sent by the keep-alive thread
    rtt_ms: float = 0.0  # round-trip time of the last acknowledged request [ms]
    max_rtt_ms: float = 0.0  # worst round-trip time seen [ms]

    def as_dict(self) -> dict[str, Any]:
        """Plain dict copy (for ``info["link"]``)."""
        return dict(self.__dict__)


def drive_letter(command: Command | int | str) -> str:
    """The drive frame's letter for ``command`` (a ``Command``, its value, or F/L/R/S)."""
    if isinstance(command, str):
        letter = command.upper()
        if letter not in wire.DRIVE_ARGS:
            raise ValueError(f"drive command must be one of F, L, R, S, got {command!r}")
        return letter
    return Command(int(command)).letter


def boot_count_of(fields: tuple[str, ...]) -> int | None:
    """The boot count in ``fields[0]`` if there is a valid one (firmware 1.2 and later)."""
    if fields and fields[0].isdigit() and len(fields[0]) <= 5 and int(fields[0]) < 65536:
        return int(fields[0])
    return None
