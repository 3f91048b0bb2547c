"""Observers: parts that see every executed step (recorder, trajectory, learner feed, callbacks,
the teaching station's case tally)."""

from __future__ import annotations

import threading
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..core.commands import Command

if TYPE_CHECKING:
    from ..dataset import DemonstrationWriter
    from .types import Step


class Observer(Protocol):
    """Receives the start of each episode and every executed step."""

    def start(self, info: dict[str, Any]) -> None:
        """An episode started; ``info`` is the env's reset info."""

    def observe(self, step: Step) -> None:
        """One command was executed (``step.info_after`` is the info after it)."""


class Recorder:
    """Writes every teaching case to a crash-safe ``.lfdemo`` file (one ``append`` per case).

    ``annotate(step)`` returns extra per-case fields for
    :meth:`~lfd_track.dataset.DemonstrationWriter.append` (``pose``, ``progress_m``,
    ``phase``, ``step`` …); a step that is not a case is skipped. Road values and histograms are
    the record-time ones from the step's percept. Every case is written with ``round`` (0 for the
    initial demonstration, r for the r-th round of autonomous runs) and ``source``: ``"correction"``
    when the command took control back from the policy (or for every case when ``source`` is
    given as ``"correction"``, e.g. interventions), else ``"demonstration"``; ``annotate`` may
    still override both per case.
    """

    def __init__(
        self,
        writer: DemonstrationWriter,
        annotate: Callable[[Step], dict[str, Any]] | None = None,
        *,
        round: int = 0,
        source: str | None = None,
    ) -> None:
        self.writer = writer
        self.annotate = annotate or (lambda step: {})
        self.round = int(round)
        self.source = source

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        if not step.is_case:
            return
        command = step.command
        assert command is not None  # a teaching case is a step the human commanded
        source = self.source or ("correction" if step.decision.correction else "demonstration")
        fields: dict[str, Any] = {"source": source, "round": self.round}
        fields.update(self.annotate(step))
        if len(step.percept.memory):
            fields.setdefault("memory", step.percept.memory)
        self.writer.append(
            int(command),
            step.percept.values,
            step.percept.histograms,
            learned=step.percept.learned,
            **fields,
        )


class CaseBuffer:
    """Keeps every teaching case in memory: the policy's inputs (road values, then any memory
    inputs), commands and whether a correction."""

    def __init__(self, n_inputs: int = 40) -> None:
        self.n_inputs = n_inputs
        self.values: list[np.ndarray] = []
        self.commands: list[int] = []
        self.corrections: list[bool] = []

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        command = step.command
        if step.is_case:
            assert command is not None  # a teaching case is a step the human commanded
            self.values.append(np.asarray(step.percept.inputs, dtype=np.float64))
            self.commands.append(int(command))
            self.corrections.append(step.decision.correction)

    def arrays(self) -> tuple[np.ndarray, np.ndarray]:
        """(N, n_inputs) float64 inputs and (N,) intp commands."""
        if not self.values:
            return np.empty((0, self.n_inputs)), np.empty(0, dtype=np.intp)
        return np.stack(self.values), np.asarray(self.commands, dtype=np.intp)


class TrajectoryObserver:
    """Collects the rover's (x, y) after reset and after every step, for plots and results."""

    def __init__(self) -> None:
        self.points: list[tuple[float, float]] = []

    def start(self, info: dict[str, Any]) -> None:
        self.points = [info["pose"][:2]]

    def observe(self, step: Step) -> None:
        self.points.append(step.info_after["pose"][:2])

    def array(self) -> np.ndarray:
        """(N, 2) float32 positions [m]."""
        return np.asarray(self.points, dtype=np.float32)


class CallbackObserver:
    """Calls ``on_step(step)`` for every executed step (videos, progress bars, live views)."""

    def __init__(self, on_step: Callable[[Step], None]) -> None:
        self.on_step = on_step

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        self.on_step(step)


class LearningTally:
    """Counts the careful-training rule at work: frames learned, off the felt, learned off it."""

    def __init__(self) -> None:
        self.learned = self.off_felt = self.learned_off_felt = 0

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        box_on_felt = bool(step.percept.box_on_felt)
        self.learned += step.percept.learned
        self.off_felt += not box_on_felt
        self.learned_off_felt += step.percept.learned and not box_on_felt


class CaseTally:
    """Observer: cases per command and corrections, as the page shows them (thread-safe)."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._counts = dict.fromkeys((c.name.lower() for c in Command), 0)
        self.corrections = 0

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        if not step.is_case:
            return
        assert step.command is not None, "a case always has the command it records"
        with self._lock:
            self._counts[step.command.name.lower()] += 1
            self.corrections += step.decision.correction

    @property
    def counts(self) -> dict[str, int]:
        with self._lock:
            return dict(self._counts)
