"""Serial link from the host to the robot board, speaking the wire protocol of :mod:`.wire`.

``RobotLink`` wraps ``serial.serial_for_url`` (``/dev/rfcomm0`` for an HC-05/06, a pty path,
``socket://host:port``, ``loop://``). Every request is one frame with a fresh sequence number and
waits for the board's reply with the same number. A drive command is a *lease*: the board stops the
motors when no valid drive frame arrived for its watchdog period (300 ms by default), so the host
must keep re-sending the current command. ``RobotLink`` does that from a background keep-alive
thread at ``keepalive_period_s`` (default 0.1 s, i.e. 10 Hz), but only until the lease the caller
asked for expires: if the program driving the robot hangs, the keep-alive stops refreshing and
sends stop, rather than driving on blindly. The lease also ends when the board refuses the drive
for its e-stop and when the board reboots (its boot frame): a cleared e-stop or a fresh board
moves again only on a new drive request, never on the keep-alive's.

Firmware 1.2 enforces the second on its side: after every reset it refuses drive frames (stop
excepted, reason ``BOOT``) until the host sends a hello (``K``) naming the boot count that its
boot frame announced, so a keep-alive that re-sends the old drive before the host has read the
boot frame cannot move it, however the two race. ``RobotLink`` sends that hello only inside
an application's ``drive()`` that asks for motion (after a version query if it has not seen the
boot count), never from the keep-alive thread; a drive request the board refused with ``BOOT`` (it was written before the
host saw the boot) returns that refusal, and the next one drives.

Link loss (a serial exception, ``max_consecutive_failures`` requests in a row without a valid
reply, or more than ``max_corrupt_replies`` undecodable replies in a row) raises ``LinkError``.

``query_version()`` asks firmware 1.1 and later for its version and the cause of its last reset
(1.2: and its boot count) at any time; the boot frame carries them too (and whether the board
booted with its e-stop latched, as it does after a watchdog or brown-out reset).

:class:`RobotLink` is one lock-guarded state machine (the lease, the keep-alive thread, the boot
count, the reply matching) whose safety rules hold only together, so it stays in one module; the
value types of its answers (:class:`Ack`, :class:`BoardVersion`, :class:`LinkStats`,
:class:`LinkError`) are :mod:`.replies` (imported from here too), the wire format :mod:`.wire`.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from ..core.commands import Command
from ..utils.extras import needs_extra
from . import wire
from .replies import (
    ESTOPPED,
    FLAG_ESTOP,
    FLAG_LEASE_EXPIRED,
    FLAG_REPLIES_DROPPED,
    STOP,
    Ack,
    BoardVersion,
    LinkError,
    LinkStats,
    boot_count_of,
    drive_letter,
)
from .wire import DEFAULT_BAUD, Frame, FrameError, FrameParser

with needs_extra("hardware"):
    import serial

__all__ = [
    "ESTOPPED",
    "FLAG_ESTOP",
    "FLAG_LEASE_EXPIRED",
    "FLAG_REPLIES_DROPPED",
    "STOP",
    "Ack",
    "BoardVersion",
    "LinkError",
    "LinkStats",
    "RobotLink",
]


@dataclass
class _Lease:
    """What the keep-alive thread re-sends and until when (monotonic seconds)."""

    letter: str = STOP
    until: float = 0.0
    events: list[str] = field(default_factory=list)


class RobotLink:
    """Host end of the serial link to the robot board; a context manager.

    ``url`` is anything ``serial.serial_for_url`` accepts. Use ``with RobotLink(url) as link:``
    (connects, and on exit stops the motors and closes the port).
    """

    def __init__(
        self,
        url: str,
        *,
        baudrate: int = DEFAULT_BAUD,
        ack_timeout_s: float = 0.15,
        max_consecutive_failures: int = 3,
        max_corrupt_replies: int = 8,
        boot_wait_s: float = 0.0,
        connect_timeout_s: float = 3.0,
        keepalive_period_s: float = 0.1,
        watchdog_ms: int | None = None,
        port_factory: Callable[[], Any] | None = None,
    ) -> None:
        """Configure the link; nothing is opened until ``connect()``.

        ``boot_wait_s``: how long ``connect()`` waits for the board's boot frame first (a USB
        Arduino resets when the port opens; a Bluetooth module does not, so 0 skips the wait).
        ``connect_timeout_s``: how long ``connect()`` keeps pinging before giving up.
        ``watchdog_ms``: if set, ``connect()`` sets the board's watchdog period.
        ``port_factory``: returns an already open serial-like object (tests, custom transports).
        """
        if keepalive_period_s <= 0 or keepalive_period_s > 0.2:
            raise ValueError("keepalive_period_s must be in (0, 0.2]: the lease is re-sent >= 5 Hz")
        if max_consecutive_failures < 1 or max_corrupt_replies < 1:
            raise ValueError("failure bounds must be >= 1")
        self.url = url
        self.baudrate = baudrate
        self.ack_timeout_s = ack_timeout_s
        self.max_consecutive_failures = max_consecutive_failures
        self.max_corrupt_replies = max_corrupt_replies
        self.boot_wait_s = boot_wait_s
        self.connect_timeout_s = connect_timeout_s
        self.keepalive_period_s = keepalive_period_s
        self.watchdog_ms = watchdog_ms
        self._port_factory = port_factory
        self._port: Any = None
        self._parser = FrameParser()
        self._io_lock = threading.RLock()  # one request/reply exchange at a time
        self._lease = _Lease()
        self._lease_lock = threading.Lock()
        self._stats = LinkStats()
        self._seq = 0
        self._state = STOP
        self._corrupt_run = 0
        self._failure: LinkError | None = None  # first fatal error; sticky until close()
        self._last_drive_sent = 0.0
        self._stop_event = threading.Event()
        self._thread: threading.Thread | None = None
        self.firmware_version: str | None = None
        self.reset_cause: str | None = None  # from the boot frame or a version query
        self.boot_count: int | None = None  # the board's current boot (firmware 1.2 and later)
        self._boot_unanswered = False  # the board waits for a hello before it drives

    # ------------------------------------------------------------------ lifecycle
    def __enter__(self) -> RobotLink:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def is_open(self) -> bool:
        """True between a successful open and ``close()``."""
        return self._port is not None

    @property
    def failure(self) -> LinkError | None:
        """The error that ended the link, if any (also raised by the next request)."""
        return self._failure

    @property
    def state(self) -> str:
        """Last motor state the board reported (``F``/``L``/``R``/``S``)."""
        return self._state

    def stats(self) -> LinkStats:
        """A copy of the link counters."""
        with self._io_lock:
            return LinkStats(**self._stats.__dict__)

    def open(self) -> None:
        """Open the serial port (no traffic); ``connect()`` calls this."""
        if self._port is not None:
            return
        try:
            if self._port_factory is not None:
                self._port = self._port_factory()
            else:
                # A short read timeout keeps reply waits responsive; the ack deadline is ours.
                self._port = serial.serial_for_url(
                    self.url, baudrate=self.baudrate, timeout=0.01, write_timeout=1.0
                )
        except (serial.SerialException, OSError, ValueError) as exc:
            raise LinkError(f"{self.url}: cannot open serial link ({exc})") from None
        self._failure = None

    def connect(self) -> RobotLink:
        """Open the port, wait for the boot frame (``boot_wait_s``), ping, set the watchdog.

        Starts the keep-alive thread. Raises ``LinkError`` if the board never answers a ping
        within ``connect_timeout_s``.
        """
        self.open()
        if self.boot_wait_s > 0:
            deadline = time.monotonic() + self.boot_wait_s
            with self._io_lock:
                while self._stats.boots == 0 and time.monotonic() < deadline:
                    self._read_frames(min(deadline, time.monotonic() + 0.02))
        deadline = time.monotonic() + self.connect_timeout_s
        while True:
            try:
                with self._io_lock:
                    ack = self._request(wire.PING, (), count_failure=False)
                if ack is not None:
                    self._stats.consecutive_failures = 0
                    break
            except LinkError:
                self.close()
                raise
            if time.monotonic() >= deadline:
                self.close()
                raise LinkError(
                    f"{self.url}: no answer from the robot board within "
                    f"{self.connect_timeout_s:g} s (is the firmware running and the baud rate "
                    f"{self.baudrate}?)"
                )
        # A board that booted before the port opened may still wait for its hello: the first
        # drive request learns its boot count (a version query) and answers it.
        with self._io_lock:
            if self.boot_count is None:
                self._boot_unanswered = True
        if self.watchdog_ms is not None:
            self.set_watchdog_ms(self.watchdog_ms)
        self._start_keepalive()
        return self

    def close(self) -> None:
        """Stop the motors (best effort), stop the keep-alive thread and close the port."""
        if self._port is None:
            return
        self.stop()
        self._stop_event.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._thread = None
        with self._io_lock:
            try:
                self._port.close()
            except Exception:  # noqa: BLE001 - closing a broken port must not raise
                pass
            self._port = None

    # ------------------------------------------------------------------ requests
    def drive(self, command: Command | int | str, *, lease_s: float | None = None) -> Ack:
        """Send a drive command and return what the board acknowledged.

        ``command``: a ``Command`` (or its int) or a letter ``F``/``L``/``R``/``S``.
        ``lease_s``: how long the keep-alive thread keeps re-sending this command (default:
        until the next request; pass a bound so a hung caller cannot keep the robot moving).
        The lease ends early if the board refuses the drive for its e-stop or reboots. After a
        reboot the host has seen, this request first answers the boot (hello ``K``, firmware
        1.2); one written before the host saw it is refused with ``BOOT`` and returned so.
        ``lease_s=0`` sends the frame once and leaves the stop to the board's watchdog (used by
        the watchdog self-test). Raises ``LinkError`` on link loss.
        """
        letter = drive_letter(command)
        self._raise_if_failed()
        # With the link held, so that a boot frame read by a keep-alive exchange in progress
        # ends the old lease before this one is set, never this one.
        with self._io_lock:
            now = time.monotonic()
            with self._lease_lock:
                if letter == STOP or (lease_s is not None and lease_s <= 0):
                    self._lease.letter, self._lease.until = STOP, 0.0  # nothing to refresh
                else:
                    self._lease.letter = letter
                    self._lease.until = float("inf") if lease_s is None else now + lease_s
            return self._drive_now(letter)

    def wait_for_watchdog_stop(self, timeout_s: float) -> float | None:
        """Wait for the board's ``$W`` (its watchdog stopped the motors); seconds waited or None."""
        self._raise_if_failed()
        start = time.monotonic()
        before = self._stats.watchdog_stops
        deadline = start + timeout_s
        while time.monotonic() < deadline:
            with self._io_lock:
                self._read_frames(min(deadline, time.monotonic() + 0.01))
                if self._stats.watchdog_stops > before:
                    return time.monotonic() - start
        return None

    def ping(self) -> Ack:
        """Ping the board (never starts motion); returns its ack with the round-trip time."""
        return self._checked(wire.PING, ())

    def query_version(self) -> BoardVersion | None:
        """Ask the board for its firmware version and last reset cause (``V``; never moves).

        Works whenever the board runs, unlike the boot frame, which is only seen if the port was
        open when the board started. Sets ``firmware_version`` and ``reset_cause``. Returns None
        if the board does not know the query (firmware before 1.1 rejects it as ``TYPE``).
        """
        ack = self._checked(wire.VERSION, ())
        if not ack.accepted or len(ack.info) < 2:
            return None
        self.firmware_version, self.reset_cause = ack.info[0], ack.info[1]
        count = boot_count_of(ack.info[2:3])
        if count is not None:
            self.boot_count = count
        return BoardVersion(ack.info[0], ack.info[1], ack, count)

    def estop(self) -> Ack:
        """Latch the board's emergency stop (motors off until ``clear_estop()`` and a new drive)."""
        with self._lease_lock:
            self._lease.letter, self._lease.until = STOP, 0.0
        return self._checked(wire.ESTOP, ())

    def clear_estop(self) -> Ack:
        """Clear a latched e-stop; the motors stay off until the next drive command."""
        return self._checked(wire.CLEAR, ())

    def set_watchdog_ms(self, ms: int) -> Ack:
        """Set the board's motor watchdog period [ms] (50..2000)."""
        if not wire.WATCHDOG_MIN_MS <= int(ms) <= wire.WATCHDOG_MAX_MS:
            raise ValueError(
                f"watchdog period must be {wire.WATCHDOG_MIN_MS}..{wire.WATCHDOG_MAX_MS} "
                f"ms, got {ms}"
            )
        ack = self._checked(wire.SET_WATCHDOG, (str(int(ms)),))
        if ack.accepted:
            self.watchdog_ms = int(ms)
        return ack

    def stop(self) -> bool:
        """Stop the motors, best effort. True if the board acknowledged ``S``.

        Raises nothing but a ``KeyboardInterrupt`` that lands in it: the stop is then sent once
        more (the interrupted frame may be cut short) and the interrupt re-raised, so a Ctrl-C
        both stops the robot and reaches the caller.
        """
        with self._lease_lock:
            self._lease.letter, self._lease.until = STOP, 0.0
        interrupt: KeyboardInterrupt | None = None
        stopped = False
        for _ in range(2):  # a second go only after an interrupt
            try:
                stopped = self._send_stop()
                break
            except KeyboardInterrupt as exc:
                interrupt = interrupt or exc
            except Exception:  # noqa: BLE001 - best effort: the lease and watchdog stop anyway
                break
        if interrupt is not None:
            raise interrupt
        return stopped

    def _send_stop(self) -> bool:
        if self._port is None:
            return False
        with self._io_lock:
            for _ in range(2):  # one retry: stopping matters more than latency
                ack = self._request(wire.DRIVE, (STOP,), count_failure=False)
                if ack is not None:
                    return ack.accepted or ack.rejected == wire.REASON_ESTOP
        return False

    def poll(self) -> None:
        """Read pending board messages (``$W``, ``$B``) without sending; raises on link loss."""
        self._raise_if_failed()
        with self._io_lock:
            self._read_frames(time.monotonic())

    def lease_letter(self) -> str:
        """The command the keep-alive thread is currently refreshing (``S`` when none)."""
        with self._lease_lock:
            if time.monotonic() >= self._lease.until:
                return STOP
            return self._lease.letter

    # ------------------------------------------------------------------ internals
    def _raise_if_failed(self) -> None:
        if self._failure is not None:
            raise self._failure
        if self._port is None:
            raise LinkError(f"{self.url}: link is not connected")

    def request(self, frame_type: str, *args: str) -> Ack:
        """Send any frame (diagnostics, e.g. an out-of-range value) and return the board's answer.

        Retries until a reply arrives or the failure bound is reached (then ``LinkError``).
        """
        return self._checked(frame_type, tuple(args))

    def _checked(self, frame_type: str, args: tuple[str, ...]) -> Ack:
        """One request with retries until acknowledged or the failure bound is reached."""
        self._raise_if_failed()
        with self._io_lock:
            while True:
                ack = self._request(frame_type, args, count_failure=True)
                if ack is not None:
                    return ack

    def _drive_now(self, letter: str) -> Ack:
        """An application's drive request: answers a boot the host has seen, then drives."""
        with self._io_lock:
            if letter != STOP:
                refused = self._answer_boot()
                if refused is not None:
                    self._end_lease()
                    return Ack(refused.seq, letter, self._state, "", refused.rejected, 0.0)
            return self._checked(wire.DRIVE, (letter,))

    def _answer_boot(self) -> Ack | None:
        """Send the hello for the board's current boot if it waits for one; never from the
        keep-alive. Returns the board's refusal if it would not take it, else None."""
        if not self._boot_unanswered:
            return None
        if self.boot_count is None and self.query_version() is None:
            self._boot_unanswered = False  # firmware before 1.1: it knows no hello
            return None
        if self.boot_count is None:
            self._boot_unanswered = False  # firmware 1.1: no boot count, no hello
            return None
        ack = self._checked(wire.HELLO, (str(self.boot_count),))
        if ack.rejected == wire.REASON_BOOT:
            # Not the board's current boot (a boot frame was missed): ask, and try once more.
            self.boot_count = None
            if self.query_version() is not None and self.boot_count is not None:
                ack = self._checked(wire.HELLO, (str(self.boot_count),))
        if ack.accepted or ack.rejected == wire.REASON_TYPE:
            self._boot_unanswered = False  # answered, or firmware that knows no hello
            return None
        return ack

    def _next_seq(self) -> int:
        self._seq = self._seq % (wire.SEQ_MODULO - 1) + 1  # 1..65535; 0 is the board's
        return self._seq

    def _end_lease(self) -> None:
        """Stop refreshing the leased drive command (the board is not told)."""
        with self._lease_lock:
            self._lease.letter, self._lease.until = STOP, 0.0

    def _fail(self, message: str) -> LinkError:
        if self._failure is None:
            self._failure = LinkError(f"{self.url}: {message}")
        return self._failure

    def _write(self, data: bytes) -> None:
        try:
            self._port.write(data)
            self._port.flush()
        except (serial.SerialException, OSError, ValueError, AttributeError, TypeError) as exc:
            raise self._fail(f"serial link lost while sending ({exc})") from None

    def _read_frames(self, deadline: float) -> list[Frame]:
        """Read until at least one valid frame arrived or ``deadline`` passed; handle events.

        Returns the valid frames read (possibly none). Updates corrupt/event counters.
        """
        frames: list[Frame] = []
        while True:
            try:
                waiting = self._port.in_waiting
                data = self._port.read(max(1, min(int(waiting), 256)))
            except (serial.SerialException, OSError, ValueError, AttributeError, TypeError) as exc:
                raise self._fail(f"serial link lost while reading ({exc})") from None
            if data:
                for item in self._parser.feed(bytes(data)):
                    if isinstance(item, FrameError):
                        self._stats.corrupt += 1
                        self._corrupt_run += 1
                        if self._corrupt_run > self.max_corrupt_replies:
                            raise self._fail(
                                f"{self._corrupt_run} corrupt replies in a row from the board "
                                f"(last: {item.reason}); check the baud rate and the wiring"
                            )
                        continue
                    self._corrupt_run = 0
                    if item.type == wire.BOOT:
                        self._stats.boots += 1
                        self._state = STOP  # a fresh board has its motors off
                        self._end_lease()  # and only a new drive request may start them
                        count = boot_count_of(item.args[3:4])
                        self.boot_count = count
                        self._boot_unanswered = count is not None  # firmware 1.2 waits
                        if item.args:
                            self.firmware_version = item.args[0]
                        if len(item.args) >= 3:  # firmware 1.1: reset cause, flags
                            self.reset_cause = item.args[1]
                            flags = item.args[2]
                            if flags.isdigit() and int(flags) & FLAG_ESTOP:
                                self._state = ESTOPPED  # booted latched (e.g. after a fault)
                    elif item.type == wire.WATCHDOG_STOP:
                        self._stats.watchdog_stops += 1
                        self._state = STOP
                    else:
                        frames.append(item)
            if frames or time.monotonic() >= deadline:
                return frames
            if not data and not getattr(self._port, "timeout", None):
                time.sleep(0.001)  # a non-blocking port: do not spin at full speed

    def _request(
        self, frame_type: str, args: tuple[str, ...], *, count_failure: bool
    ) -> Ack | None:
        """Send one frame and wait for its reply; None if no valid reply came in time.

        With ``count_failure`` a missed reply counts towards the link-loss bound and raises
        ``LinkError`` when it is reached.
        """
        if self._port is None:
            raise self._fail("link is not connected")
        seq = self._next_seq()
        data = wire.encode_frame(frame_type, seq, *args)
        sent_at = time.monotonic()
        self._write(data)
        self._stats.sent += 1
        if frame_type == wire.DRIVE:
            self._last_drive_sent = sent_at
        deadline = sent_at + self.ack_timeout_s
        corrupt_before = self._stats.corrupt
        requested = args[0] if frame_type == wire.DRIVE else frame_type
        resend = False
        while not resend and time.monotonic() < deadline:
            for frame in self._read_frames(deadline):
                if frame.seq != seq or frame.type not in (wire.ACK, wire.NAK):
                    self._stats.stale += 1  # an older reply, or one the host did not ask for
                    continue
                rtt_ms = (time.monotonic() - sent_at) * 1000.0
                if frame.type == wire.ACK:
                    self._stats.acks += 1
                    self._stats.consecutive_failures = 0
                    self._stats.rtt_ms = rtt_ms
                    self._stats.max_rtt_ms = max(self._stats.max_rtt_ms, rtt_ms)
                    state = frame.args[0] if frame.args else self._state
                    flags = frame.args[1] if len(frame.args) > 1 else ""
                    self._state = state
                    return Ack(seq, requested, state, flags, None, rtt_ms, frame.args[2:])
                reason = frame.args[0] if frame.args else "?"
                if reason in (wire.REASON_CRC, wire.REASON_FRAME):
                    # Our frame was damaged on the way: resend. Counts as a failure so a link
                    # that damages everything still ends in LinkError.
                    self._stats.naks += 1
                    resend = True
                    break
                self._stats.naks += 1
                self._stats.consecutive_failures = 0
                if reason == wire.REASON_ESTOP:
                    self._state = ESTOPPED
                    if frame_type == wire.DRIVE:
                        self._end_lease()  # else clearing the e-stop would restart the drive
                if reason == wire.REASON_BOOT and frame_type == wire.DRIVE:
                    # The board rebooted and waits for a hello, which only a new drive request
                    # sends: the lease of the old one ends here.
                    self._state = STOP
                    self._boot_unanswered = True
                    self._end_lease()
                return Ack(seq, requested, self._state, "", reason, rtt_ms)
            if self._stats.corrupt > corrupt_before:
                resend = True  # the reply was damaged: resend now rather than wait it out
        self._stats.missed += 1
        if count_failure:
            self._stats.consecutive_failures += 1
            if self._stats.consecutive_failures >= self.max_consecutive_failures:
                raise self._fail(
                    f"no valid reply from the robot board to {self._stats.consecutive_failures} "
                    f"requests in a row (link lost?)"
                )
        return None

    # ------------------------------------------------------------------ keep-alive
    def _start_keepalive(self) -> None:
        if self._thread is not None:
            return
        self._stop_event.clear()
        self._thread = threading.Thread(
            target=self._keepalive_loop, name=f"lfd-track keep-alive {self.url}", daemon=True
        )
        self._thread.start()

    def keepalive(self) -> Ack | None:
        """Re-send the leased drive command if it is due; send stop once when the lease ends.

        Called by the background thread every ``keepalive_period_s``; safe to call from a control
        loop too. Returns the ack if a frame was sent.
        """
        if self._failure is not None or self._port is None:
            return None
        # The lease is read with the link held: a stop() or drive() that changed it while this
        # thread waited for the link has gone out already and must not be followed by the old
        # command (over a slow link its reply can take longer than the period checked below).
        with self._io_lock:
            with self._lease_lock:
                letter, until = self._lease.letter, self._lease.until
                expired = letter != STOP and time.monotonic() >= until
                if expired:
                    self._lease.letter = STOP
            if expired:
                self.stop()
                return None
            if letter == STOP:
                return None
            if time.monotonic() - self._last_drive_sent < self.keepalive_period_s * 0.9:
                return None  # a drive went out recently anyway
            ack = self._checked(wire.DRIVE, (letter,))
            self._stats.keepalives += 1
            return ack

    def _keepalive_loop(self) -> None:
        while not self._stop_event.wait(self.keepalive_period_s / 2):
            try:
                self.keepalive()
            except LinkError:
                # Recorded in self._failure; the caller sees it on its next request. Try to stop
                # the motors in case only the replies are lost.
                self.stop()
                return
            except Exception as exc:  # noqa: BLE001 - the thread must not die silently
                self._fail(f"keep-alive failed ({exc!r})")
                self.stop()
                return
