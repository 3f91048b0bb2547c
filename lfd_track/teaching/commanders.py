"""Commanders: anything that proposes a command for a frame (``None`` = no opinion yet).

The scripted human (:mod:`lfd_track.teaching.scripted`), a keyboard or a browser (through
:class:`QueueCommander`) and policies (:class:`PolicyCommander`) all implement
:class:`Commander`, so the arbiter can weigh them the same way.
"""

from __future__ import annotations

import threading
from typing import TYPE_CHECKING, Protocol, runtime_checkable

import numpy as np

from ..core.commands import Command
from ..policy.mlp import N_HIDDEN, ensemble_forward, select_action

if TYPE_CHECKING:
    from .types import Moment


@runtime_checkable
class Commander(Protocol):
    """Proposes a command for the current moment of the loop."""

    def reset(self) -> None:
        """Start of an episode: forget per-episode state."""

    def propose(self, moment: Moment) -> Command | None:
        """The command this commander wants now, or ``None`` for no opinion."""


# Optional members a commander may have, read by the loop with getattr:
#   claim() -> bool: called by a loop where only the human drives, before it perceives. False
#       means propose() would certainly return None now: the loop waits without perceiving the
#       frame (so waiting never teaches the library the same frame twice). True reserves the
#       input: the next propose() returns it, even if another thread changes the input in
#       between (so a perceived frame is always followed by its command).
#   records -> bool: whether the command just proposed is a teaching case (default True).
#   finished(info) -> bool: a scripted human whose script is over ends the loop's run().


class PolicyCommander:
    """A 40-5-3 MLP driving from road values (paper §4.2.3): the largest output wins.

    An exact tie keeps the previous command. ``weights`` may be replaced between steps (a learner
    updating the policy); ``None`` weights mean there is no policy yet (proposes ``None``);
    (k, W) weights are an ensemble, driving by the mean of its networks' outputs.
    ``hidden``: nodes of the hidden layer (the paper's 5; a wider network says so).
    """

    def __init__(self, weights: np.ndarray | None, *, hidden: int = N_HIDDEN) -> None:
        self.weights = None if weights is None else np.asarray(weights, dtype=np.float64)
        self.hidden = hidden
        self._previous: int | None = None
        self.last_outputs: np.ndarray | None = None
        """MLP outputs (3,) of the latest proposal."""

    def reset(self) -> None:
        self._previous = None
        self.last_outputs = None

    def propose(self, moment: Moment) -> Command | None:
        return self.act_on_values(moment.policy_inputs)

    def act_on_values(self, values: np.ndarray) -> Command | None:
        """Command for road values (40,) float (followed by memory inputs if the net has any)."""
        if self.weights is None:
            return None
        values = np.asarray(values, dtype=np.float64)[None]
        outputs = ensemble_forward(self.weights, values, hidden=self.hidden)[0]
        self.last_outputs = outputs
        self._previous = select_action(outputs, self._previous)
        return Command(self._previous)


class QueueCommander:
    """A push-style human: another thread (keys, a web server) sets the latest command.

    :meth:`push` may be called from any thread; :meth:`propose` hands the latest pushed command
    to the loop once (then ``None`` until the next push), so a held key or a button is one command.
    The first ``library_only`` commands taken only build the road library (not teaching cases,
    as in the paper, §4.2.5).
    """

    def __init__(self, library_only: int = 0) -> None:
        self._lock = threading.Lock()
        self._pending: Command | None = None
        self.library_only = int(library_only)
        self.taken = 0
        """Commands handed to the loop so far."""

    def claim(self) -> bool:
        """Whether a pushed command waits (with none, a human-only loop does not even look).
        Only :meth:`propose` takes it, so it stays reserved: a later push only replaces it."""
        with self._lock:
            return self._pending is not None

    @property
    def records(self) -> bool:
        """Whether the command just taken is a teaching case (past the library-only ones)."""
        return self.taken > self.library_only

    def push(self, command: Command | int) -> None:
        """Set the command the human gives next (replaces one not yet taken)."""
        with self._lock:
            self._pending = Command(int(command))

    def reset(self) -> None:
        with self._lock:
            self._pending = None

    def propose(self, moment: Moment) -> Command | None:
        with self._lock:
            command, self._pending = self._pending, None
        self.taken += command is not None
        return command
