"""Memory inputs: what the policy may know besides the current frame (beyond the paper, §6).

The paper's controller is purely reactive: 40 road values of one frame in, one command out. At a
sharp corner whose next strip is out of view (the testing track's 135° corner) the frame alone
cannot say which way the felt went, and a reactive network turns either way (or dithers). A
memory input carries that one fact forward from the commands the robot executed:

* ``"none"`` — no memory (the paper's 40 inputs);
* ``"last_bend"`` — one input saying which way the robot last turned by a whole bend: 1 after a
  left bend, 0 after a right bend, 0.5 before any. A *bend* is ``bend_pivots`` more pivots one way
  than the other since the last extreme of the running count (left +1, right -1; forward
  commands count nothing), so a wobble of one pivot left and one right changes nothing while
  two pivots the same way (45° with the paper's 23° pivots, the training track's gentlest bend)
  flip it.

The input is computed from *executed* commands, whoever gave them (the human demonstrating or
correcting, the policy driving), so a recorded case and an autonomous run see the same thing.
The teaching loop owns it through :class:`~lfd_track.teaching.perception.Perception`: the loop
notes each executed command and starts it afresh with each episode.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..core.commands import Command
from ..core.config import DictConfig
from ..core.frame import N_REGIONS

MEMORY_KINDS = ("none", "last_bend")
#: Value of the ``last_bend`` input before the first bend of an episode.
UNKNOWN_SIDE = 0.5


@dataclass(frozen=True)
class MemoryConfig(DictConfig):
    """Which memory inputs the policy gets (TOML table ``[memory]`` of a study condition)."""

    settings_name: ClassVar[str] = "memory"

    kind: str = "none"
    """One of :data:`MEMORY_KINDS`."""
    bend_pivots: int = 2
    """Net pivots one way that make a bend (``last_bend``)."""

    def __post_init__(self) -> None:
        if self.kind not in MEMORY_KINDS:
            raise ValueError(
                f"memory kind must be one of {', '.join(MEMORY_KINDS)}, got {self.kind!r}"
            )
        if isinstance(self.bend_pivots, bool) or not isinstance(self.bend_pivots, int):
            raise ValueError(f"memory bend_pivots must be an integer, got {self.bend_pivots!r}")
        if self.bend_pivots < 1:
            raise ValueError(f"memory bend_pivots must be >= 1, got {self.bend_pivots}")

    @property
    def n_inputs(self) -> int:
        """Inputs the memory adds after the 40 road values."""
        return 0 if self.kind == "none" else 1

    @property
    def policy_inputs(self) -> int:
        """Inputs of a network with this memory: the 40 road values plus :attr:`n_inputs`."""
        return N_REGIONS + self.n_inputs

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        """Memory inputs (N, m) as they would be in a world flipped left to right."""
        x = np.asarray(inputs, dtype=np.float64)
        return x.copy() if self.kind == "none" else 1.0 - x


class TurnMemory:
    """The ``last_bend`` latch over executed commands (see the module docstring)."""

    def __init__(self, config: MemoryConfig) -> None:
        if config.kind != "last_bend":
            raise ValueError(f"TurnMemory implements 'last_bend', not {config.kind!r}")
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Start of an episode: no bend seen yet."""
        self._count = 0
        self._high = 0
        self._low = 0
        self.side = UNKNOWN_SIDE
        """1.0 after a left bend, 0.0 after a right bend, 0.5 before any."""

    def note(self, command: Command | int) -> None:
        """Count one executed command."""
        cmd = int(command)
        if cmd == Command.LEFT:
            self._count += 1
        elif cmd == Command.RIGHT:
            self._count -= 1
        else:
            return
        self._high = max(self._high, self._count)
        self._low = min(self._low, self._count)
        k = self.config.bend_pivots
        if self._count - self._low >= k:
            self.side = 1.0
            self._high = self._low = self._count
        elif self._high - self._count >= k:
            self.side = 0.0
            self._high = self._low = self._count

    def inputs(self) -> np.ndarray:
        """The memory inputs now, (1,) float64."""
        return np.array([self.side])


def policy_inputs(config: MemoryConfig | None) -> int:
    """Inputs of a network with memory ``config`` (None: no memory, the paper's 40)."""
    return (config or MemoryConfig()).policy_inputs


def memory_for(config: MemoryConfig | None) -> TurnMemory | None:
    """The memory part for ``config`` (None for no memory)."""
    if config is None or config.kind == "none":
        return None
    return TurnMemory(config)
