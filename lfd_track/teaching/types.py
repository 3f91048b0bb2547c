"""What the parts of the teaching loop hand each other: a :class:`Moment` and a :class:`Step`.

The loop builds them, commanders read a :class:`Moment`, observers receive a :class:`Step`. They
live apart from :mod:`lfd_track.teaching.loop` so that commanders and observers import these
types and not the loop that imports them.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.commands import Command
from .arbiter import Decision
from .perception import Percept


@dataclass(frozen=True)
class Moment:
    """What the commanders see when proposing a command."""

    step: int
    """Commands executed so far in this episode."""
    frame: np.ndarray
    """The camera frame, RGB uint8 (480, 640, 3)."""
    values: np.ndarray
    """Its road values, (40,) float64."""
    info: dict[str, Any]
    """The env's info for this frame (privileged state in simulation, e.g. ``pose``)."""
    driving: str
    """Who drives before this frame's decision: ``"human"`` or ``"policy"``."""
    inputs: np.ndarray | None = None
    """The policy's inputs: road values then memory inputs (None: the road values alone)."""

    @property
    def policy_inputs(self) -> np.ndarray:
        """What a policy network reads: :attr:`inputs`, or the road values without memory."""
        return self.values if self.inputs is None else self.inputs

    @property
    def pose(self) -> np.ndarray | None:
        """The rover pose (x [m], y [m], theta [rad]) as (3,) float64, if the world reports it."""
        pose = self.info.get("pose")
        return None if pose is None else np.asarray(pose, dtype=np.float64)


@dataclass(frozen=True)
class Step:
    """One executed (or waiting) step of the loop, as observers receive it."""

    moment: Moment
    percept: Percept
    human: Command | None
    """The human's proposal (None: no opinion or no human)."""
    policy: Command | None
    """The policy's proposal (None: no opinion or no policy)."""
    decision: Decision
    is_case: bool
    """The human drove this step and it counts as a teaching case."""
    info_after: dict[str, Any] = field(default_factory=dict)
    """The env's info after the command was executed (empty when nothing was executed)."""
    decision_ms: float | None = None
    """Wall-clock milliseconds from the frame to the command: the perception, the commanders'
    proposals and the arbiter (None for a step where nobody was asked). On a robot this is the
    latency the decision adds; ``benchmarks/speed/bench_budget.py`` measures its CPU time."""

    @property
    def command(self) -> Command | None:
        return self.decision.command
