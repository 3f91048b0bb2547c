"""Keyboard tele-operation of the real robot, recording a demonstration as it drives.

The paper's human used a remote with discrete forward/left/right buttons (§4.2): every press is
one command. Here a key press (``w``/``a``/``d`` or the arrow keys) is one command held for one
control period, then the robot stops (the env runs with ``between_steps="stop"``, so releasing
the key stops the robot at once instead of after a lease); holding a key down repeats it. Space
stops, ``p`` pauses/resumes road-library learning (for moments the safe box is off the felt,
paper §6), ``q`` quits.

Each command is recorded with the road values of the frame it was given on, computed with the
record-time library, in the format of ``lfd_track.dataset`` (one ``.lfdemo`` file).
"""

from __future__ import annotations

import os
import select
import sys
import termios
import tty
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from ..core.commands import Command
from ..policy.map_geometry import MapGeometry, hardware_geometry
from ..policy.memory import MemoryConfig

QUIT = "quit"
STOP = "stop"
TOGGLE_LEARNING = "toggle_learning"

KEYMAP: Mapping[str, Command | str] = {
    "w": Command.FORWARD,
    "\x1b[A": Command.FORWARD,  # up arrow
    "a": Command.LEFT,
    "\x1b[D": Command.LEFT,  # left arrow
    "d": Command.RIGHT,
    "\x1b[C": Command.RIGHT,  # right arrow
    " ": STOP,
    "s": STOP,
    "p": TOGGLE_LEARNING,
    "q": QUIT,
    "\x03": QUIT,  # Ctrl-C arrives as a byte in cbreak mode only if ISIG is off; kept for safety
}

LIBRARY_ONLY_COMMANDS = (
    10  # first commands only build the library (as in lfd_track/demo/demonstrator.py)
)


class KeySource(Protocol):
    """Anything that yields key presses: ``poll(timeout_s)`` → the latest key or None."""

    def poll(self, timeout_s: float) -> str | None: ...


class TerminalKeys:
    """Key presses from the controlling terminal in cbreak mode (a context manager).

    ``poll`` returns the *latest* key pressed since the last call (auto-repeat queues many while
    a command runs; only the newest one reflects what the operator wants now).
    """

    def __init__(self, stream: Any = None) -> None:
        self._stream = stream if stream is not None else sys.stdin
        self._saved: list[Any] | None = None

    def __enter__(self) -> TerminalKeys:
        fd = self._stream.fileno()
        if not os.isatty(fd):
            raise OSError("keyboard tele-operation needs an interactive terminal")
        self._saved = termios.tcgetattr(fd)
        tty.setcbreak(fd)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._saved is not None:
            termios.tcsetattr(self._stream.fileno(), termios.TCSADRAIN, self._saved)
            self._saved = None

    def poll(self, timeout_s: float) -> str | None:
        fd = self._stream.fileno()
        ready, _, _ = select.select([fd], [], [], max(timeout_s, 0.0))
        if not ready:
            return None
        data = b""
        while select.select([fd], [], [], 0)[0]:
            chunk = os.read(fd, 64)
            if not chunk:
                break
            data += chunk
        return _last_key(data.decode("utf-8", "replace"))


def _last_key(text: str) -> str | None:
    """The last complete key in ``text`` (arrow keys are 3-character escape sequences)."""
    keys: list[str] = []
    i = 0
    while i < len(text):
        if text[i] == "\x1b" and text[i + 1 : i + 2] == "[" and i + 2 < len(text):
            keys.append(text[i : i + 3])
            i += 3
        else:
            keys.append(text[i].lower())
            i += 1
    return keys[-1] if keys else None


class DemonstrationRecorder:
    """The teleop's recording parts: a road library with its learning rule, and the file.

    The library learns from each commanded frame (rule ``careful``; ``learning = False`` switches
    to ``paused``) as the paper's robot did while a careful human drove; the first
    ``library_only`` commands only build the library. It is an observer of the teaching loop:
    cases go through ``lfd_track.dataset.DemonstrationWriter``, with the perception's memory
    inputs (``memory``, none by default) if it has any. A ``fresh_felt`` map assumes
    ``map_geometry``: the robot's profile where one exists, else (None)
    :func:`~lfd_track.policy.map_geometry.hardware_geometry`, the paper preset's camera and
    rates (nothing on the robot is measured yet).
    """

    def __init__(
        self,
        path: str | Path,
        *,
        bins: int = 32,
        library_only: int = LIBRARY_ONLY_COMMANDS,
        metadata: Mapping[str, Any] | None = None,
        overwrite: bool = False,
        memory: MemoryConfig | None = None,
        map_geometry: MapGeometry | None = None,
    ) -> None:
        from ..dataset.recording import RecordingTarget
        from ..teaching.observers import Recorder
        from ..teaching.perception import Perception
        from ..vision.road_library import RoadLibrary

        self.library = RoadLibrary(bins=bins)
        self.perception = Perception(
            self.library, "careful", memory, geometry=hardware_geometry(map_geometry)
        )
        self.library_only = int(library_only)
        meta = {"source": "hardware teleop", **dict(metadata or {})}
        # The library is logged as it changes, so an interrupted recording still trains; the
        # perception's memory inputs (if any) go with every case.
        self._writer = RecordingTarget(path).writer(
            meta, self.perception, fsync=True, overwrite=overwrite
        )
        self._recorder = Recorder(self._writer, lambda step: {"phase": "drive", "step": None})

    @property
    def learning(self) -> bool:
        """Whether the library learns from commanded frames (False: paused by the operator)."""
        return self.perception.rule == "careful"

    @learning.setter
    def learning(self, value: bool) -> None:
        self.perception.rule = "careful" if value else "paused"

    @property
    def n_cases(self) -> int:
        """Cases written so far."""
        return self._writer.n_cases

    def start(self, info: dict[str, Any]) -> None:
        self._recorder.start(info)

    def observe(self, step: Any) -> None:
        self._recorder.observe(step)

    def close(self) -> None:
        """Write the footer with the record-time library snapshot."""
        self._writer.close({"road_library": self.library.to_dict()})

    def __enter__(self) -> DemonstrationRecorder:
        return self

    def __exit__(self, exc_type: object, *exc: object) -> None:
        # Even after an error the file keeps every case so far; the footer marks a clean end.
        self.close()


def run_teleop(
    env: Any,
    observation: np.ndarray,
    keys: KeySource,
    recorder: DemonstrationRecorder | None,
    *,
    max_commands: int | None = None,
    say: Callable[[str], None] = print,
) -> int:
    """Drive ``env`` (a reset ``HardwareEnv``) from ``keys``, recording each command.

    ``observation``: the frame ``env.reset()`` returned, RGB uint8 (480, 640, 3). An arrangement
    of the teaching loop: the keys feed a :class:`~lfd_track.teaching.QueueCommander`, the
    arbiter lets only the human drive, the recorder observes.

    Returns the number of commands sent. Stops the robot and returns on ``q``, at
    ``max_commands``, or when the episode ends (its failure is reported through ``say``).
    """
    from ..teaching import Arbiter, Perception, QueueCommander, TeachingLoop
    from ..vision.road_library import RoadLibrary

    human = QueueCommander(library_only=recorder.library_only if recorder is not None else 0)
    perception = (
        recorder.perception if recorder is not None else Perception(RoadLibrary(), "frozen")
    )
    loop = TeachingLoop(
        env,
        perception,
        Arbiter("human"),
        human=human,
        observers=[recorder] if recorder is not None else [],
    )
    loop.attach(observation)
    while max_commands is None or loop.counts.steps < max_commands:
        key = keys.poll(0.1)
        if key is None:
            continue
        action = KEYMAP.get(key)
        if action == QUIT:
            break
        if action == STOP:
            env.unwrapped.link.stop()
            continue
        if action == TOGGLE_LEARNING and recorder is not None:
            recorder.learning = not recorder.learning
            say(f"library learning {'on' if recorder.learning else 'paused'}")
            continue
        if not isinstance(action, Command):
            continue
        human.push(action)
        step = loop.step()
        if loop.terminated:
            info = step.info_after
            say(f"stopped: {info.get('error', info.get('failure'))}")
            break
    env.unwrapped.link.stop()
    return loop.counts.steps
