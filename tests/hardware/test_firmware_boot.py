"""A board that has just booted does not move until the host has answered its boot, in simavr.

The attack: the host drives, the board resets (any cause), and the host, not having read the
boot frame yet, re-sends its last drive frame, as the link's keep-alive does. The board must
refuse every drive but stop until a hello frame (``K``) names the boot count of its boot frame,
and ``RobotLink`` sends that hello only inside a new application drive request or ``connect()``,
never from its keep-alive thread. Also here: the reset cause and the e-stop latch read the way
the Optiboot bootloader hands them over (flags in r2, MCUSR cleared), a line whose newline never
comes, and a lease change in the middle of a lease.

Timing is read from simulated time (the harness's motor log and marks).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from typing import TYPE_CHECKING

import pytest
import serial

from lfd_track.hardware import wire
from lfd_track.hardware.link import RobotLink
from lfd_track.hardware.simavr import FIRMWARE_BAUD, SimulatedBoard

if TYPE_CHECKING:
    from conftest import BoardLink  # the fixture's type, defined in tests/hardware/conftest.py

pytestmark = pytest.mark.simavr

LEASE_S = 0.300
LEASE_TOLERANCE_S = 0.010  # millis() ticks in 1.024 ms steps
WAIT_S = 10.0  # failure guard only: every wait returns as soon as what it waits for happened

# Every reset the harness can make: (reset() cause or "watchdog", flags cleared by a bootloader).
RESETS = [
    ("external", False),
    ("power-on", False),
    ("brown-out", False),
    ("watchdog", False),
    ("external", True),
    ("power-on", True),
    ("brown-out", True),
]
RESET_IDS = [f"{cause}{'-flags-cleared' if cleared else ''}" for cause, cleared in RESETS]
LATCHING = {"brown-out", "watchdog"}  # boot latched (when the cause is known)


def moving(sample) -> bool:
    return sample.left_pwm > 0 or sample.right_pwm > 0


def moved_since(board: SimulatedBoard, t_s: float) -> list:
    return [s for s in board.motor_log() if s.t_s >= t_s and moving(s)]


def wait_sim_time(board: SimulatedBoard, until_s: float) -> None:
    """Poll the board's clock until simulated time has reached ``until_s``."""
    deadline = time.monotonic() + WAIT_S + until_s - board.mark()
    while board.mark() < until_s:
        assert time.monotonic() < deadline, "simulated time stood still"
        time.sleep(0.005)  # polling the board's clock, which has no change notification


def reset_board(board: SimulatedBoard, cause: str, cleared: bool) -> float:
    """Reset the board; the simulated time of the reset."""
    if cause == "watchdog":
        return board.hang().t_s  # the firmware hangs; its hardware watchdog resets the board
    board.reset(cause=cause, flags_cleared=cleared)
    return board.resets()[-1].t_s


@pytest.fixture(scope="module")
def optiboot_board(simulated_board: SimulatedBoard) -> Iterator[SimulatedBoard]:
    """A board whose bootloader hands the reset flags over in r2 and clears MCUSR (Optiboot).

    (``simulated_board`` only for its check of the tools, which fails under CI.)
    """
    with SimulatedBoard(optiboot=True) as board:
        yield board


@pytest.fixture(scope="module")
def optiboot_link(
    optiboot_board: SimulatedBoard, board_link_type: type[BoardLink]
) -> Iterator[BoardLink]:
    port = serial.serial_for_url(optiboot_board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.05)
    try:
        yield board_link_type(optiboot_board, port)
    finally:
        port.close()


@pytest.fixture
def optiboot_rover(optiboot_link: BoardLink) -> BoardLink:
    """The Optiboot board freshly powered up, its boot answered."""
    optiboot_link.reset(cause="power-on")
    return optiboot_link


@pytest.fixture(scope="module")
def link_board(simulated_board: SimulatedBoard) -> Iterator[SimulatedBoard]:
    """A board of its own for RobotLink, which must be the only reader of its pty."""
    with SimulatedBoard() as board:
        yield board


# --- the link's keep-alive after a reset -------------------------------------------------------


@pytest.mark.parametrize(("cause", "cleared"), RESETS, ids=RESET_IDS)
def test_the_links_keepalive_never_restarts_a_reset_board(
    link_board: SimulatedBoard, cause: str, cleared: bool
) -> None:
    """Drive forward with no end, reset the board: the keep-alive goes on re-sending D,F until it
    reads the boot frame or a refusal, and the fresh board must not move for any of it. Only a
    new drive request moves it again (after C, if it booted latched)."""
    board = link_board
    board.reset(cause="power-on")
    with RobotLink(board.serial_url, boot_wait_s=0, max_consecutive_failures=6) as link:
        assert link.drive("F").state == "F"
        reset_at = reset_board(board, cause, cleared)
        keepalives_before = link.stats().keepalives
        # Two leases and more: long enough for any stale drive to show in the motor log.
        wait_sim_time(board, reset_at + 3 * LEASE_S)
        assert moved_since(board, reset_at) == []
        assert link.stats().boots >= 1
        assert link.lease_letter() == "S"
        stale = link.stats().keepalives - keepalives_before
        assert stale >= 0
        boot = link.reset_cause
        if link.state == "X":  # booted latched: the host must look, then clear
            assert link.clear_estop().accepted
        again = link.drive("F")  # the application's own new request
        assert again.state == "F", (again, boot)
        assert moved_since(board, reset_at)


def settle(rover: BoardLink) -> list[wire.Frame]:
    """Ping until a ping is answered (the board has worked through its input); the frames
    before that answer. A reply that did not fit the board's transmit buffer is dropped, so a
    ping may go unanswered while a flood's replies drain; the next one is then answered."""
    frames: list[wire.Frame] = []
    deadline = time.monotonic() + WAIT_S
    while time.monotonic() < deadline:
        ping = rover.send(wire.PING)
        ping_deadline = min(deadline, time.monotonic() + 1.0)
        while time.monotonic() < ping_deadline:
            try:
                frame = rover.read_frame(timeout_s=0.05)
            except AssertionError:  # nothing came yet
                continue
            if frame.type == wire.ACK and frame.seq == ping:
                return frames
            frames.append(frame)
    raise AssertionError(f"the board answered no ping within {WAIT_S} s")


RACE_DELAYS_S = [0.0, 0.001, 0.003, 0.010, 0.030, 0.100]


@pytest.mark.parametrize(("cause", "cleared"), RESETS, ids=RESET_IDS)
def test_stale_drive_frames_racing_the_boot_frame_are_refused(
    rover: BoardLink, cause: str, cleared: bool
) -> None:
    """The stale drive frame is written at several delays after the reset, before the host has
    read anything (the boot frame included); a replayed hello from the previous boot and a
    flood of drive frames after it are refused too. Nothing moves."""
    tried = refused = dropped = 0
    for delay_s in RACE_DELAYS_S:
        reply = rover.request(wire.VERSION)
        old_count = reply.args[4] if len(reply.args) > 4 else "0"  # firmware 1.1: no count
        assert rover.request(wire.DRIVE, "F").args[0] == "F"
        reset_at = reset_board(rover.board, cause, cleared)
        if delay_s:
            time.sleep(delay_s)  # the race itself: how late the stale frame is written
        seqs = [rover.send(wire.DRIVE, "F")]
        seqs.append(rover.send(wire.HELLO, old_count))  # the previous boot's hello
        seqs += [rover.send(wire.DRIVE, "FLR"[i % 3]) for i in range(20)]  # a flood
        # The flood's replies outrun 9600 baud and some are dropped (ack flag 4): ping until
        # a ping is answered, i.e. the board has worked through all of it.
        frames = settle(rover)
        boots = [f for f in frames if f.type == wire.BOOT]
        assert len(boots) == 1, frames
        boot = boots[0]
        replies = {f.seq: f for f in frames if f.seq in seqs}
        tried += len(seqs)
        dropped += len(seqs) - len(replies)
        reasons = (wire.REASON_BOOT, wire.REASON_ESTOP)
        refused += sum(f.type == wire.NAK and f.args[0] in reasons for f in replies.values())
        assert all(f.type == wire.NAK for f in replies.values()), (delay_s, boot, replies)
        assert replies.get(seqs[0]) is not None  # the first stale frame's reply always fits
        assert moved_since(rover.board, reset_at) == [], (delay_s, boot, replies)
        assert boot.args[3] != old_count
        if boot.args[2] == "1":
            assert rover.request(wire.CLEAR).type == wire.ACK
        assert rover.acknowledge_boot(boot).type == wire.ACK
    print(
        f"{cause}{' flags cleared' if cleared else ''}: {tried} stale frames tried, "
        f"{refused} refused, {dropped} replies dropped, 0 moved"
    )
    assert refused + dropped == tried


def test_a_stop_is_obeyed_and_a_hello_for_another_boot_is_refused(rover: BoardLink) -> None:
    boot = rover.reset(acknowledge=False)
    assert rover.request(wire.DRIVE, "S").args[0] == "S"  # stopping needs no hello
    refused = rover.request(wire.DRIVE, "F")
    assert (refused.type, refused.args) == (wire.NAK, (wire.REASON_BOOT,))
    wrong = str((int(boot.args[3]) + 1) % 65536)
    assert rover.request(wire.HELLO, wrong).args == (wire.REASON_BOOT,)
    assert rover.request(wire.HELLO).args == (wire.REASON_ARG,)
    assert rover.request(wire.HELLO, "x").args == (wire.REASON_ARG,)
    assert rover.request(wire.DRIVE, "L").args == (wire.REASON_BOOT,)
    assert rover.request(wire.VERSION).args[4] == boot.args[3]
    assert rover.acknowledge_boot(boot).args[0] == "S"
    assert rover.acknowledge_boot(boot).args[0] == "S"  # idempotent
    assert rover.request(wire.DRIVE, "L").args[0] == "L"


def test_the_boot_count_survives_resets_and_changes_at_every_boot(rover: BoardLink) -> None:
    counts = [int(rover.reset(cause=cause).args[3]) for cause in ("external",) * 3]
    assert counts[1] == (counts[0] + 1) % 65536 and counts[2] == (counts[1] + 1) % 65536
    rover.board.hang()
    watchdog, _ = rover.wait_for(lambda f: f.type == wire.BOOT)
    assert int(watchdog.args[3]) == (counts[2] + 1) % 65536


# --- Optiboot: reset flags handed over in r2 ----------------------------------------------


def expect_boot(rover: BoardLink) -> wire.Frame:
    frame, _ = rover.wait_for(lambda f: f.type == wire.BOOT)
    return frame


@pytest.mark.parametrize("latched", [True, False])
def test_under_optiboot_a_watchdog_reset_is_named_and_latches(
    optiboot_rover: BoardLink, latched: bool
) -> None:
    rover = optiboot_rover
    assert rover.request(wire.SET_WATCHDOG, "2000").type == wire.ACK
    if latched:
        assert rover.request(wire.ESTOP).args[:2] == ("X", "1")
    else:
        assert rover.request(wire.DRIVE, "F").args[0] == "F"
    reset = rover.board.hang()
    assert reset.cause == "watchdog"
    boot = expect_boot(rover)
    assert boot.args[1:3] == ("WDT", "1"), boot
    assert rover.request(wire.VERSION).args[3] == "WDT"
    for command in "FLR":
        assert rover.request(wire.DRIVE, command).args == (wire.REASON_ESTOP,)
    assert moved_since(rover.board, reset.t_s) == []


@pytest.mark.parametrize("latched", [True, False])
def test_under_optiboot_an_external_reset_keeps_the_latch_and_is_named(
    optiboot_rover: BoardLink, latched: bool
) -> None:
    rover = optiboot_rover
    if latched:
        assert rover.request(wire.ESTOP).args[:2] == ("X", "1")
    boot = rover.reset(cause="external", acknowledge=False)
    assert boot.args[1:3] == ("EXT", "1" if latched else "0"), boot
    reason = wire.REASON_ESTOP if latched else wire.REASON_BOOT
    assert rover.request(wire.DRIVE, "F").args == (reason,)
    assert moved_since(rover.board, rover.board.resets()[-1].t_s) == []


def test_under_optiboot_a_brown_out_latches_and_only_power_on_clears(
    optiboot_rover: BoardLink,
) -> None:
    rover = optiboot_rover
    assert rover.reset(cause="brown-out").args[1:3] == ("BOD", "1")
    for cause in ("external", "external"):
        assert rover.reset(cause=cause).args[1:3] == ("EXT", "1")
    rover.board.hang()
    assert expect_boot(rover).args[1:3] == ("WDT", "1")
    assert rover.reset(cause="power-on").args[1:3] == ("PWR", "0")


@pytest.mark.parametrize("fixture", ["rover", "optiboot_rover"])
@pytest.mark.parametrize("cleared", [False, True])
def test_a_power_on_boots_unlatched_with_motors_off_and_refuses_to_drive(
    request: pytest.FixtureRequest, fixture: str, cleared: bool
) -> None:
    """RAM is garbage after a power-up: it never reads as a latch record (the board boots
    unlatched) nor as an answered boot; every drive until the hello is refused."""
    link = request.getfixturevalue(fixture)
    assert link.request(wire.ESTOP).args[:2] == ("X", "1")
    for _ in range(6):
        link.board.reset(cause="power-on", flags_cleared=cleared)
        reset_at = link.board.resets()[-1].t_s
        boot = expect_boot(link)
        assert boot.args[1:3] == ("?" if cleared else "PWR", "0"), boot
        for command in "FLR":
            assert link.request(wire.DRIVE, command).args == (wire.REASON_BOOT,)
        assert moved_since(link.board, reset_at) == []


# --- a line whose newline never comes --------------------------------------------------------


@pytest.mark.parametrize("gap_s", [0.2, 3.0])
def test_a_drive_frame_completed_after_a_gap_is_discarded(rover: BoardLink, gap_s: float) -> None:
    drive = wire.encode_frame(wire.DRIVE, rover.next_seq(), "F")
    since = rover.board.mark()
    rover.write(drive[:-1])  # everything but the newline
    wait_sim_time(rover.board, since + gap_s)
    rover.write(b"\n")
    ping = rover.send(wire.PING)
    reply, skipped = rover.wait_for(lambda f: f.seq == ping)
    assert skipped == [] and reply.args[0] == "S", (skipped, reply)
    assert moved_since(rover.board, since) == []


def test_a_frame_written_in_two_pieces_without_a_pause_is_obeyed(rover: BoardLink) -> None:
    seq = rover.next_seq()
    drive = wire.encode_frame(wire.DRIVE, seq, "F")
    rover.write(drive[:9])
    rover.write(drive[9:])
    assert rover.reply_to(seq).args[0] == "F"


# --- a lease change applies from the next drive frame ----------------------------------------


def test_a_lease_change_mid_lease_does_not_extend_the_motion_in_progress(
    rover: BoardLink,
) -> None:
    seq = rover.send(wire.DRIVE, "F")
    assert rover.reply_to(seq).args[0] == "F"
    started = rover.board.mark()
    wait_sim_time(rover.board, started + 0.1)
    assert rover.request(wire.SET_WATCHDOG, "2000").args[0] == "F"
    rover.wait_for(lambda f: f.type == wire.WATCHDOG_STOP)
    samples = rover.board.motor_log(since_reset=True)
    start = next(s.t_s for s in samples if moving(s))
    stop = next(s.t_s for s in samples if s.t_s > start and not moving(s))
    assert abs((stop - start) - LEASE_S) <= LEASE_TOLERANCE_S, stop - start
    # The next drive frame runs on the new lease.
    assert rover.request(wire.DRIVE, "L").args[0] == "L"
    again = rover.board.mark()
    wait_sim_time(rover.board, again + 3 * LEASE_S)
    assert rover.request(wire.PING).args[0] == "L"
    assert rover.request(wire.DRIVE, "S").args[0] == "S"
