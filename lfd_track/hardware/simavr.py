"""Run the real rover firmware in simavr: build it, start the harness, talk to it over a pty.

The sources of the firmware (``hardware/firmware/lfd_rover``) and of the C harness
(``hardware/sim``) ship inside the package (``lfd_track/_data/hardware`` in a wheel, the
checkout's ``hardware/`` otherwise). ``SimulatedBoard`` copies them into a per-user cache folder
keyed by a hash of their contents (``$XDG_CACHE_HOME/lfd-track`` or ``~/.cache/lfd-track``) and
builds both there on first use (``make``, with Debian's ``gcc-avr``/``arduino-mk`` and
``libsimavr-dev``), so nothing is written next to the installed package. It then starts the
harness and exposes the pty path for ``serial.serial_for_url`` plus the motor log the harness
writes with simulated time::

    with SimulatedBoard() as board:
        link = serial.serial_for_url(board.serial_url, baudrate=FIRMWARE_BAUD, timeout=0.1)
        ...
        samples = board.motor_log()  # [MotorSample(t_s, left_pwm, left_dir, ...), ...]
"""

from __future__ import annotations

import fcntl
import hashlib
import os
import selectors
import shutil
import subprocess
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import NamedTuple

from ..utils.data import data_dir, shipped_dir

FIRMWARE_BAUD = 9600
"""UART baud rate of the firmware (HC-05/06 factory default); the pty itself ignores it."""

HARDWARE_SOURCES = (
    "firmware/lfd_rover/lfd_rover.ino",
    "firmware/lfd_rover/Makefile",
    "sim/lfd_rover_sim.c",
    "sim/Makefile",
)
"""Files, relative to the hardware folder, that the simulated board is built from."""


def _find_hardware_dir() -> Path:
    try:
        return data_dir("hardware", required=HARDWARE_SOURCES)
    except FileNotFoundError:  # missing_tools() names the absent sources and this folder
        return shipped_dir("hardware")


HARDWARE_DIR = _find_hardware_dir()
"""Hardware sources this package uses: ``lfd_track/_data/hardware`` of a wheel, else the source
checkout's ``hardware/`` (the wheel's copy holds only ``HARDWARE_SOURCES``)."""

RESET_CAUSES = ("power-on", "external", "brown-out", "watchdog")
"""Reset causes the harness logs (from the MCU status register after the reset)."""

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


class BoardReset(NamedTuple):
    """One ``# reset`` line of the motor log: when (simulated seconds) and why."""

    t_s: float
    cause: str  # one of RESET_CAUSES, or "unknown" (no flag set in the MCU status register)


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
    absent = [name for name in HARDWARE_SOURCES if not (HARDWARE_DIR / name).is_file()]
    if absent:
        missing.append(
            f"firmware/harness sources {', '.join(absent)} not found in {HARDWARE_DIR}: "
            "reinstall lfd-track"
        )
    return missing


def cache_dir() -> Path:
    """Per-user cache folder: ``$XDG_CACHE_HOME/lfd-track``, else ``~/.cache/lfd-track``."""
    base = os.environ.get("XDG_CACHE_HOME", "")
    root = Path(base) if os.path.isabs(base) else Path.home() / ".cache"
    return root / "lfd-track"


def source_digest(source_dir: str | os.PathLike[str] | None = None) -> str:
    """First 16 hex digits of a SHA-256 over the names and contents of ``HARDWARE_SOURCES``."""
    root = Path(source_dir) if source_dir is not None else HARDWARE_DIR
    digest = hashlib.sha256()
    for name in HARDWARE_SOURCES:
        data = (root / name).read_bytes()
        digest.update(f"{name}\0{len(data)}\0".encode())
        digest.update(data)
    return digest.hexdigest()[:16]


def default_build_dir() -> Path:
    """Where ``SimulatedBoard`` builds by default: ``cache_dir()/simavr-<source_digest()>``."""
    return cache_dir() / f"simavr-{source_digest()}"


def _stage_sources(subdir: str, out: Path) -> Path:
    """Copy ``HARDWARE_DIR/subdir``'s build sources to ``out/src``; return that folder.

    Only files whose contents differ are rewritten, so make's timestamps stay meaningful.
    """
    staged = out / "src"
    staged.mkdir(parents=True, exist_ok=True)
    prefix = subdir.rstrip("/") + "/"
    for name in HARDWARE_SOURCES:
        if not name.startswith(prefix):
            continue
        source, target = HARDWARE_DIR / name, staged / name[len(prefix) :]
        data = source.read_bytes()
        if not target.is_file() or target.read_bytes() != data:
            tmp = target.with_name(target.name + ".tmp")
            tmp.write_bytes(data)
            tmp.replace(target)
    return staged


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
    """Build the firmware with arduino-mk into ``out_dir``; return the ELF path.

    The sources are copied to ``out_dir/src`` first: the package folder is never written to.
    """
    return _build(out_dir, "firmware", "firmware/lfd_rover", "OBJDIR", "lfd_rover.elf")


def build_harness(out_dir: str | os.PathLike[str]) -> Path:
    """Build the simavr harness into ``out_dir``; return the executable path.

    The sources are copied to ``out_dir/src`` first: the package folder is never written to.
    """
    return _build(out_dir, "simavr harness", "sim", "OUT_DIR", "lfd_rover_sim")


def _build(
    out_dir: str | os.PathLike[str], what: str, sources: str, out_variable: str, product: str
) -> Path:
    """Stage the package's ``sources`` folder in ``out_dir`` and run make there with
    ``out_variable`` naming ``out_dir``; the path of the ``product`` it must leave there."""
    _require_tools()
    out = Path(out_dir).resolve()
    with _build_lock(out):
        source = _stage_sources(sources, out)
        _run_make(what, source, f"{out_variable}={out}")
    built = out / product
    if not built.is_file():
        raise SimavrError(f"building the {what} did not produce {built}")
    return built


def parse_resets(text: str) -> list[BoardReset]:
    """The board resets recorded in a motor log, oldest first (a torn last line skipped).

    Lines written by older harnesses name no cause; they are read as ``"external"``.
    """
    resets = []
    for line in text.split("\n")[:-1]:
        if line.startswith("# reset "):
            fields = line.split()
            cause = fields[3] if len(fields) > 3 else "external"
            resets.append(BoardReset(int(fields[2]) * 1e-6, cause))
    return resets


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
        build_dir: where firmware and harness are built (default ``default_build_dir()``, a
            per-user cache folder keyed by the sources' hash).
        start_timeout_s: how long to wait for the harness to announce its pty.
        keep_files: leave the run folder (motor log, harness stderr) in place on ``close()``;
            by default it is removed.
        optiboot: hand the reset flags to the firmware as the Optiboot bootloader does, at every
            boot (watchdog resets included): MCUSR cleared, its old value in register r2.
    """

    def __init__(
        self,
        build_dir: str | os.PathLike[str] | None = None,
        start_timeout_s: float = 30.0,
        keep_files: bool = False,
        optiboot: bool = False,
    ) -> None:
        self._optiboot = optiboot
        self._build_dir = Path(build_dir) if build_dir is not None else None
        self._start_timeout_s = start_timeout_s
        self._keep_files = keep_files
        self._proc: subprocess.Popen[bytes] | None = None
        self._run_dir: Path | None = None
        self._serial_url: str | None = None
        self._exit_code: int | None = None
        self._elf: Path | None = None

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
        _require_tools()
        build_dir = self._build_dir if self._build_dir is not None else default_build_dir()
        elf = build_firmware(build_dir / "firmware")
        exe = build_harness(build_dir / "sim")
        self._elf = elf
        self._run_dir = Path(tempfile.mkdtemp(prefix="lfd-rover-sim-"))
        stderr_path = self._run_dir / "harness.stderr"
        try:
            with open(stderr_path, "wb") as stderr:
                options = ["--optiboot"] if self._optiboot else []
                self._proc = subprocess.Popen(
                    [str(exe), "--log", str(self.log_path), "--control", *options, str(elf)],
                    stdin=subprocess.PIPE,
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

    def reset(
        self, timeout_s: float = 5.0, cause: str = "external", flags_cleared: bool = False
    ) -> None:
        """Reset the simulated board and return once it has happened.

        ``cause``: ``"external"`` (its reset button or pin), ``"power-on"`` (a power cycle: the
        SRAM comes up scrambled) or ``"brown-out"``; the firmware sees it in its MCU status
        register, unless ``flags_cleared``, which leaves that register zero as a bootloader
        that clears it and passes nothing on does (register r2 zeroed too; the log then names
        the cause ``"unknown"``). The firmware then
        boots again (motors off, boot frame sent). Host bytes
        written after this returns are not lost to the reboot: the harness holds host input
        back for 2 ms of simulated time after a reset, until the firmware's UART is listening.
        """
        if cause not in ("external", "power-on", "brown-out"):
            raise ValueError(f"cause must be external, power-on or brown-out, got {cause!r}")
        modifier = " flags-cleared" if flags_cleared else ""
        self._command_and_wait_for_reset(f"reset {cause}{modifier}", timeout_s)

    def hang(self, timeout_s: float = 5.0) -> BoardReset:
        """Freeze the firmware, as a main loop stuck with interrupts off would be; return its reset.

        No instruction runs while the timers do, so an enabled AVR watchdog resets the board;
        the board runs normally from then on. The log marks the start with ``# hang <t_us>``
        (see ``hangs()``). Raises ``SimavrError`` if no reset came within ``timeout_s`` (wall
        seconds), i.e. the watchdog was off: the firmware arms it in ``setup()``, so right
        after a reset wait for the boot frame (or any reply) before calling this.
        """
        return self._command_and_wait_for_reset("hang", timeout_s)

    def mark(self, timeout_s: float = 5.0) -> float:
        """The board's simulated time now, in seconds (written to the log as ``# mark``)."""
        return self._logged_time("mark", "mark", timeout_s)

    def _logged_time(self, command: str, tag: str, timeout_s: float) -> float:
        """Send harness ``command`` and wait for its ``# <tag> t_us`` log line; that time [s]."""
        marker = f"\n# {tag} "
        before = self._log_text().count(marker)
        self._command(command)
        deadline = time.monotonic() + timeout_s
        while True:
            text = self._log_text()
            tail = text[text.rindex(marker) + 1 :] if text.count(marker) > before else ""
            if "\n" in tail:  # a whole line: the simulator's buffered log may end mid-line
                return int(tail.split("\n", 1)[0].split()[2]) * 1e-6
            self._check_alive(deadline, f"write a {tag}")
            time.sleep(0.001)  # polling the log file, which has no change notification

    def symbol_address(self, name: str) -> int:
        """Data-space address of the firmware's RAM variable ``name`` (for ``poke()``).

        Read from the ELF with ``avr-nm`` (binutils-avr); statics of the Arduino core, such as
        ``timer0_millis`` behind ``millis()``, are found too.
        """
        if self._elf is None:
            raise SimavrError("the simulated board is not running (use it as a context manager)")
        try:
            result = subprocess.run(
                ["avr-nm", str(self._elf)], capture_output=True, text=True, check=True
            )
        except FileNotFoundError as exc:
            raise ToolMissingError(f"avr-nm not found: {_APT_FIRMWARE}") from exc
        for line in result.stdout.splitlines():
            fields = line.split()
            if len(fields) == 3 and fields[2] == name and fields[1] in ("b", "B", "d", "D"):
                return int(fields[0], 16) - 0x800000  # the ELF places the data space at 0x800000
        raise SimavrError(f"no RAM variable {name!r} in {self._elf}")

    def poke(self, address: int, data: bytes, timeout_s: float = 5.0) -> float:
        """Write ``data`` (1..16 bytes) into the firmware's RAM at ``address``; return the time.

        The harness writes it between two instructions while interrupts are enabled, so no
        interrupt handler and no interrupts-off read (``millis()``) sees half of it; the
        simulated time of the write is returned. Tests use it to move the ``millis()`` clock
        (``symbol_address("timer0_millis")``) to just before its 32-bit wrap.
        """
        if not 1 <= len(data) <= 16:
            raise ValueError(f"poke writes 1..16 bytes, got {len(data)}")
        command = f"poke {address:x} " + " ".join(f"{b:02x}" for b in data)
        return self._logged_time(command, "poke", timeout_s)

    def hangs(self) -> list[float]:
        """Simulated times [s] at which ``hang()`` froze the firmware, oldest first."""
        lines = self._log_text().split("\n")[:-1]
        return [int(line.split()[2]) * 1e-6 for line in lines if line.startswith("# hang ")]

    def resets(self) -> list[BoardReset]:
        """Every board reset so far (the initial power-up excluded), oldest first."""
        return parse_resets(self._log_text())

    def _command(self, line: str) -> None:
        if self._proc is None or self._proc.poll() is not None or self._proc.stdin is None:
            raise SimavrError("the simulated board is not running")
        try:
            self._proc.stdin.write(line.encode("ascii") + b"\n")
            self._proc.stdin.flush()
        except OSError as exc:
            raise SimavrError(f"the simulated board is not running ({exc})") from None

    def _check_alive(self, deadline: float, what: str) -> None:
        if self._proc is None or self._proc.poll() is not None:
            raise SimavrError(f"the simulated board stopped before it could {what}")
        if time.monotonic() > deadline:
            raise SimavrError(f"the simulated board did not {what} in time")

    def _command_and_wait_for_reset(self, line: str, timeout_s: float) -> BoardReset:
        resets_before = len(self.resets())
        self._command(line)
        deadline = time.monotonic() + timeout_s
        while True:
            resets = self.resets()
            if len(resets) > resets_before:
                return resets[-1]
            self._check_alive(deadline, f"reset ({line})")
            time.sleep(0.001)  # polling the log file, which has no change notification

    def _log_text(self) -> str:
        return self.log_path.read_text()

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
            if proc.stdin is not None:
                try:
                    proc.stdin.close()  # the end of its command input also stops the harness
                except OSError:
                    pass
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
