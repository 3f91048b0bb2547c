"""Fixtures that run the real rover firmware in simavr and talk to it over its pty.

Without the AVR toolchain or simavr the firmware tests are skipped, except under CI=true, where
a missing tool is a failure: CI installs them (``.ci/run``), so their absence is a broken build.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest
import serial
from lfd_test_support import unavailable

from lfd_track.hardware import wire
from lfd_track.hardware.simavr import FIRMWARE_BAUD, SimulatedBoard, ToolMissingError, missing_tools

# Failure guard only: every wait below returns as soon as the awaited data arrives.
REPLY_TIMEOUT_S = 5.0


def _tools_unavailable(reason: str) -> None:
    unavailable(f"the simavr firmware tests need the AVR toolchain and simavr: {reason}")


@pytest.fixture(scope="module")
def simulated_board() -> Iterator[SimulatedBoard]:
    """One simulated board per test module (booting per test would be slower, not safer)."""
    missing = missing_tools()
    if missing:
        _tools_unavailable("; ".join(missing))
    board = SimulatedBoard()
    try:
        board.start()
    except ToolMissingError as exc:
        _tools_unavailable(str(exc))
    try:
        yield board
    finally:
        board.close()


class BoardLink:
    """Serial link to the simulated board, decoding its frames with the host codec."""

    def __init__(self, board: SimulatedBoard, port: serial.SerialBase) -> None:
        self.board = board
        self.port = port
        self._parser = wire.FrameParser()
        self._pending: list[wire.Frame | wire.FrameError] = []
        self._seq = 0

    def next_seq(self) -> int:
        self._seq = (self._seq + 1) % wire.SEQ_MODULO
        return self._seq

    def write(self, data: bytes) -> None:
        self.port.write(data)
        self.port.flush()

    def send(self, frame_type: str, *args: str) -> int:
        """Send one well-formed frame; return its seq."""
        seq = self.next_seq()
        self.write(wire.encode_frame(frame_type, seq, *args))
        return seq

    def read_frame(self, timeout_s: float = REPLY_TIMEOUT_S) -> wire.Frame:
        """Next frame from the board; fails on a malformed one or when nothing comes in time."""
        deadline = time.monotonic() + timeout_s
        while not self._pending:
            if time.monotonic() > deadline:
                raise AssertionError(f"no frame from the board within {timeout_s} s")
            self._pending.extend(self._parser.feed(self.port.read(self.port.in_waiting or 1)))
        item = self._pending.pop(0)
        assert isinstance(item, wire.Frame), f"board sent a malformed line: {item}"
        return item

    def wait_for(
        self, accept: Callable[[wire.Frame], bool], timeout_s: float = REPLY_TIMEOUT_S
    ) -> tuple[wire.Frame, list[wire.Frame]]:
        """Read until a frame satisfies ``accept``; return it and the frames skipped before it."""
        deadline = time.monotonic() + timeout_s
        skipped = []
        while True:
            frame = self.read_frame(max(deadline - time.monotonic(), 0.0))
            if accept(frame):
                return frame, skipped
            skipped.append(frame)

    def reply_to(self, seq: int) -> wire.Frame:
        """The ack or reject carrying ``seq``; any other frame in between fails the test."""
        frame = self.read_frame()
        assert frame.type in (wire.ACK, wire.NAK) and frame.seq == seq, (
            f"expected the reply to seq {seq}, got {frame}"
        )
        return frame

    def request(self, frame_type: str, *args: str) -> wire.Frame:
        """Send a frame and return the board's reply to it."""
        return self.reply_to(self.send(frame_type, *args))

    def acknowledge_boot(self, boot: wire.Frame) -> wire.Frame:
        """Tell the board the host has seen ``boot`` (its hello ``K``); return the board's reply.

        Until then the board refuses every drive frame but stop (firmware 1.2).
        """
        return self.request(wire.HELLO, boot.args[3] if len(boot.args) > 3 else "0")

    def reset(self, cause: str = "external", acknowledge: bool = True) -> wire.Frame:
        """Reset the board; return its boot frame once every frame from before it is consumed.

        ``cause``: see ``SimulatedBoard.reset`` (an external reset keeps a latched e-stop).
        ``acknowledge``: answer the boot with the hello frame, as an application about to
        drive does, so that drive frames are obeyed again.

        The ping sent after the reset is answered only after the new boot frame went out, so
        reading up to its ack skips stale frames, including a late boot frame from an earlier
        boot, and leaves the stream empty.
        """
        self.board.reset(cause=cause)
        seq = self.send(wire.PING)
        _, skipped = self.wait_for(lambda f: f.type == wire.ACK and f.seq == seq)
        boots = [f for f in skipped if f.type == wire.BOOT]
        assert boots, f"no boot frame after the reset, only {skipped}"
        if acknowledge:
            self.acknowledge_boot(boots[-1])
        return boots[-1]


@pytest.fixture(scope="module")
def board_link(simulated_board: SimulatedBoard) -> Iterator[BoardLink]:
    """A serial connection to the module's board, synchronised past its first boot frame."""
    port = serial.serial_for_url(simulated_board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.05)
    try:
        link = BoardLink(simulated_board, port)
        link.reset()
        yield link
    finally:
        port.close()


@pytest.fixture
def rover(board_link: BoardLink) -> BoardLink:
    """The board freshly powered up (motors off, default lease, no e-stop) for one test."""
    board_link.reset(cause="power-on")
    return board_link


@pytest.fixture(scope="session")
def board_link_type() -> type[BoardLink]:
    """:class:`BoardLink` itself, for a module that opens a link to a board of its own (importing
    ``conftest`` by name is ambiguous when several test folders have one)."""
    return BoardLink
