"""The firmware under load and across resets, in simavr: floods, the e-stop latch, the harness.

Every flood here is written in one go, faster than 9600 baud can carry it, so the board's input
is busy for the whole flood while its replies back up. Timing is read from simulated time (the
harness's motor log and marks), never from the host's clock, except where the claim is about
the host's clock: the harness must not let simulated time run ahead of it.
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

import numpy as np
import pytest
import serial
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lfd_track.hardware import wire
from lfd_track.hardware.simavr import FIRMWARE_BAUD, SimulatedBoard

if TYPE_CHECKING:
    from conftest import BoardLink  # the fixture's type, defined in tests/hardware/conftest.py

pytestmark = pytest.mark.simavr

DUTY = 200
LEASE_S = 0.300
# The bound for the lease under load; millis() ticks in 1.024 ms steps.
LEASE_TOLERANCE_S = 0.010
FLOOD_FRAMES = 60
# Failure guard only: the waits below return as soon as the awaited reply arrives.
SETTLE_TIMEOUT_S = 10.0
HARNESS_SLICE_S = 200e-6  # hardware/sim/lfd_rover_sim.c: SLICE_US
HARNESS_MAX_LAG_S = 0.020  # hardware/sim/lfd_rover_sim.c: MAX_LAG_NS (a larger debt is forgiven)


def moving(sample) -> bool:
    return sample.left_pwm > 0 or sample.right_pwm > 0


def watchdog_resets(board: SimulatedBoard, since: int) -> list:
    return [r for r in board.resets()[since:] if r.cause == "watchdog"]


class Stream:
    """Everything the board sends, decoded: frames in order, and any malformed line."""

    def __init__(self, rover: BoardLink) -> None:
        self.rover = rover
        self.parser = wire.FrameParser()
        self.frames: list[wire.Frame] = []
        self.errors: list[wire.FrameError] = []

    def pump(self) -> None:
        port = self.rover.port
        for item in self.parser.feed(port.read(port.in_waiting or 1)):
            (self.frames if isinstance(item, wire.Frame) else self.errors).append(item)

    def settle(self) -> wire.Frame:
        """Ping until a ping is answered, i.e. until the board has worked through its input.

        A reply that does not fit the board's transmit buffer is dropped, so one ping may go
        unanswered while the flood's replies drain; the next one is then answered.
        """
        deadline = time.monotonic() + SETTLE_TIMEOUT_S
        while time.monotonic() < deadline:
            seq = self.rover.send(wire.PING)
            ping_deadline = min(deadline, time.monotonic() + 1.0)
            while time.monotonic() < ping_deadline:
                self.pump()
                for frame in self.frames:
                    if frame.type == wire.ACK and frame.seq == seq:
                        return frame
        raise AssertionError(f"the board answered no ping within {SETTLE_TIMEOUT_S} s")


def _frames(frame_type: str, seqs: list[int], *args: str) -> bytes:
    return b"".join(wire.encode_frame(frame_type, seq, *args) for seq in seqs)


def _bad_crc(seqs: list[int]) -> bytes:
    out = b""
    for seq in seqs:
        frame = wire.encode_frame(wire.DRIVE, seq, "F")
        out += frame[:-5] + b"%04X" % (int(frame[-5:-1], 16) ^ 0x5A5A) + b"\n"
    return out


FLOODS = {
    "drive": lambda seqs: _frames(wire.DRIVE, seqs, "F"),
    "ping": lambda seqs: _frames(wire.PING, seqs),
    "estop-clear": lambda seqs: b"".join(
        wire.encode_frame(wire.ESTOP if i % 2 == 0 else wire.CLEAR, seq)
        for i, seq in enumerate(seqs)
    ),
    "lease": lambda seqs: _frames(wire.SET_WATCHDOG, seqs, "2000"),
    "version": lambda seqs: _frames("V", seqs),
    "bad-crc": _bad_crc,
    "unknown-type": lambda seqs: _frames("Q", seqs),
    "too-long": lambda seqs: b"".join(b"$H,%d," % seq + b"9" * 25 + b"*0000\n" for seq in seqs),
    "dollars": lambda seqs: b"$" * (14 * len(seqs)),
    "newlines": lambda seqs: b"$\n" * (7 * len(seqs)),
}


@pytest.mark.parametrize("kind", sorted(FLOODS))
def test_no_flood_causes_a_watchdog_reset(rover: BoardLink, kind: str) -> None:
    assert_ack_state(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    resets = len(rover.board.resets())
    stream = Stream(rover)
    rover.write(FLOODS[kind]([rover.next_seq() for _ in range(FLOOD_FRAMES)]))
    stream.settle()
    assert watchdog_resets(rover.board, resets) == []
    assert len(rover.board.resets()) == resets, rover.board.resets()
    # Whatever was dropped under the load, every line the board sent is whole and valid.
    assert stream.errors == []
    assert all(f.type != wire.BOOT for f in stream.frames)


DROPPED = 4  # ack flag: replies were dropped; after a flood it depends on how the host wrote


def assert_ack_state(frame: wire.Frame, state: str, flags: int | None = None) -> None:
    assert frame.type == wire.ACK, f"expected an ack, got {frame}"
    assert frame.args[0] == state, frame
    if flags is not None:
        assert int(frame.args[1]) & ~DROPPED == flags, frame


def test_every_drive_frame_of_a_flood_is_obeyed_and_the_lease_runs_from_the_last(
    rover: BoardLink,
) -> None:
    stream = Stream(rover)
    seqs = [rover.next_seq() for _ in range(FLOOD_FRAMES)]
    # F, L, R, ... back to back: each must reach the motors, in order, acked or not.
    commands = ["FLR"[i % 3] for i in range(FLOOD_FRAMES)]
    rover.write(b"".join(wire.encode_frame("D", s, c) for s, c in zip(seqs, commands, strict=True)))
    deadline = time.monotonic() + SETTLE_TIMEOUT_S
    while stream.settle().args[0] != "S":  # until the lease has run out
        assert time.monotonic() < deadline, "the motors never stopped"
    samples = rover.board.motor_log(since_reset=True)
    states, started = [], []
    for s in samples:
        state = {(DUTY, 0, DUTY, 0): "F", (DUTY, 1, DUTY, 0): "L", (DUTY, 0, DUTY, 1): "R"}.get(
            (s.left_pwm, s.left_dir, s.right_pwm, s.right_dir)
        )
        if state is not None and (not states or states[-1] != state):
            states.append(state)
            started.append(s.t_s)
    assert states == commands
    # The motors stop one lease after the last drive frame took effect.
    last_drive = started[-1]
    stop = next(s.t_s for s in samples if s.t_s >= last_drive and not moving(s))
    assert abs((stop - last_drive) - LEASE_S) <= LEASE_TOLERANCE_S, stop - last_drive
    first = next(s.t_s for s in samples if moving(s))
    assert last_drive - first > LEASE_S  # the flood itself outlasted one lease
    acked = [f for f in stream.frames if f.type == wire.ACK and f.seq in seqs]
    assert acked, "no drive frame of the flood was acknowledged"
    assert stream.errors == []


def test_lease_holds_under_back_to_back_pings(rover: BoardLink) -> None:
    resets = len(rover.board.resets())
    stream = Stream(rover)
    drive_seq = rover.next_seq()
    pings = [rover.next_seq() for _ in range(FLOOD_FRAMES)]  # ~750 ms at 9600 baud
    rover.write(wire.encode_frame(wire.DRIVE, drive_seq, "F") + _frames("H", pings))
    stream.settle()
    samples = rover.board.motor_log(since_reset=True)
    start = next(s.t_s for s in samples if moving(s))
    stop = next(s.t_s for s in samples if s.t_s > start and not moving(s))
    assert abs((stop - start) - LEASE_S) <= LEASE_TOLERANCE_S, stop - start
    assert watchdog_resets(rover.board, resets) == []
    assert any(f.type == wire.WATCHDOG_STOP for f in stream.frames) or any(
        f.type == wire.ACK and int(f.args[1]) & 2 for f in stream.frames
    ), "the lease stop was reported neither as $W nor in an ack's flags"


def motion_span(samples: list) -> tuple[float, float]:
    """When the motors first started, and when they were next fully off."""
    start = next(s.t_s for s in samples if moving(s))
    stop = next(s.t_s for s in samples if s.t_s > start and not moving(s))
    return start, stop


# Floods that must not renew the lease: nothing in them is an accepted drive frame. "lease-300"
# resets the lease period to the one running (a T frame is not a drive frame); "bad-arg" drive
# frames carry a valid CRC and seq but no valid command.
NOT_RENEWING = {
    kind: FLOODS[kind]
    for kind in ("ping", "version", "bad-crc", "unknown-type", "too-long", "dollars", "newlines")
}
NOT_RENEWING["lease-300"] = lambda seqs: _frames(wire.SET_WATCHDOG, seqs, "300")
NOT_RENEWING["bad-arg"] = lambda seqs: _frames(wire.DRIVE, seqs, "Z")
NOT_RENEWING["noise"] = lambda seqs: (
    np.random.default_rng(len(seqs)).integers(0, 256, size=12 * len(seqs), dtype=np.uint8).tobytes()
)


@pytest.mark.parametrize("kind", sorted(NOT_RENEWING))
def test_the_lease_runs_out_on_time_under_a_flood_that_carries_no_drive_frame(
    rover: BoardLink, kind: str
) -> None:
    resets = len(rover.board.resets())
    stream = Stream(rover)
    flood = NOT_RENEWING[kind]([rover.next_seq() for _ in range(FLOOD_FRAMES)])
    assert len(flood) * 10 / FIRMWARE_BAUD > 2 * LEASE_S  # the flood outlasts the lease
    rover.write(wire.encode_frame(wire.DRIVE, rover.next_seq(), "F") + flood + b"\n")
    assert_ack_state(stream.settle(), "S")
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert abs((stop - start) - LEASE_S) <= LEASE_TOLERANCE_S, stop - start
    assert watchdog_resets(rover.board, resets) == []
    assert len(rover.board.resets()) == resets


@pytest.mark.parametrize("before_wrap_ms", [250, 100])
def test_the_lease_runs_out_on_time_across_the_millis_wrap(
    rover: BoardLink, before_wrap_ms: int
) -> None:
    """millis() wraps to 0 after 2^32 ms (49.7 days up); a lease running over it ends on time.

    The drive frame lands a few ms after the clock is set, before the wrap, and its lease ends
    after it. (A check written as ``millis() >= last_drive_ms + lease_ms`` stops at once here.)
    """
    millis = rover.board.symbol_address("timer0_millis")
    rover.board.poke(millis, (2**32 - before_wrap_ms).to_bytes(4, "little"))
    drive_seq = rover.next_seq()
    rover.write(wire.encode_frame(wire.DRIVE, drive_seq, "F"))
    assert_ack_state(rover.reply_to(drive_seq), "F")
    rover.wait_for(lambda f: f.type == wire.WATCHDOG_STOP)
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert abs((stop - start) - LEASE_S) <= LEASE_TOLERANCE_S, stop - start
    assert_ack_state(rover.request(wire.PING), "S", 2)


def test_an_estop_inside_a_drive_flood_latches_and_clearing_does_not_restart(
    rover: BoardLink,
) -> None:
    """D,F at full rate, E, more D,F (longer than a lease), C: the e-stop stops the motors at
    once (its ack may be dropped), every later drive is refused while it is latched, and the C
    starts nothing; only a drive frame sent after it moves again."""
    assert_ack_state(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    since = rover.board.mark()
    stream = Stream(rover)
    seq = rover.next_seq
    before = _frames(wire.DRIVE, [seq() for _ in range(20)], "F")
    estop = wire.encode_frame(wire.ESTOP, seq())
    refused = [seq() for _ in range(FLOOD_FRAMES)]  # ~900 ms at 9600 baud
    clear = wire.encode_frame(wire.CLEAR, seq())
    rover.write(before + estop + _frames(wire.DRIVE, refused, "F") + clear)
    assert_ack_state(stream.settle(), "S", 0)
    samples = [s for s in rover.board.motor_log() if s.t_s >= since]
    start, stop = motion_span(samples)
    assert not any(moving(s) for s in samples if s.t_s >= stop)  # never again, C included
    # The stop came from the E frame, well within the first drive frames' 2 s lease.
    assert stop - start < 0.5
    refusals = [f for f in stream.frames if f.seq in refused]
    assert refusals and all(f.type == wire.NAK for f in refusals), refusals
    assert all(f.args == (wire.REASON_ESTOP,) for f in refusals)
    assert_ack_state(rover.request(wire.DRIVE, "L"), "L")  # an explicit drive moves again


# --- the e-stop latch and resets ----------------------------------------------------------


def expect_boot(rover: BoardLink) -> wire.Frame:
    frame, _ = rover.wait_for(lambda f: f.type == wire.BOOT)
    return frame


def drive_is_refused_and_motors_never_move(rover: BoardLink, since: float) -> None:
    for command in "FLR":
        reply = rover.request(wire.DRIVE, command)
        assert reply.type == wire.NAK and reply.args == (wire.REASON_ESTOP,), reply
    moved = [s for s in rover.board.motor_log() if s.t_s >= since and moving(s)]
    assert moved == []


def test_estop_then_a_flood_then_drive_is_refused(rover: BoardLink) -> None:
    """The issue's reproduction: E, 60 back-to-back pings, then D,F must not move."""
    assert_ack_state(rover.request(wire.ESTOP), "X", 1)
    since = rover.board.mark()
    stream = Stream(rover)
    rover.write(_frames(wire.PING, [rover.next_seq() for _ in range(FLOOD_FRAMES)]))
    assert_ack_state(stream.settle(), "X", 1)
    drive_is_refused_and_motors_never_move(rover, since)


@pytest.mark.parametrize("latched", [True, False])
def test_a_watchdog_reset_boots_latched_and_says_why(rover: BoardLink, latched: bool) -> None:
    assert_ack_state(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    if latched:
        assert_ack_state(rover.request(wire.ESTOP), "X", 1)
    else:
        assert_ack_state(rover.request(wire.DRIVE, "F"), "F")  # hangs while driving
    reset = rover.board.hang()
    assert reset.cause == "watchdog"
    boot = expect_boot(rover)
    assert boot.args[1:3] == ("WDT", "1"), boot
    # The watchdog stopped a hung board; whoever drove it must look before it moves again.
    assert_ack_state(rover.request(wire.PING), "X", 1)
    drive_is_refused_and_motors_never_move(rover, reset.t_s)
    assert_ack_state(rover.request(wire.CLEAR), "S", 0)
    assert rover.request(wire.DRIVE, "F").args == (wire.REASON_BOOT,)  # no hello yet
    assert_ack_state(rover.acknowledge_boot(boot), "S", 0)
    assert_ack_state(rover.request(wire.DRIVE, "F"), "F")


def test_a_brown_out_reset_boots_latched(rover: BoardLink) -> None:
    rover.board.reset(cause="brown-out")
    assert expect_boot(rover).args[1:3] == ("BOD", "1")
    drive_is_refused_and_motors_never_move(rover, rover.board.resets()[-1].t_s)


@pytest.mark.parametrize("latched", [True, False])
def test_an_external_reset_keeps_the_latch_as_it_was(rover: BoardLink, latched: bool) -> None:
    if latched:
        assert_ack_state(rover.request(wire.ESTOP), "X", 1)
    rover.board.reset(cause="external")
    boot = expect_boot(rover)
    assert boot.args[1:3] == ("EXT", "1" if latched else "0")
    if latched:
        drive_is_refused_and_motors_never_move(rover, rover.board.resets()[-1].t_s)
    else:
        assert rover.request(wire.DRIVE, "F").args == (wire.REASON_BOOT,)
        assert_ack_state(rover.acknowledge_boot(boot), "S", 0)
        assert_ack_state(rover.request(wire.DRIVE, "F"), "F")


def test_only_power_on_clears_the_latch(rover: BoardLink) -> None:
    assert_ack_state(rover.request(wire.ESTOP), "X", 1)
    for cause in ("external", "brown-out", "external"):
        rover.board.reset(cause=cause)
        assert expect_boot(rover).args[2] == "1", cause
    rover.board.hang()
    assert expect_boot(rover).args[1:3] == ("WDT", "1")
    rover.board.reset(cause="power-on")
    boot = expect_boot(rover)
    assert boot.args[1:3] == ("PWR", "0")
    assert_ack_state(rover.acknowledge_boot(boot), "S", 0)
    assert_ack_state(rover.request(wire.DRIVE, "F"), "F")


def test_without_reset_flags_the_latch_stays_as_it_was_and_power_up_noise_never_latches(
    rover: BoardLink,
) -> None:
    """A bootloader may clear MCUSR first; then only the firmware's RAM record tells."""
    assert_ack_state(rover.request(wire.ESTOP), "X", 1)
    rover.board.reset(cause="external", flags_cleared=True)
    assert expect_boot(rover).args[1:3] == ("?", "1")
    assert rover.board.resets()[-1].cause == "unknown"
    # A power-up leaves random RAM; it must never read as a latched e-stop.
    for _ in range(5):
        rover.board.reset(cause="power-on", flags_cleared=True)
        assert expect_boot(rover).args[1:3] == ("?", "0")
    rover.board.reset(cause="external", flags_cleared=True)  # the record is now "clear"
    assert expect_boot(rover).args[1:3] == ("?", "0")


def test_a_hung_board_is_reset_by_the_watchdog_within_its_period(rover: BoardLink) -> None:
    reset = rover.board.hang()
    assert reset.cause == "watchdog"
    # The firmware arms a 250 ms watchdog (WDTO_250MS: 32768 cycles of the 128 kHz watchdog
    # oscillator, 256 ms; simavr's is exact, a real one is not) and kicks it every loop pass,
    # so the reset comes within one period of the hang (plus one 200 us harness slice).
    hung_at = rover.board.hangs()[-1]
    assert 0 < reset.t_s - hung_at <= 0.256 + 0.001
    # After the reset the board runs (the watchdog was disabled early, then re-armed).
    expect_boot(rover)
    assert_ack_state(rover.request(wire.PING), "X", 1)
    resets = len(rover.board.resets())
    assert_ack_state(rover.request(wire.CLEAR), "S", 0)
    for _ in range(3):
        assert_ack_state(rover.request(wire.PING), "S", 0)
    assert len(rover.board.resets()) == resets  # no reset loop at the 16 ms watchdog timeout


# --- version query ---------------------------------------------------------------------------


def test_version_query_names_version_and_reset_cause(rover: BoardLink) -> None:
    reply = rover.request("V")
    assert reply.type == wire.ACK and len(reply.args) == 5, reply
    state, flags, version, cause, count = reply.args
    assert (state, flags, cause) == ("S", "0", "PWR")
    boot = rover.reset()  # external reset
    assert boot.args[0] == version
    assert rover.request("V").args[2:] == (version, "EXT", boot.args[3])
    assert int(boot.args[3]) == (int(count) + 1) % 65536
    assert rover.request("V", "x").args == (wire.REASON_ARG,)


# --- the harness ------------------------------------------------------------------------------


def test_watchdog_resets_are_written_to_the_motor_log(rover: BoardLink) -> None:
    rover.board.hang()
    text = rover.board.log_path.read_text()
    last = [line for line in text.splitlines() if line.startswith("# reset ")][-1]
    assert last.endswith(" watchdog") and int(last.split()[2]) > 0


def test_simulated_time_never_runs_ahead_of_wall_time_under_a_flood() -> None:
    """More bytes than the harness buffers (4 KiB) at once, read back while they drain."""
    with SimulatedBoard() as board:
        port = serial.serial_for_url(board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.05)
        try:
            parser = wire.FrameParser()
            wall_start = time.monotonic()
            sim_start = board.mark()
            seqs = [i % 65535 + 1 for i in range(500)]  # 500 pings, ~5.5 KiB
            port.write(_frames(wire.PING, seqs))
            replies = 0
            deadline = time.monotonic() + SETTLE_TIMEOUT_S
            while replies < 40 and time.monotonic() < deadline:  # ~0.5 s of simulated time
                replies += sum(
                    isinstance(f, wire.Frame) and f.type == wire.ACK
                    for f in parser.feed(port.read(port.in_waiting or 1))
                )
            sim_end = board.mark()
            wall_end = time.monotonic()
            assert replies >= 40
            # The harness keeps simulated time since its start at or behind the wall clock's:
            # one 200 us slice may run before it sleeps, and a simulation that fell behind (the
            # host was busy) catches up by at most MAX_LAG before the rest of the debt is
            # forgiven. So between two marks simulated time may exceed wall time by that catch-up
            # (seen on a 2-core machine with both cores busy: 1.35 ms), never by more. The
            # host's clock is read before the first mark and after the last one.
            catch_up = HARNESS_MAX_LAG_S + HARNESS_SLICE_S
            assert sim_end - sim_start <= wall_end - wall_start + catch_up
            # The board is not deaf afterwards: the marks keep coming, and simulated time moves.
            assert board.mark() > sim_end
        finally:
            port.close()


# --- random floods ----------------------------------------------------------------------------

flood_bytes = st.lists(
    st.one_of(
        st.binary(min_size=1, max_size=40),
        st.sampled_from([b"$", b"\n", b"\r", b"*", b",", b"$D,1,F*", b"$H,2*"]),
        st.builds(
            lambda t, s, a: wire.encode_frame(t, s, *a),
            st.sampled_from("DHECTVQ"),
            st.integers(0, 65535),
            st.lists(st.sampled_from(["F", "L", "R", "S", "300", "x"]), max_size=2),
        ),
    ),
    min_size=1,
    max_size=30,
).map(b"".join)


@settings(
    max_examples=25,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture],
)
@given(data=flood_bytes)
def test_random_byte_floods_never_reset_the_board(board_link: BoardLink, data: bytes) -> None:
    resets = len(board_link.board.resets())
    board_link.write(data[:600] + b"\n")
    Stream(board_link).settle()
    assert len(board_link.board.resets()) == resets, board_link.board.resets()[resets:]


def test_random_noise_bursts_from_a_seeded_generator(rover: BoardLink) -> None:
    """Two seconds of line noise (~1,900 bytes), including every byte value."""
    rng = np.random.default_rng(8)
    noise = rng.integers(0, 256, size=1900, dtype=np.uint8).tobytes()
    resets = len(rover.board.resets())
    stream = Stream(rover)
    rover.write(noise + b"\n")
    stream.settle()
    assert len(rover.board.resets()) == resets
    assert stream.errors == []
