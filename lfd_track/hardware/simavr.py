"""Run the real rover firmware in simavr: build it, start the harness, talk to it over a pty.

The firmware (``hardware/firmware/lfd_rover``) and the C harness (``hardware/sim``) live in the
source checkout, not in the wheel. ``SimulatedBoard`` builds both on first use (``make``, with
Debian's ``gcc-avr``/``arduino-mk`` and ``libsimavr-dev``), starts the harness, and exposes the
pty path for ``serial.serial_for_url`` plus the motor log the harness writes with simulated time::

    with SimulatedBoard() as board:
        link = serial.serial_for_url(board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.1)
        ...
        samples = board.motor_log()  # [MotorSample(t_s, left_pwm, left_dir, ...), ...]
"""

from __future__ import annotations

import fcntl
import os
import selectors
import shutil
import signal
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

FIRMWARE_BAUD = 9600
"""UART baud rate of the firmware (HC-05/06 factory default); the pty itself ignores it."""

HARDWARE_DIR = Path(__file__).resolve().parents[2] / "hardware"
"""``hardware/`` of the source checkout this package was imported from."""

ARDUINO_DIR = Path("/usr/share/arduino")
SIMAVR_INCLUDE = Path("/usr/include/simavr")

_APT_FIRMWARE = "apt-get install gcc-avr avr-libc binutils-avr arduino-core-avr arduino-mk make"
_APT_HARNESS = "apt-get install gcc make simavr libsimavr-dev libsimavrparts1 libelf-dev"


class SimavrError(RuntimeError):
    """The firmware or harness could not be built or started."""


class ToolMissingError(SimavrError):
    """A tool or library needed to build or run the simulated board is not installed."""


class MotorSample(NamedTuple):
    """One line of the harness's motor log: outputs from time ``t_s`` on (simulated seconds)."""

    t_s: float
    left_pwm: int  # duty 0..255 on E1 (D5)
    left_dir: int  # level of M1 (D4); 0 = forward (see hardware/README.md)
    right_pwm: int  # duty 0..255 on E2 (D6)
    right_dir: int  # level of M2 (D7); 0 = forward


def missing_tools() -> list[str]:
    """Messages, one per missing tool or library, naming the package that provides it."""
    missing = []
    if shutil.which("make") is None:
        missing.append("make not found: apt-get install make")
    if shutil.which("avr-gcc") is None:
        missing.append(f"avr-gcc not found: {_APT_FIRMWARE}")
    if not Path("/usr/lib/avr/include/avr/io.h").is_file():
        missing.append(f"avr-libc headers not found: {_APT_FIRMWARE}")
    if not (ARDUINO_DIR / "Arduino.mk").is_file():
        missing.append(f"{ARDUINO_DIR}/Arduino.mk not found: {_APT_FIRMWARE}")
    if not (ARDUINO_DIR / "hardware/arduino/avr/cores/arduino/Arduino.h").is_file():
        missing.append(f"Arduino AVR core not found: {_APT_FIRMWARE}")
    if shutil.which("cc") is None and shutil.which("gcc") is None:
        missing.append(f"gcc not found: {_APT_HARNESS}")
    if not (SIMAVR_INCLUDE / "sim_avr.h").is_file():
        missing.append(f"simavr headers not found: {_APT_HARNESS}")
    if not Path("/usr/include/libelf.h").is_file():
        missing.append(f"libelf headers not found: {_APT_HARNESS}")
    if not HARDWARE_DIR.is_dir():
        missing.append(
            f"{HARDWARE_DIR} not found: the firmware sources ship with the source checkout only"
        )
    return missing


@contextmanager
def _build_lock(out_dir: Path) -> Iterator[None]:
    # Parallel test workers may build into the same directory; make is not safe against that.
    out_dir.mkdir(parents=True, exist_ok=True)
    with open(out_dir / ".build.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(lock, fcntl.LOCK_UN)


def _run_make(what: str, source_dir: Path, *make_args: str) -> None:
    try:
        result = subprocess.run(
            ["make", "-C", str(source_dir), *make_args],
            capture_output=True,
            text=True,
            check=False,
        )
    except FileNotFoundError as exc:
        raise ToolMissingError("make not found: apt-get install make") from exc
    if result.returncode != 0:
        tail = "\n".join((result.stdout + result.stderr).strip().splitlines()[-15:])
        raise SimavrError(f"building the {what} failed (make -C {source_dir}):\n{tail}")


def _require_tools() -> None:
    missing = missing_tools()
    if missing:
        raise ToolMissingError("; ".join(missing))


def build_firmware(out_dir: str | os.PathLike[str]) -> Path:
    """Build the firmware with arduino-mk into ``out_dir``; return the ELF path."""
    _require_tools()
    out = Path(out_dir).resolve()
    with _build_lock(out):
        _run_make("firmware", HARDWARE_DIR / "firmware" / "lfd_rover", f"OBJDIR={out}")
    elf = out / "lfd_rover.elf"
    if not elf.is_file():
        raise SimavrError(f"building the firmware did not produce {elf}")
    return elf


def build_harness(out_dir: str | os.PathLike[str]) -> Path:
    """Build the simavr harness into ``out_dir``; return the executable path."""
    _require_tools()
    out = Path(out_dir).resolve()
    with _build_lock(out):
        _run_make("simavr harness", HARDWARE_DIR / "sim", f"OUT_DIR={out}")
    exe = out / "lfd_rover_sim"
    if not exe.is_file():
        raise SimavrError(f"building the harness did not produce {exe}")
    return exe


def parse_motor_log(text: str, since_reset: bool = False) -> list[MotorSample]:
    """Parse the harness's motor log (header, ``#`` comments and a torn last line skipped).

    With ``since_reset``, only the samples after the latest board reset are returned, led by
    an all-off sample at the reset time (a reset clears every output register).
    """
    samples: list[MotorSample] = []
    lines = text.split("\n")
    for line in lines[:-1]:  # the last element is "" or a line still being written
        if line.startswith("# reset ") and since_reset:
            samples = [MotorSample(int(line.split()[2]) * 1e-6, 0, 0, 0, 0)]
        if not line or line.startswith("#") or line.startswith("t_us"):
            continue
        t_us, left_pwm, left_dir, right_pwm, right_dir = (int(v) for v in line.split(","))
        samples.append(MotorSample(t_us * 1e-6, left_pwm, left_dir, right_pwm, right_dir))
    return samples


class SimulatedBoard:
    """The rover firmware running in simavr, reachable at ``serial_url``; a context manager.

    Arguments:
        build_dir: where firmware and harness are built (default ``hardware/build``).
        start_timeout_s: how long to wait for the harness to announce its pty.
        keep_files: leave the run folder (motor log, harness stderr) in place on ``close()``;
            by default it is removed.
    """

    def __init__(
        self,
        build_dir: str | os.PathLike[str] | None = None,
        start_timeout_s: float = 30.0,
        keep_files: bool = False,
    ) -> None:
        self._build_dir = Path(build_dir) if build_dir is not None else HARDWARE_DIR / "build"
        self._start_timeout_s = start_timeout_s
        self._keep_files = keep_files
        self._proc: subprocess.Popen[bytes] | None = None
        self._run_dir: Path | None = None
        self._serial_url: str | None = None
        self._exit_code: int | None = None

    @property
    def exit_code(self) -> int | None:
        """The harness's exit status once closed (0 = clean stop), else None."""
        return self._exit_code

    @property
    def serial_url(self) -> str:
        """Path of the pty bridged to the firmware's UART (for ``serial.serial_for_url``)."""
        if self._serial_url is None:
            raise SimavrError("the simulated board is not running (use it as a context manager)")
        return self._serial_url

    @property
    def run_dir(self) -> Path:
        """Folder of this run's files (``lfd-rover-sim-*`` in the temporary directory)."""
        if self._run_dir is None:
            raise SimavrError("the simulated board is not running (use it as a context manager)")
        return self._run_dir

    @property
    def log_path(self) -> Path:
        """Motor log file written by the harness."""
        return self.run_dir / "motors.csv"

    def start(self) -> SimulatedBoard:
        """Build if needed, start the harness and wait until its pty exists."""
        if self._proc is not None:
            return self
        elf = build_firmware(self._build_dir / "firmware")
        exe = build_harness(self._build_dir / "sim")
        self._run_dir = Path(tempfile.mkdtemp(prefix="lfd-rover-sim-"))
        stderr_path = self._run_dir / "harness.stderr"
        try:
            with open(stderr_path, "wb") as stderr:
                self._proc = subprocess.Popen(
                    [str(exe), "--log", str(self.log_path), str(elf)],
                    stdin=subprocess.DEVNULL,
                    stdout=subprocess.PIPE,
                    stderr=stderr,
                )
            self._serial_url = self._read_pty_line(stderr_path)
        except BaseException:
            self.close()
            raise
        return self

    def _read_pty_line(self, stderr_path: Path) -> str:
        assert self._proc is not None and self._proc.stdout is not None
        deadline = time.monotonic() + self._start_timeout_s
        received = b""
        with selectors.DefaultSelector() as selector:
            selector.register(self._proc.stdout, selectors.EVENT_READ)
            while b"\n" not in received:
                remaining = deadline - time.monotonic()
                if remaining <= 0 or not selector.select(remaining):
                    raise SimavrError(
                        f"the simavr harness did not announce its pty within "
                        f"{self._start_timeout_s} s; its stderr: {stderr_path.read_text()!r}"
                    )
                chunk = os.read(self._proc.stdout.fileno(), 256)
                if not chunk:
                    raise SimavrError(
                        f"the simavr harness exited ({self._proc.wait()}) before announcing its "
                        f"pty; its stderr: {stderr_path.read_text()!r}"
                    )
                received += chunk
        line = received.split(b"\n", 1)[0].decode("ascii", "replace")
        if not line.startswith("PTY "):
            raise SimavrError(f"unexpected first line from the simavr harness: {line!r}")
        return line[len("PTY ") :]

    def reset(self, timeout_s: float = 5.0) -> None:
        """Reset the simulated board, as its reset button would, and return once it has happened.

        The firmware then boots again (motors off, boot frame sent). Host bytes written after
        this returns are not lost to the reboot: the harness holds host input back for 2 ms of
        simulated time after a reset, until the firmware's UART is listening.
        """
        if self._proc is None or self._proc.poll() is not None:
            raise SimavrError("the simulated board is not running")
        resets_before = self._count_resets()
        self._proc.send_signal(signal.SIGUSR1)
        deadline = time.monotonic() + timeout_s
        while self._count_resets() == resets_before:
            if time.monotonic() > deadline or self._proc.poll() is not None:
                raise SimavrError(f"the simulated board did not reset within {timeout_s} s")
            time.sleep(0.001)  # polling the log file, which has no change notification

    def _count_resets(self) -> int:
        return self.log_path.read_text().count("\n# reset ")

    def motor_log(self, since_reset: bool = False) -> list[MotorSample]:
        """Motor-output changes so far, oldest first, with simulated time in seconds.

        With ``since_reset``, only those after the latest ``reset()`` (see ``parse_motor_log``).
        """
        return parse_motor_log(self.log_path.read_text(), since_reset)

    def close(self) -> None:
        """Stop the harness (SIGTERM, then SIGKILL after 5 s) and remove its files.

        The run folder stays if the board was made with ``keep_files=True``.
        """
        proc, self._proc = self._proc, None
        if proc is not None:
            if proc.poll() is None:
                proc.terminate()
                try:
                    proc.wait(timeout=5.0)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()
            self._exit_code = proc.returncode
            if proc.stdout is not None:
                proc.stdout.close()
        self._serial_url = None
        run_dir, self._run_dir = self._run_dir, None
        if run_dir is not None and not self._keep_files:
            shutil.rmtree(run_dir, ignore_errors=True)

    def __enter__(self) -> SimulatedBoard:
        return self.start()

    def __exit__(self, *exc_info: object) -> None:
        self.close()
