"""RobotLink against a fake board served on loopback (``socket://127.0.0.1:PORT``).

``FakeBoard`` speaks the wire protocol from a thread and can be told to misbehave: stop acking,
corrupt its replies, or drop the connection. ``test_hardware_env.py`` reuses it.
"""

from __future__ import annotations

import _thread
import socket
import statistics
import threading
import time

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lfd_track.core.commands import Command
from lfd_track.errors import LfdTrackError
from lfd_track.hardware import wire
from lfd_track.hardware.link import LinkError, RobotLink

WAIT_S = 5.0  # upper bound for event waits; never reached when the code works


class FakeBoard:
    """A threaded TCP server that behaves like the robot firmware, with fault injection.

    ``mode``: ``"ok"``, ``"silent"`` (reads but never replies), ``"corrupt"`` (replies with a bad
    CRC) or ``"disconnect"`` (closes the connection on the next frame). ``fault_after``: the number
    of frames answered normally before ``mode`` applies. ``version``: answer the version query
    ``V`` with it (and reset cause ``EXT``) like firmware 1.1; without it ``V`` gets a plain ack. ``boot_delay_s``: when the boot frame
    goes out after the connection opens (if ``boot``), as if the board were reset then; frames
    are answered before it too. Every frame received is recorded with its
    arrival time in ``received``. ``lease_lapses`` counts the times the real firmware's watchdog
    would have stopped the motors: a drive frame arrived while moving, more than ``watchdog_ms``
    after the previous one.
    """

    def __init__(
        self,
        *,
        mode: str = "ok",
        fault_after: int = 0,
        boot: bool = True,
        boot_delay_s: float = 0.05,
        on_frame=None,
        version: str | None = None,
    ) -> None:
        self.mode = mode
        self.fault_after = fault_after
        self.boot = boot
        self.boot_delay_s = boot_delay_s
        self.on_frame = on_frame
        self.version = version
        self.received: list[tuple[float, wire.Frame]] = []
        self.state = "S"
        self.estopped = False
        self.watchdog_ms = 300
        self.lease_lapses = 0
        self._last_drive_at: float | None = None
        self.changed = threading.Condition()
        self._server = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self._server.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self._server.bind(("127.0.0.1", 0))
        self._server.listen(1)
        self._closed = threading.Event()
        self._conn: socket.socket | None = None
        self._thread = threading.Thread(target=self._serve, daemon=True)

    @property
    def url(self) -> str:
        return f"socket://127.0.0.1:{self._server.getsockname()[1]}"

    def __enter__(self) -> FakeBoard:
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._closed.set()
        for sock in (self._server, self._conn):
            try:
                if sock is not None:
                    sock.close()
            except OSError:
                pass
        self._thread.join(timeout=WAIT_S)

    def drives(self) -> list[str]:
        """Drive letters received so far, in order."""
        with self.changed:
            return [f.args[0] for _, f in self.received if f.type == wire.DRIVE and f.args]

    def wait_for(self, predicate, timeout_s: float = WAIT_S) -> bool:
        """Wait until ``predicate(self)`` holds (woken by every received frame)."""
        with self.changed:
            return self.changed.wait_for(lambda: predicate(self), timeout=timeout_s)

    def _reply(self, conn: socket.socket, frame_type: str, seq: int, *args: str) -> None:
        data = wire.encode_frame(frame_type, seq, *args)
        if self.mode == "corrupt" and self._faulty():
            data = data[:-3] + (b"0" if data[-3:-2] != b"0" else b"1") + data[-2:]
        conn.sendall(data)

    def _faulty(self) -> bool:
        return len(self.received) > self.fault_after

    def _handle(self, conn: socket.socket, frame: wire.Frame) -> bool:
        now = time.monotonic()
        if frame.type == wire.DRIVE:
            moving = self.state in ("F", "L", "R")
            if moving and now - self._last_drive_at > self.watchdog_ms / 1000:
                self.lease_lapses += 1
            self._last_drive_at = now
        with self.changed:
            self.received.append((now, frame))
            self.changed.notify_all()
        if self.on_frame is not None:
            self.on_frame(self, frame)
        if self._faulty() and self.mode == "disconnect":
            return False
        if self._faulty() and self.mode == "silent":
            return True
        if frame.type == wire.DRIVE:
            if self.estopped:
                self._reply(conn, wire.NAK, frame.seq, wire.REASON_ESTOP)
                return True
            self.state = frame.args[0]
        elif frame.type == wire.ESTOP:
            self.estopped, self.state = True, "X"
        elif frame.type == wire.CLEAR:
            self.estopped = False
            self.state = "S"
        elif frame.type == wire.SET_WATCHDOG:
            ms = int(frame.args[0])
            if not wire.WATCHDOG_MIN_MS <= ms <= wire.WATCHDOG_MAX_MS:
                self._reply(conn, wire.NAK, frame.seq, wire.REASON_ARG)
                return True
            self.watchdog_ms = ms
        elif frame.type == wire.VERSION and self.version is not None:
            flags = "1" if self.estopped else "0"
            self._reply(conn, wire.ACK, frame.seq, self.state, flags, self.version, "EXT")
            return True
        self._reply(conn, wire.ACK, frame.seq, self.state, "1" if self.estopped else "0")
        return True

    def _serve(self) -> None:
        try:
            conn, _ = self._server.accept()
        except OSError:
            return
        self._conn = conn
        parser = wire.FrameParser()
        # Like a real bootloader, announce a moment after the port opens (pyserial drops input
        # that arrives while it is still opening the port); frames are answered meanwhile.
        boot_at = time.monotonic() + self.boot_delay_s if self.boot else None
        try:
            while not self._closed.is_set():
                if boot_at is not None:
                    if time.monotonic() >= boot_at:
                        conn.sendall(wire.encode_frame(wire.BOOT, 0, "fake-1"))
                        boot_at = None
                    conn.settimeout(
                        None if boot_at is None else max(boot_at - time.monotonic(), 0.001)
                    )
                try:
                    data = conn.recv(256)
                except TimeoutError:
                    continue  # time to boot
                if not data:
                    return
                for item in parser.feed(data):
                    if isinstance(item, wire.FrameError):
                        self._reply(conn, wire.NAK, 0, item.reason)
                    elif not self._handle(conn, item):
                        conn.shutdown(socket.SHUT_RDWR)
                        conn.close()
                        return
        except OSError:
            return


def make_link(board: FakeBoard, **kwargs) -> RobotLink:
    kwargs.setdefault("boot_wait_s", 1.0)
    return RobotLink(board.url, **kwargs)


def test_connect_reads_boot_version_and_pings() -> None:
    with FakeBoard() as board, make_link(board) as link:
        assert link.firmware_version == "fake-1"
        assert [f.type for _, f in board.received][:1] == [wire.PING]
        ack = link.ping()
        assert ack.accepted and ack.requested == wire.PING
        assert link.stats().rtt_ms > 0


def test_drive_returns_what_the_board_acknowledged() -> None:
    with FakeBoard() as board, make_link(board) as link:
        ack = link.drive(Command.LEFT)
        assert (ack.requested, ack.state, ack.accepted) == ("L", "L", True)
        assert link.drive("S").state == "S"
        seqs = [f.seq for _, f in board.received]
        assert seqs == sorted(seqs) and len(set(seqs)) == len(seqs)


def test_estop_latches_and_drive_is_refused_until_cleared() -> None:
    with FakeBoard() as board, make_link(board) as link:
        link.drive(Command.FORWARD)
        stopped = link.estop()
        assert stopped.accepted and stopped.estopped and not stopped.moving
        refused = link.drive(Command.FORWARD)
        assert refused.rejected == wire.REASON_ESTOP and refused.state == "X"
        assert refused.estopped and not refused.accepted
        assert link.stop()  # stop is "done" when the board is e-stopped
        cleared = link.clear_estop()
        assert cleared.accepted and not cleared.estopped and cleared.state == "S"
        assert link.drive(Command.FORWARD).state == "F"


def test_set_watchdog_validates_range() -> None:
    with FakeBoard() as board, make_link(board) as link:
        assert link.set_watchdog_ms(250).accepted
        assert board.watchdog_ms == 250
        with pytest.raises(ValueError):
            link.set_watchdog_ms(10)


def test_close_stops_the_motors() -> None:
    with FakeBoard() as board:
        with make_link(board) as link:
            link.drive(Command.FORWARD)
        assert board.drives()[-1] == "S"
        assert board.state == "S"


def test_a_ctrl_c_landing_in_a_stop_stops_the_motors_and_reaches_the_caller() -> None:
    """The board gets the stop, Ctrl-C comes before its ack is read (the interrupt is set before
    the board answers, so it lands inside ``stop``): the stop is sent again and the interrupt
    raised, not swallowed by the best-effort stop."""

    def interrupt_on_first_stop(board, frame) -> None:
        if frame.type == wire.DRIVE and frame.args == ("S",) and board.drives().count("S") == 1:
            _thread.interrupt_main()  # what Ctrl-C does to the control loop

    with FakeBoard() as board, make_link(board) as link:
        link.drive(Command.FORWARD)
        board.on_frame = interrupt_on_first_stop
        with pytest.raises(KeyboardInterrupt):
            link.stop()
        board.on_frame = None
        assert board.drives()[-2:] == ["S", "S"]
        assert board.state == "S"
        assert link.lease_letter() == "S"


def test_keepalive_refreshes_the_lease_faster_than_the_watchdog() -> None:
    # Gaps are taken where the board receives the frames. A loaded machine can delay a single
    # keep-alive, so the bounds are loose: with the board's watchdog at 1 s the lease must never
    # lapse, and the typical gap must suit the default 300 ms watchdog. Without keep-alive the
    # board would see one drive frame and the wait below would fail.
    with FakeBoard() as board, make_link(board, keepalive_period_s=0.1, watchdog_ms=1000) as link:
        assert board.watchdog_ms == 1000
        link.drive(Command.FORWARD, lease_s=10.0)
        assert board.wait_for(lambda b: b.drives().count("F") >= 10)
        times = [t for t, f in board.received if f.type == wire.DRIVE and f.args == ("F",)]
        gaps = [b - a for a, b in zip(times, times[1:], strict=False)]
        assert board.lease_lapses == 0, gaps
        assert statistics.median(gaps) < 0.25, gaps
        assert link.stats().keepalives >= 9


def test_expired_lease_sends_stop() -> None:
    with FakeBoard() as board, make_link(board) as link:
        link.drive(Command.RIGHT, lease_s=0.3)
        assert board.wait_for(lambda b: b.drives()[-1:] == ["S"])
        assert link.lease_letter() == "S"


@pytest.mark.parametrize("mode", ["silent", "corrupt", "disconnect"])
def test_board_faults_raise_link_error(mode: str) -> None:
    with FakeBoard(mode=mode, fault_after=2) as board:
        link = make_link(board)
        link.connect()
        try:
            with pytest.raises(LinkError) as info:
                for _ in range(20):
                    link.drive(Command.FORWARD)
            assert isinstance(info.value, LfdTrackError)
            assert board.url in str(info.value)
            assert link.failure is info.value
            with pytest.raises(LinkError):
                link.ping()  # the failure is sticky
        finally:
            link.close()
        if mode != "disconnect":
            # The board still hears us: close() (and the failure path) sent stop.
            assert board.drives()[-1] == "S"


def test_unreachable_port_is_a_clear_error() -> None:
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    port = sock.getsockname()[1]
    sock.close()  # nothing listens there now
    with pytest.raises(LinkError, match="cannot open serial link"):
        RobotLink(f"socket://127.0.0.1:{port}").connect()


def test_board_that_never_answers_fails_connect() -> None:
    with FakeBoard(mode="silent", boot=False) as board:
        link = RobotLink(board.url, connect_timeout_s=0.3)
        with pytest.raises(LinkError, match="no answer"):
            link.connect()
        assert not link.is_open


class ScriptedPort:
    """A serial-like object whose replies are fixed bytes (for fuzzing the reply handling)."""

    timeout = 0

    def __init__(self, replies: bytes) -> None:
        self._replies = bytearray(replies)
        self.written = bytearray()

    @property
    def in_waiting(self) -> int:
        return len(self._replies)

    def reply(self, data: bytes) -> None:
        """Queue more bytes from the board."""
        self._replies += data

    def read(self, n: int) -> bytes:
        out = bytes(self._replies[:n])
        del self._replies[:n]
        return out

    def write(self, data: bytes) -> int:
        self.written += data
        return len(data)

    def flush(self) -> None:
        pass

    def close(self) -> None:
        pass


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=400))
def test_reply_handling_never_crashes_on_random_bytes(noise: bytes) -> None:
    port = ScriptedPort(noise)
    link = RobotLink(
        "scripted", ack_timeout_s=0.002, max_consecutive_failures=2, port_factory=lambda: port
    )
    link.open()
    try:
        ack = link.drive(Command.FORWARD)
        assert ack.requested == "F"  # random bytes cannot forge a CRC-checked ack for seq 1..
    except LinkError:
        pass
    assert link._parser.buffered <= wire.MAX_LINE_BYTES + 1
    link.close()
    assert b"$D," in bytes(port.written)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.binary(max_size=200), st.binary(max_size=50))
def test_valid_ack_is_found_among_noise(before: bytes, after: bytes) -> None:
    ack = wire.encode_frame(wire.ACK, 1, "F", "0")
    port = ScriptedPort(before + ack + after)
    # The ack is always there; 2 ms was too short for a loaded machine to read it.
    link = RobotLink("scripted", ack_timeout_s=0.05, port_factory=lambda: port)
    link.open()
    try:
        reply = link.drive(Command.FORWARD)
    except LinkError as exc:
        # Only an implausibly long run of broken lines may hide the ack.
        assert "corrupt replies" in str(exc)
    else:
        assert (reply.seq, reply.state, reply.accepted) == (1, "F", True)
    assert link._parser.buffered <= wire.MAX_LINE_BYTES + 1
    link.ack_timeout_s = 0.002  # close() sends stop, which nothing answers here
    link.close()


def test_query_version_reads_version_and_reset_cause() -> None:
    with (
        FakeBoard(boot=False, version="fake-1.1") as board,
        make_link(board, boot_wait_s=0) as link,
    ):
        assert link.firmware_version is None  # no boot frame seen
        answer = link.query_version()
        assert answer is not None and (answer.version, answer.reset_cause) == ("fake-1.1", "EXT")
        assert answer.reset_cause_text == "reset pin" and answer.ack.accepted
        assert (link.firmware_version, link.reset_cause) == ("fake-1.1", "EXT")


def test_query_version_of_firmware_without_it_is_none() -> None:
    # Firmware 1.0 rejects the unknown type; a plain ack carries no version either.
    port = ScriptedPort(wire.encode_frame(wire.NAK, 1, wire.REASON_TYPE))
    link = RobotLink("scripted", ack_timeout_s=0.05, port_factory=lambda: port)
    link.open()
    assert link.query_version() is None and link.firmware_version is None
    with FakeBoard(boot=False) as board, make_link(board, boot_wait_s=0) as link:
        assert link.query_version() is None


def test_a_boot_frame_names_the_reset_cause_and_a_latched_boot() -> None:
    boot = wire.encode_frame(wire.BOOT, 0, "1.1", "WDT", "1")
    port = ScriptedPort(boot)
    link = RobotLink("scripted", ack_timeout_s=0.05, port_factory=lambda: port)
    link.open()
    link.poll()
    assert (link.firmware_version, link.reset_cause, link.state) == ("1.1", "WDT", "X")
    port.reply(wire.encode_frame(wire.NAK, 1, wire.REASON_ESTOP))
    refused = link.drive("F")
    assert refused.rejected == wire.REASON_ESTOP and refused.estopped


def test_ack_flags_report_dropped_replies() -> None:
    port = ScriptedPort(wire.encode_frame(wire.ACK, 1, "S", "4"))
    link = RobotLink("scripted", ack_timeout_s=0.05, port_factory=lambda: port)
    link.open()
    ack = link.ping()
    assert ack.replies_dropped and not ack.estopped and not ack.lease_expired


# --- the keep-alive never drives on behind the caller's back ---------------------------------


def _drives_after(board: FakeBoard, frame_type: str) -> list[str]:
    """Drive letters the board received after the last frame of ``frame_type``."""
    with board.changed:
        frames = [f for _, f in board.received]
    last = max(i for i, f in enumerate(frames) if f.type == frame_type)
    return [f.args[0] for f in frames[last + 1 :] if f.type == wire.DRIVE and f.args]


def test_a_stop_is_not_overtaken_by_a_keepalive_of_the_old_lease() -> None:
    """The keep-alive thread read its lease (F), then waited for the link while stop() ran.

    Over a slow link (Bluetooth) the stop's ack takes longer than the keep-alive period, so the
    "a drive went out recently" check no longer covered it: the thread sent the old F after the
    stop, and the board drove on for a whole lease (up to 2 s).
    """

    def slow_stop_ack(_board: FakeBoard, frame: wire.Frame) -> None:
        if frame.type == wire.DRIVE and frame.args == ("S",):
            time.sleep(0.11)  # within the 0.15 s ack timeout, longer than 0.9 x 0.1 s

    with FakeBoard(on_frame=slow_stop_ack) as board, make_link(board) as link:
        link.drive(Command.FORWARD)
        with link._io_lock:  # hold the link: the keep-alive thread reads F and waits here
            time.sleep(0.2)  # several keep-alive wake-ups (every 0.05 s)
            assert link.stop()
        time.sleep(0.3)
        assert board.drives()[-1] == "S", board.drives()
        assert board.state == "S"


def test_a_drive_refused_for_the_estop_is_not_kept_alive_and_clearing_does_not_restart() -> None:
    """The board latched on its own (a watchdog or brown-out reset whose boot frame was lost):
    the refused drive's lease must end, or the keep-alive restarts the motors once the e-stop
    is cleared, without any new drive request."""
    with FakeBoard() as board, make_link(board) as link:
        board.estopped, board.state = True, "X"
        refused = link.drive(Command.FORWARD)  # lease until the next request
        assert refused.rejected == wire.REASON_ESTOP
        assert link.lease_letter() == "S"
        assert link.clear_estop().accepted
        time.sleep(0.4)  # four keep-alive periods
        assert _drives_after(board, wire.CLEAR) == []
        assert board.state == "S"


def test_a_board_reset_ends_the_lease() -> None:
    """After the board rebooted (boot frame) the keep-alive must not start it again: a board
    boots with its motors off, and only a new drive request may move it."""
    with (
        FakeBoard(boot_delay_s=0.4) as board,  # the board resets 0.4 s after the port opened
        make_link(board, boot_wait_s=0) as link,
    ):
        link.drive(Command.FORWARD)
        deadline = time.monotonic() + WAIT_S
        while link.stats().boots == 0:  # the keep-alive's requests read the boot frame
            assert time.monotonic() < deadline, "the link never saw the boot frame"
            time.sleep(0.01)
        seen = len(board.drives())
        time.sleep(0.4)
        assert "F" not in board.drives()[seen:], board.drives()
        assert link.lease_letter() == "S"
        assert link.drive(Command.FORWARD).state == "F"  # an explicit request drives again
