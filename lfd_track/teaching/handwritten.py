"""Hand-written policies on the road values: what the 40 inputs allow without any learning.

:class:`RoadRule` reads the same 40 road values (8 columns x 5 rows, row-major from the
top-left) a learned 40-5-3 network reads, through a frozen road library, and steers by a fixed
rule:

* a region counts as felt by how far its road value lies between ``carpet`` and ``felt``
  (0 at or below ``carpet``, 1 at or above ``felt``);
* the *aim* is the felt's mean column position (columns at -3.5 .. +3.5, left negative), each
  row weighted by ``row_weights`` (top row first: weighting the far rows looks further ahead);
* if the weighted felt in view is below ``blank``, the view says nothing about where the felt
  went (past a sharp corner the next strip is out of view): the rule pivots toward the side of
  the last bend when it has the one-bit latch (``latch=True``; the ``last_bend`` memory of
  :mod:`lfd_track.policy.memory`, computed from the executed commands), or toward the side the
  felt was last seen on (``seen_latch=True``: the sign of the aim on the last frame that was not
  blank, a bit the rule keeps itself), else toward the side with more faint felt (ties:
  ``default_turn``);
* otherwise it pivots toward the aim when it lies more than ``turn_at`` columns off the centre,
  and drives forward when not.

The rule has no random part: the same road values (and latch) give the same command.

:class:`FreshFeltRule` steers by the ``fresh_felt`` memory inputs alone (the dead-reckoned map
of felt the rover has not driven along yet, :mod:`lfd_track.policy.memory`): it pivots toward
the fresh felt's bearing when that lies more than ``turn_deg`` off the heading, drives forward
when not, and with no fresh felt at all pivots toward the side it last turned toward the fresh
felt (left at first). It reads exactly the inputs a network with that memory gets, so it says
what those inputs allow without learning.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..core.commands import Command
from ..core.frame import GRID_COLUMNS, GRID_ROWS, N_REGIONS
from ..policy.branch_side import side_command
from ..policy.memory import (
    UNKNOWN_SIDE,
    FreshFeltConfig,
    LastBendConfig,
    MemoryConfig,
    fresh_bearing_rad,
)

_COLUMN_X = np.arange(GRID_COLUMNS, dtype=np.float64) - (GRID_COLUMNS - 1) / 2.0


@dataclass(frozen=True)
class RoadRuleConfig:
    """Settings of the hand-written road-value rule (see the module docstring)."""

    carpet: float = 0.3
    """Road value at or below which a region counts as carpet."""
    felt: float = 0.5
    """Road value at or above which a region counts as felt."""
    row_weights: tuple[float, ...] = (1.0, 1.0, 1.0, 1.0, 1.0)
    """Weight of each grid row in the aim, top (far) row first."""
    turn_at: float = 1.0
    """[columns] aim offset beyond which the rule pivots toward it."""
    blank: float = 1.5
    """Weighted felt in view below which the view is blank (nothing to aim at)."""
    latch: bool = False
    """Pivot toward the last bend's side when the view is blank (the one-bit latch)."""
    default_turn: str = "left"
    """Pivot direction on a blank view with no evidence either way (and, latched, before any
    bend)."""
    seen_latch: bool = False
    """Pivot toward the side the felt was last seen on when the view is blank (a one-bit
    memory the rule keeps: the sign of the last non-blank frame's aim). Not with ``latch``."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.carpet < self.felt <= 1.0:
            raise ValueError("road rule needs 0 <= carpet < felt <= 1")
        if len(self.row_weights) != GRID_ROWS or min(self.row_weights) < 0:
            raise ValueError(f"row_weights must be {GRID_ROWS} numbers >= 0")
        object.__setattr__(self, "row_weights", tuple(float(w) for w in self.row_weights))
        if self.turn_at < 0 or self.blank < 0:
            raise ValueError("turn_at and blank must be >= 0")
        if self.default_turn not in ("left", "right"):
            raise ValueError("default_turn must be 'left' or 'right'")
        if self.latch and self.seen_latch:
            raise ValueError("a road rule has one latch: latch or seen_latch, not both")

    @property
    def memory(self) -> MemoryConfig | None:
        """The memory the perception must supply (the latch), or None."""
        return LastBendConfig() if self.latch else None


@dataclass
class RoadRule:
    """A commander driving by :class:`RoadRuleConfig` from the moment's road values."""

    config: RoadRuleConfig = field(default_factory=RoadRuleConfig)
    blank_frames: int = 0
    """Frames so far on which the view was blank."""
    last_seen: Command | None = None
    """``seen_latch``: the side (LEFT/RIGHT) of the last non-blank frame's aim, None before."""

    def reset(self) -> None:
        # The last-bend latch lives in the perception; the last-seen side is the rule's own.
        self.last_seen = None

    def propose(self, moment) -> Command:  # noqa: ANN001 - a teaching-loop Moment
        inputs = np.asarray(moment.policy_inputs, dtype=np.float64)
        side = float(inputs[N_REGIONS]) if len(inputs) > N_REGIONS else UNKNOWN_SIDE
        return self.act(inputs[:N_REGIONS], side)

    def act(self, values: np.ndarray, side: float = UNKNOWN_SIDE) -> Command:
        """The command for road values (40,) and the latch ``side`` (1 left, 0 right, 0.5
        unknown; ignored without ``latch``)."""
        cfg = self.config
        grid = np.asarray(values, dtype=np.float64).reshape(GRID_ROWS, GRID_COLUMNS)
        felt = np.clip((grid - cfg.carpet) / (cfg.felt - cfg.carpet), 0.0, 1.0)
        weights = np.asarray(cfg.row_weights)[:, None] * felt
        mass = float(weights.sum())
        default = Command.LEFT if cfg.default_turn == "left" else Command.RIGHT
        if mass < cfg.blank:
            self.blank_frames += 1
            if cfg.latch and side != UNKNOWN_SIDE:
                return Command.LEFT if side > UNKNOWN_SIDE else Command.RIGHT
            if cfg.seen_latch and self.last_seen is not None:
                return self.last_seen
            lean = float((grid.sum(axis=0) * _COLUMN_X).sum())  # faint felt: which side
            if abs(lean) < 1e-9:
                return default
            return Command.LEFT if lean < 0 else Command.RIGHT
        aim = float((weights.sum(axis=0) * _COLUMN_X).sum() / mass)
        if aim != 0.0:
            self.last_seen = Command.LEFT if aim < 0 else Command.RIGHT
        if aim < -cfg.turn_at:
            return Command.LEFT
        if aim > cfg.turn_at:
            return Command.RIGHT
        return Command.FORWARD


@dataclass(frozen=True)
class FreshFeltRuleConfig:
    """Settings of the hand-written rule on the ``fresh_felt`` memory inputs."""

    turn_deg: float = 20.0
    """[deg] bearing of the fresh felt beyond which the rule pivots toward it (the default
    and the memory's defaults are the limits experiment's choice, part 2c)."""
    memory: FreshFeltConfig = field(default_factory=FreshFeltConfig.plain)
    """The map's settings (kind ``fresh_felt``; default the map with every option off, as the
    limits experiment tuned the rule on)."""

    def __post_init__(self) -> None:
        if not 0.0 <= self.turn_deg < 180.0:
            raise ValueError("turn_deg must lie in [0, 180)")
        if not isinstance(self.memory, FreshFeltConfig):
            raise ValueError("a fresh-felt rule needs memory kind 'fresh_felt'")
        if self.turn_deg >= self.memory.bearing_range_deg:
            raise ValueError("turn_deg must lie below the memory's bearing_range_deg")


@dataclass
class FreshFeltRule:
    """A commander driving by :class:`FreshFeltRuleConfig` from the ``fresh_felt`` inputs."""

    config: FreshFeltRuleConfig = field(default_factory=FreshFeltRuleConfig)
    blank_frames: int = 0
    """Frames so far with no fresh felt on the map."""
    side: Command = Command.LEFT
    """The side the fresh felt last lay on (the pivot when there is none)."""

    def reset(self) -> None:
        self.side = Command.LEFT

    def propose(self, moment) -> Command:  # noqa: ANN001 - a teaching-loop Moment
        inputs = np.asarray(moment.policy_inputs, dtype=np.float64)
        return self.act(inputs[-self.config.memory.n_inputs :])  # the map's inputs come last

    def act(self, memory: np.ndarray) -> Command:
        """The command for the ``fresh_felt`` inputs (3,): bearing, amount, distance; with the
        map's ``branch_side`` (4,), while no fresh felt is left the rule pivots toward the side
        felt branched off, when it gives one (else toward the side the fresh felt last lay on)."""
        if float(memory[1]) <= 0.0:  # no fresh felt
            self.blank_frames += 1
            branch = side_command(float(memory[3])) if len(memory) > 3 else None
            return self.side if branch is None else branch
        bearing = fresh_bearing_rad(memory, self.config.memory.bearing_range_deg)
        if bearing != 0.0:
            self.side = Command.LEFT if bearing > 0 else Command.RIGHT
        limit = math.radians(self.config.turn_deg)
        if bearing > limit:
            return Command.LEFT
        if bearing < -limit:
            return Command.RIGHT
        return Command.FORWARD
