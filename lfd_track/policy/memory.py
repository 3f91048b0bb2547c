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
  flip it;
* ``"previous_command"`` — a Jordan network's feedback: three inputs, the one-hot of the command
  executed at the previous step (forward, left, right), all 0 at an episode's first step. The
  network learns what to do with it, where ``last_bend`` fixes a latch by hand.

``previous_command`` feeds back the *executed* command, not the network's three output
activations: on recorded cases the previous executed command is known (teacher forcing: the
human's, or the policy's where it drove), so GA fitness and backprop over the static cases stay
valid, whereas the outputs a network would have produced depend on its own weights and are not
in any recording. The risk is the one of every such input: consecutive commands of a
demonstration mostly agree, so "repeat the previous command" alone already scores high and a
learner may lean on it (copying the last command) instead of on the road; when driving, one
wrong command is then fed back and repeated. Learning from a recording where corrections break
such runs, and reading the training accuracy with that baseline in mind, are the guards.

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
from .features import frame_inputs

MEMORY_KINDS = ("none", "last_bend", "previous_command")
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
        """Inputs the memory adds after the per-region inputs (the 40 road values)."""
        return {"none": 0, "last_bend": 1, "previous_command": 3}[self.kind]

    @property
    def policy_inputs(self) -> int:
        """Inputs of a network with this memory: the 40 road values plus :attr:`n_inputs`."""
        return N_REGIONS + self.n_inputs

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        """Memory inputs (N, m) as they would be in a world flipped left to right."""
        x = np.asarray(inputs, dtype=np.float64)
        if self.kind == "previous_command":  # the previous left becomes a right and back
            return x[:, [0, 2, 1]]
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


class PreviousCommandMemory:
    """The ``previous_command`` feedback: the one-hot of the last executed command."""

    def __init__(self, config: MemoryConfig) -> None:
        if config.kind != "previous_command":
            raise ValueError(
                f"PreviousCommandMemory implements 'previous_command', not {config.kind!r}"
            )
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Start of an episode: no command executed yet (all three inputs 0)."""
        self._inputs = np.zeros(3)

    def note(self, command: Command | int) -> None:
        """The command just executed becomes the next step's input."""
        cmd = int(command)
        if cmd not in (0, 1, 2):
            raise ValueError(f"command must be 0, 1 or 2, got {command!r}")
        self._inputs = np.zeros(3)
        self._inputs[cmd] = 1.0

    def inputs(self) -> np.ndarray:
        """The memory inputs now, (3,) float64."""
        return self._inputs.copy()


def policy_inputs(config: MemoryConfig | None, features: str = "road_values") -> int:
    """Inputs of a network with memory ``config`` (None: no memory) reading the per-region
    ``features`` (:mod:`lfd_track.policy.features`; default the paper's 40 road values)."""
    return frame_inputs(features) + (config or MemoryConfig()).n_inputs


def memory_for(config: MemoryConfig | None) -> TurnMemory | PreviousCommandMemory | None:
    """The memory part for ``config`` (None for no memory)."""
    if config is None or config.kind == "none":
        return None
    if config.kind == "previous_command":
        return PreviousCommandMemory(config)
    return TurnMemory(config)
