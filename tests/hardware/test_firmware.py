"""The real rover firmware, running in simavr, against the wire protocol and its safety rules.

Timing claims are checked on simulated time from the harness's motor log, so a loaded test
machine cannot make them pass or fail.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest

from lfd_track.hardware import simavr, wire
from lfd_track.hardware.simavr import (
    BoardReset,
    MotorSample,
    SimulatedBoard,
    parse_motor_log,
    parse_resets,
)

if TYPE_CHECKING:
    from conftest import BoardLink  # the fixture's type, defined in tests/hardware/conftest.py

pytestmark = pytest.mark.simavr

DUTY = 200  # the firmware's fixed drive duty
FORWARD, BACKWARD = 0, 1  # direction pin levels
# millis() on a 16 MHz Uno ticks in 1.024 ms steps, so a lease can end up to ~1 ms early; the
# late side allows for the main loop and the motor-pin writes.
LEASE_EARLY_S = 0.002
LEASE_LATE_S = 0.005


def outputs(sample: MotorSample) -> tuple[int, int, int, int]:
    return sample.left_pwm, sample.left_dir, sample.right_pwm, sample.right_dir


def moving(sample: MotorSample) -> bool:
    return sample.left_pwm > 0 or sample.right_pwm > 0


def assert_ack(frame: wire.Frame, state: str, flags: int = 0) -> None:
    assert frame.type == wire.ACK, f"expected an ack, got {frame}"
    assert frame.args == (state, str(flags)), f"expected state {state} flags {flags}: {frame}"


def assert_nak(frame: wire.Frame, reason: str) -> None:
    assert frame.type == wire.NAK, f"expected a reject ({reason}), got {frame}"
    assert frame.args == (reason,), f"expected reason {reason}: {frame}"


def motion_span(samples: list[MotorSample]) -> tuple[float, float]:
    """Time the motors first started and the time they were next fully off."""
    start = next(s.t_s for s in samples if moving(s))
    stop = next(s.t_s for s in samples if s.t_s > start and not moving(s))
    return start, stop


def expect_lease_stop(rover: BoardLink) -> None:
    """Wait for the board to report that the lease ran out."""
    frame, skipped = rover.wait_for(lambda f: f.type == wire.WATCHDOG_STOP)
    assert frame.seq == 0 and frame.args == ("S",)
    assert all(f.type == wire.ACK for f in skipped), skipped


# --- 1. drive commands set the motor pins ----------------------------------------------------

DRIVE_OUTPUTS = {
    "F": (DUTY, FORWARD, DUTY, FORWARD),
    "L": (DUTY, BACKWARD, DUTY, FORWARD),  # left tread back, right tread forward
    "R": (DUTY, FORWARD, DUTY, BACKWARD),
}


@pytest.mark.parametrize("command", ["F", "L", "R"])
def test_drive_frame_is_acked_and_sets_motor_pins(rover: BoardLink, command: str) -> None:
    # A long lease keeps a slow test machine from seeing the lease stop instead.
    assert_ack(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    assert_ack(rover.request(wire.DRIVE, command), command)
    assert outputs(rover.board.motor_log(since_reset=True)[-1]) == DRIVE_OUTPUTS[command]


def test_drive_sequence_switches_outputs_and_stop_turns_both_off(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    for command in ["F", "L", "R", "F"]:
        assert_ack(rover.request(wire.DRIVE, command), command)
        assert outputs(rover.board.motor_log(since_reset=True)[-1]) == DRIVE_OUTPUTS[command]
    assert_ack(rover.request(wire.DRIVE, "S"), "S")
    last = rover.board.motor_log(since_reset=True)[-1]
    assert (last.left_pwm, last.right_pwm) == (0, 0)


def test_a_reversing_tread_is_switched_off_before_its_direction_changes(
    rover: BoardLink,
) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    assert_ack(rover.request(wire.DRIVE, "L"), "L")
    samples = rover.board.motor_log(since_reset=True)
    # No logged state may run a tread backward at full duty before its direction pin flips.
    for before, after in zip(samples, samples[1:], strict=False):
        if after.left_dir != before.left_dir:
            assert before.left_pwm == 0 or after.left_pwm == 0, (before, after)


def send_pipelined(rover: BoardLink, frame_type: str, arg: str, count: int) -> list[int]:
    """Write ``count`` frames in one go (no waiting for acks in between); return their seqs."""
    seqs = [rover.next_seq() for _ in range(count)]
    rover.write(b"".join(wire.encode_frame(frame_type, seq, arg) for seq in seqs))
    return seqs


def test_renewed_drive_frames_do_not_glitch_the_outputs(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    count = len(rover.board.motor_log())
    for seq in send_pipelined(rover, wire.DRIVE, "F", 3):
        assert_ack(rover.reply_to(seq), "F")
    assert len(rover.board.motor_log()) == count


# --- 2. malformed input is rejected with the right reason, and the link recovers --------------


def corrupt_crc(frame: bytes) -> bytes:
    crc = int(frame[-5:-1], 16)
    return frame[:-5] + f"{crc ^ 0x0001:04X}".encode() + b"\n"


def with_crc(body: bytes) -> bytes:
    return b"$" + body + b"*" + f"{wire.crc16(body):04X}".encode() + b"\n"


@pytest.mark.parametrize(
    ("line", "reason", "seq"),
    [
        (corrupt_crc(wire.encode_frame("D", 41, "F")), wire.REASON_CRC, 41),
        (b"$D,42,F*12G4\n", wire.REASON_FRAME, 42),  # not hex
        (b"$D,43,F*123\n", wire.REASON_FRAME, 43),  # 3 CRC digits
        (b"$D,44,F\n", wire.REASON_FRAME, 44),  # no CRC at all
        (b"$ju\x01nk\n", wire.REASON_FRAME, 0),
        (with_crc(b"DD,45,F"), wire.REASON_FRAME, 45),  # two-letter type
        (with_crc(b"D,x,F"), wire.REASON_FRAME, 0),  # seq not a number
        (with_crc(b"D,65536,F"), wire.REASON_FRAME, 0),  # seq out of range
        (with_crc(b"D,46,\xe9"), wire.REASON_FRAME, 46),  # not ASCII
        (b"$H,47," + b"9" * 40 + b"*0000\n", wire.REASON_LONG, 47),
        (with_crc(b"Q,48"), wire.REASON_TYPE, 48),
        (with_crc(b"D,49,Z"), wire.REASON_ARG, 49),
        (with_crc(b"D,50"), wire.REASON_ARG, 50),
        (with_crc(b"D,51,F,F"), wire.REASON_ARG, 51),
        (with_crc(b"D,52,FF"), wire.REASON_ARG, 52),
        (with_crc(b"H,53,1"), wire.REASON_ARG, 53),
        (with_crc(b"T,54,49"), wire.REASON_ARG, 54),
        (with_crc(b"T,55,2001"), wire.REASON_ARG, 55),
        (with_crc(b"T,56,fast"), wire.REASON_ARG, 56),
    ],
)
def test_bad_frames_are_rejected_and_the_next_frame_is_accepted(
    rover: BoardLink, line: bytes, reason: str, seq: int
) -> None:
    rover.write(line)
    nak = rover.read_frame()
    assert_nak(nak, reason)
    assert nak.seq == seq
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    expected = wire.decode_line(line.rstrip(b"\n"))
    if isinstance(expected, wire.FrameError):  # framing errors: host and board agree
        assert expected.reason == reason


def test_rejected_drive_frames_never_move_the_motors(rover: BoardLink) -> None:
    for line in [
        corrupt_crc(wire.encode_frame("D", 60, "F")),
        with_crc(b"D,61,Z"),
        b"$D,62,F" + b"," * 30 + b"\n",
    ]:
        rover.write(line)
        assert rover.read_frame().type == wire.NAK
    assert not any(moving(s) for s in rover.board.motor_log(since_reset=True))


def test_noise_before_a_frame_is_ignored(rover: BoardLink) -> None:
    seq = rover.next_seq()
    rover.write(b"\x00\xff\r\nnoise*1234,," + wire.encode_frame("D", seq, "L"))
    assert_ack(rover.reply_to(seq), "L")


def test_dollar_resynchronises_a_cut_frame(rover: BoardLink) -> None:
    seq = rover.next_seq()
    rover.write(b"$D,99,F*" + wire.encode_frame("D", seq, "R"))
    assert_ack(rover.reply_to(seq), "R")  # no reply to the cut frame at all


def test_line_length_limit_is_31_bytes_with_an_optional_carriage_return(
    rover: BoardLink,
) -> None:
    body = b"H,70,"
    longest = with_crc(body + b"a" * (wire.MAX_LINE_BYTES - 6 - len(body)))
    assert len(longest) == wire.MAX_LINE_BYTES + 1  # 31 bytes plus the newline
    rover.write(longest)
    assert_nak(rover.read_frame(), wire.REASON_ARG)  # parsed, not cut
    rover.write(longest[:-1] + b"\r\n")
    assert_nak(rover.read_frame(), wire.REASON_ARG)
    too_long = with_crc(body + b"a" * (wire.MAX_LINE_BYTES - 5 - len(body)))
    rover.write(too_long)
    assert_nak(rover.read_frame(), wire.REASON_LONG)
    assert_ack(rover.request(wire.PING), "S")


def test_trailing_carriage_returns_are_ignored(rover: BoardLink) -> None:
    seq = rover.next_seq()
    rover.write(wire.encode_frame("D", seq, "F")[:-1] + b"\r\r\n")
    assert_ack(rover.reply_to(seq), "F")


def test_lower_case_crc_digits_are_accepted(rover: BoardLink) -> None:
    seq = rover.next_seq()
    frame = wire.encode_frame("D", seq, "F")
    rover.write(frame[:-5] + frame[-5:-1].lower() + b"\n")
    assert_ack(rover.reply_to(seq), "F")


def test_random_noise_never_wedges_the_receiver(rover: BoardLink) -> None:
    rng = np.random.default_rng(20240611)
    alphabet = np.frombuffer(b"$*,\r\nDHECT0123456789ABCDEFXYZ\x00\xff", dtype=np.uint8)
    noise = rng.choice(alphabet, size=600).astype(np.uint8).tobytes()
    seq = rover.next_seq()
    rover.write(noise + b"\n" + wire.encode_frame(wire.PING, seq))
    # Every line the board sends stays well-formed (read_frame checks), whatever the noise was;
    # noise that happens to be a valid frame may be acked.
    _, skipped = rover.wait_for(lambda f: f.type == wire.ACK and f.seq == seq)
    assert all(f.type in (wire.ACK, wire.NAK, wire.WATCHDOG_STOP) for f in skipped)


# --- 3. safety: the lease, boot, ping, e-stop, watchdog period --------------------------------


def test_motors_are_off_after_boot_and_a_ping_never_starts_them(rover: BoardLink) -> None:
    # The reset in the fixture already returned the boot frame and one ping's ack.
    for _ in range(3):
        assert_ack(rover.request(wire.PING), "S")
    samples = rover.board.motor_log(since_reset=True)
    assert not any(moving(s) for s in samples), samples


def test_boot_frame_carries_version_reset_cause_and_flags(board_link: BoardLink) -> None:
    boot = board_link.reset(cause="power-on")
    assert boot.seq == 0 and len(boot.args) == 4 and boot.args[0]
    assert boot.args[1:3] == ("PWR", "0")
    assert boot.args[3].isdigit() and int(boot.args[3]) < 65536  # the boot count


def test_motors_stop_when_the_default_lease_runs_out(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    expect_lease_stop(rover)
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert 0.300 - LEASE_EARLY_S <= stop - start <= 0.300 + LEASE_LATE_S
    assert_ack(rover.request(wire.PING), "S", flags=2)  # lease-expired flag
    assert_ack(rover.request(wire.DRIVE, "S"), "S", flags=0)  # cleared by a drive frame


def test_pings_do_not_renew_the_lease(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.DRIVE, "L"), "L")
    # Ping back to back until the stop comes: ~10 round trips at 9600 baud span the lease, so
    # 40 pings (~1.3 s simulated) without a stop mean the pings kept the motors running.
    for _ in range(40):
        seq = rover.send(wire.PING)
        frame, _ = rover.wait_for(lambda f, seq=seq: f.seq == seq or f.type == wire.WATCHDOG_STOP)
        if frame.type == wire.WATCHDOG_STOP:
            break
        assert frame.args[0] == "L"
    else:
        pytest.fail("the motors were still running after 40 pings")
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert 0.300 - LEASE_EARLY_S <= stop - start <= 0.300 + LEASE_LATE_S


def test_drive_frames_renew_the_lease(rover: BoardLink) -> None:
    # Written in one go, so the host's own speed does not matter: the board takes them at the
    # simulated 9600 baud, 25 x (14 frame + 16 ack) bytes at ~1.15 ms/byte, over ~400 ms of
    # simulated time, longer than the 300 ms lease.
    for seq in send_pipelined(rover, wire.DRIVE, "F", 25):
        assert_ack(rover.reply_to(seq), "F")
    expect_lease_stop(rover)
    samples = rover.board.motor_log(since_reset=True)
    start, stop = motion_span(samples)
    assert stop - start > 0.300 + 0.080
    # Motion was continuous: no off state between start and the final stop.
    assert all(moving(s) for s in samples if start <= s.t_s < stop)


def test_set_watchdog_changes_the_lease_period(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "100"), "S")
    assert_ack(rover.request(wire.DRIVE, "R"), "R")
    expect_lease_stop(rover)
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert 0.100 - LEASE_EARLY_S <= stop - start <= 0.100 + LEASE_LATE_S


def test_reset_restores_the_default_lease_period(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "50"), "S")
    rover.reset()
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    expect_lease_stop(rover)
    start, stop = motion_span(rover.board.motor_log(since_reset=True))
    assert stop - start >= 0.300 - LEASE_EARLY_S


def test_estop_latches_refuses_drive_and_clearing_does_not_restart(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "2000"), "S")
    assert_ack(rover.request(wire.DRIVE, "F"), "F")
    assert moving(rover.board.motor_log()[-1])
    assert_ack(rover.request(wire.ESTOP), "X", flags=1)
    stopped_at = len(rover.board.motor_log())
    assert not moving(rover.board.motor_log()[-1])
    for command in ["F", "L", "R", "S"]:
        assert_nak(rover.request(wire.DRIVE, command), wire.REASON_ESTOP)
    assert_ack(rover.request(wire.PING), "X", flags=1)  # still latched
    assert_ack(rover.request(wire.ESTOP), "X", flags=1)  # idempotent
    assert_ack(rover.request(wire.CLEAR), "S", flags=0)
    assert_ack(rover.request(wire.PING), "S", flags=0)
    assert not any(moving(s) for s in rover.board.motor_log()[stopped_at - 1 :])
    assert_ack(rover.request(wire.DRIVE, "F"), "F")  # an explicit drive frame moves again
    assert moving(rover.board.motor_log()[-1])


def test_estop_survives_a_lease_period(rover: BoardLink) -> None:
    assert_ack(rover.request(wire.SET_WATCHDOG, "50"), "S")
    assert_ack(rover.request(wire.ESTOP), "X", flags=1)
    # 3 ping round trips take > 50 ms of simulated time at 9600 baud.
    for _ in range(3):
        assert_ack(rover.request(wire.PING), "X", flags=1)


# --- the harness and the helper --------------------------------------------------------------


def test_harness_stops_cleanly_on_sigterm(simulated_board: SimulatedBoard) -> None:
    # A second board beside the module's one: boards are independent processes and ptys.
    with SimulatedBoard() as board:
        assert board.serial_url != simulated_board.serial_url
        assert board.motor_log()[0] == MotorSample(0.0, 0, 0, 0, 0)
    assert board.exit_code == 0


def test_missing_avr_gcc_is_named_with_its_package(monkeypatch: pytest.MonkeyPatch) -> None:
    real_which = simavr.shutil.which
    monkeypatch.setattr(
        simavr.shutil, "which", lambda name: None if name == "avr-gcc" else real_which(name)
    )
    with pytest.raises(simavr.ToolMissingError, match="avr-gcc not found: apt-get install gcc-avr"):
        simavr.build_firmware(Path("unused"))


@pytest.mark.parametrize(("ci", "outcome"), [("true", "error"), ("", "skipped")])
def test_missing_tools_fail_under_ci_and_skip_otherwise(
    tmp_path: Path, ci: str, outcome: str
) -> None:
    # An empty PATH hides make, avr-gcc and gcc from the fixture's tool check.
    env = {**os.environ, "PATH": str(tmp_path), "CI": ci}
    target = f"{__file__}::test_motors_are_off_after_boot_and_a_ping_never_starts_them"
    result = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", target],
        capture_output=True,
        text=True,
        env=env,
        cwd=Path(__file__).parents[2],
        timeout=120,
    )
    assert f"1 {outcome}" in result.stdout, result.stdout
    assert "avr-gcc not found" in result.stdout
    assert (result.returncode != 0) == (outcome == "error")


def test_builds_go_to_a_per_user_cache_keyed_by_the_sources(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert simavr.cache_dir() == tmp_path / "xdg" / "lfd-track"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")  # ignored, as the XDG spec says
    assert simavr.cache_dir() == Path.home() / ".cache" / "lfd-track"
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert simavr.default_build_dir().parent == tmp_path / "xdg" / "lfd-track"
    # The folder name follows the sources: any change gives a new one.
    copy = tmp_path / "sources"
    for name in simavr.HARDWARE_SOURCES:
        (copy / name).parent.mkdir(parents=True, exist_ok=True)
        (copy / name).write_bytes((simavr.HARDWARE_DIR / name).read_bytes())
    assert simavr.source_digest(copy) == simavr.source_digest()
    ino = copy / simavr.HARDWARE_SOURCES[0]
    ino.write_bytes(ino.read_bytes() + b"\n")
    assert simavr.source_digest(copy) != simavr.source_digest()


def test_staging_rewrites_only_changed_sources(tmp_path: Path) -> None:
    staged = simavr._stage_sources("sim", tmp_path)
    assert sorted(p.name for p in staged.iterdir()) == ["Makefile", "lfd_rover_sim.c"]
    source = staged / "lfd_rover_sim.c"
    os.utime(source, (1_000_000, 1_000_000))
    simavr._stage_sources("sim", tmp_path)
    assert source.stat().st_mtime == 1_000_000  # unchanged content: make sees no change
    source.write_text("stale")
    simavr._stage_sources("sim", tmp_path)
    assert source.read_bytes() == (simavr.HARDWARE_DIR / "sim/lfd_rover_sim.c").read_bytes()


# --- the log parser -------------------------------------------------------------------------


def test_parse_motor_log_skips_comments_and_a_torn_last_line() -> None:
    text = (
        "t_us,left_pwm,left_dir,right_pwm,right_dir\n"
        "0,0,0,0,0\n"
        "1500,200,1,200,0\n"
        "# reset 2000\n"
        "2000,0,0,0,0\n"
        "2100,20"
    )
    assert parse_motor_log(text) == [
        MotorSample(0.0, 0, 0, 0, 0),
        MotorSample(0.0015, 200, 1, 200, 0),
        MotorSample(0.002, 0, 0, 0, 0),
    ]
    assert parse_motor_log(text, since_reset=True) == [
        MotorSample(0.002, 0, 0, 0, 0),
        MotorSample(0.002, 0, 0, 0, 0),
    ]


def test_parse_resets_reads_cause_and_time() -> None:
    text = (
        "t_us,left_pwm,left_dir,right_pwm,right_dir\n"
        "0,0,0,0,0\n"
        "# reset 2000\n"  # a harness before causes were logged
        "# reset 250000 watchdog\n"
        "# mark 300000\n"
        "# reset 400000 power-on\n"
        "# reset 5000"
    )
    resets = parse_resets(text)
    assert [r.cause for r in resets] == ["external", "watchdog", "power-on"]
    # Scaled as parse_motor_log scales, so reset and sample times compare exactly.
    assert [r.t_s for r in resets] == [t * 1e-6 for t in (2000, 250000, 400000)]
    assert all(isinstance(r, BoardReset) for r in resets)
