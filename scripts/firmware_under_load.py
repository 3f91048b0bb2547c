"""The rover firmware under floods, in simavr: lease stop time and watchdog resets, over runs.

Each run powers the simulated board up, writes one ``D,F`` frame followed by 60 back-to-back
pings in a single write (about 750 ms of 9600 baud line time), waits until the board answers a
ping again, and reads from the harness's motor log (simulated time) how long after the drive
frame the motors stopped, and from its reset lines whether the watchdog reset the board.

Run: ``.venv/bin/python scripts/firmware_under_load.py [--runs 20]`` (about 1 s per run);
prints one line. ``tests/hardware/test_firmware_safety.py`` checks the same bound in one run.
"""

from __future__ import annotations

import argparse
import time

import serial

from lfd_track.hardware import wire
from lfd_track.hardware.simavr import FIRMWARE_BAUD, SimulatedBoard

PINGS = 60


def _answered_ping(port: serial.SerialBase, parser: wire.FrameParser, seq: int) -> None:
    """Ping until one is answered (replies the board could not queue are dropped)."""
    for attempt in range(20):
        port.write(wire.encode_frame(wire.PING, seq + attempt))
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            for item in parser.feed(port.read(port.in_waiting or 1)):
                if isinstance(item, wire.Frame) and item.seq == seq + attempt:
                    return
    raise RuntimeError("the simulated board answered no ping")


def _acknowledged_boot(port: serial.SerialBase, parser: wire.FrameParser, seq: int) -> None:
    """Ask the fresh board its boot count (``V``) and answer it with the hello, so it drives."""
    for attempt in range(20):
        port.write(wire.encode_frame(wire.VERSION, seq + attempt))
        deadline = time.monotonic() + 1.0
        while time.monotonic() < deadline:
            for item in parser.feed(port.read(port.in_waiting or 1)):
                if isinstance(item, wire.Frame) and item.seq == seq + attempt:
                    count = item.args[-1] if len(item.args) > 1 else "0"
                    port.write(wire.encode_frame(wire.HELLO, seq + 100, count))
                    _answered_ping(port, parser, seq + 200)
                    return
    raise RuntimeError("the simulated board answered no version query")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=20)
    args = parser.parse_args()
    spans_ms: list[float] = []
    watchdog_resets = 0
    started = time.monotonic()
    with SimulatedBoard() as board:
        port = serial.serial_for_url(board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.05)
        frames = wire.FrameParser()
        try:
            for _ in range(args.runs):
                board.reset(cause="power-on")
                _answered_ping(port, frames, 60000)
                _acknowledged_boot(port, frames, 62000)
                resets = len(board.resets())
                flood = b"".join(wire.encode_frame(wire.PING, 2 + i) for i in range(PINGS))
                port.write(wire.encode_frame(wire.DRIVE, 1, "F") + flood)
                _answered_ping(port, frames, 61000)
                watchdog_resets += sum(r.cause == "watchdog" for r in board.resets()[resets:])
                samples = board.motor_log(since_reset=True)
                start = next(s.t_s for s in samples if s.left_pwm or s.right_pwm)
                stop = next(
                    s.t_s for s in samples if s.t_s > start and not (s.left_pwm or s.right_pwm)
                )
                spans_ms.append((stop - start) * 1000.0)
        finally:
            port.close()
    print(
        f"{args.runs} runs, D,F + {PINGS} back-to-back pings: motors stopped "
        f"{min(spans_ms):.1f}-{max(spans_ms):.1f} ms (simulated) after the drive frame; "
        f"{watchdog_resets} watchdog resets; {time.monotonic() - started:.1f} s wall"
    )


if __name__ == "__main__":
    main()
