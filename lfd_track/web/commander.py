"""The browser as a commander of the teaching loop: button presses in, one command per period out."""

from __future__ import annotations

import threading
from collections import deque
from typing import TYPE_CHECKING

from ..core.commands import Command

if TYPE_CHECKING:
    from ..teaching.types import Moment

MAX_QUEUED = 4
"""Presses kept while the robot is busy; more are dropped (a frantic tapper does not queue a lap)."""


class BrowserCommander:
    """Commands from the page, as the paper's remote gave them: each press is one command.

    ``press`` queues the command once and holds it; ``release`` lets go. Each control period the
    loop asks :meth:`next_command`: a queued press first (so a quick tap still runs once), else
    the held command (holding a button repeats it), else None (no opinion: the robot waits).
    Thread-safe: the server thread presses, the loop thread asks.

    A :class:`~lfd_track.teaching.commanders.Commander` of the teaching loop; the first
    ``library_only`` commands it gives only build the road library (:attr:`records` is False).
    """

    def __init__(self, library_only: int = 0) -> None:
        self._lock = threading.Lock()
        self._queue: deque[Command] = deque(maxlen=MAX_QUEUED)
        self._held: Command | None = None
        self._claimed: Command | None = None
        self.library_only = int(library_only)
        self.given = 0
        """Commands handed to the loop so far."""

    @property
    def records(self) -> bool:
        """Whether the command just given counts as a teaching case (past the library-only ones)."""
        return self.given > self.library_only

    def reset(self) -> None:
        """Start of an episode: nothing to forget (a press outlives the world's reset, e.g. the
        press that clears the real robot's e-stop)."""

    def propose(self, moment: Moment) -> Command | None:
        """The loop asks for this frame's command (see :meth:`next_command`)."""
        command = self.next_command()
        if command is not None:
            self.given += 1
        return command

    def press(self, command: Command) -> None:
        """A button went down: run ``command`` at least once, and while held."""
        with self._lock:
            self._queue.append(Command(command))
            self._held = Command(command)

    def release(self) -> None:
        """The button went up."""
        with self._lock:
            self._held = None

    def clear(self) -> None:
        """Forget queued, held and claimed commands (stop, lease expiry, page closed): a stop
        wins even over a command the loop already reserved."""
        with self._lock:
            self._queue.clear()
            self._held = None
            self._claimed = None

    @property
    def pending(self) -> bool:
        """True when a command waits: claimed by the loop, queued, or held."""
        with self._lock:
            return self._claimed is not None or bool(self._queue) or self._held is not None

    def claim(self) -> bool:
        """The loop is about to perceive a frame for the human's command: reserve the command
        :meth:`next_command` would give now, so a release racing the loop's perception cannot
        leave a perceived frame without its command. False (nothing reserved) when there is
        none: a human-only loop then does not even look."""
        with self._lock:
            if self._claimed is None:
                self._claimed = self._take()
            return self._claimed is not None

    def next_command(self) -> Command | None:
        """The command for this control period, or None when the human gives none: a claimed
        command first, then a queued press, then the held button."""
        with self._lock:
            if self._claimed is not None:
                command, self._claimed = self._claimed, None
                return command
            return self._take()

    def _take(self) -> Command | None:
        if self._queue:
            return self._queue.popleft()
        return self._held
