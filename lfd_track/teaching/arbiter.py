"""The arbiter: who drives — the human, the policy, or the policy after it earned a takeover.

Modes:

* ``human`` — demonstration: the human's command is executed (none: the robot waits);
* ``policy`` — autonomous trial: the policy's command is executed;
* ``takeover`` — the human drives while the policy's proposals are compared with the human's
  commands; once the policy agreed on at least ``threshold`` of the last ``window`` commands it
  drives. Any command the human gives while the policy drives is executed instead, hands control
  back to the human, clears the agreement record and is flagged as a *correction*.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

from ..core.commands import Command

ARBITER_MODES = ("human", "policy", "takeover")


@dataclass(frozen=True)
class Decision:
    """What the arbiter decided for one frame."""

    command: Command | None
    """The command to execute (None: nobody gave one, the robot waits)."""
    driver: str | None
    """``"human"`` or ``"policy"`` (None with no command)."""
    correction: bool = False
    """The human took control back from the policy with this command."""
    takeover: bool = False
    """The policy took control with this command."""


class Arbiter:
    """Decides who drives; its state (mode, who drives, agreement) is readable at any time.

    Args:
        mode: one of ``human``, ``policy``, ``takeover``.
        window: K, the number of recent human commands the agreement is measured over.
        threshold: share of those K the policy must have agreed with to take over (0..1].
        auto_accept: with False an earned takeover is only *offered* (:attr:`offer`) until
            :meth:`accept` is called (a person confirming on a teaching station).
        initial_driver: who drives at the start of an episode in takeover mode (``"policy"``:
            the robot drives and the human intervenes, as in HG-DAgger).
    """

    def __init__(
        self,
        mode: str = "human",
        *,
        window: int = 10,
        threshold: float = 0.9,
        auto_accept: bool = True,
        initial_driver: str = "human",
    ) -> None:
        if mode not in ARBITER_MODES:
            raise ValueError(f"arbiter mode must be one of {', '.join(ARBITER_MODES)}")
        if window < 1:
            raise ValueError(f"takeover window must be >= 1, got {window}")
        if not 0.0 < threshold <= 1.0:
            raise ValueError(f"takeover threshold must be in (0, 1], got {threshold}")
        if initial_driver not in ("human", "policy"):
            raise ValueError("initial_driver must be 'human' or 'policy'")
        self.mode = mode
        self.initial_driver = "policy" if mode == "policy" else initial_driver
        if mode == "human":
            self.initial_driver = "human"
        self.window = int(window)
        self.threshold = float(threshold)
        self.auto_accept = bool(auto_accept)
        self.driving = self.initial_driver
        self._agreement: deque[bool] = deque(maxlen=self.window)
        self.offer = False
        self._accepted = False
        self.takeovers = 0
        self.corrections = 0

    @property
    def agreement(self) -> float:
        """Share of the last K human commands the policy agreed with (0 with none yet)."""
        agreement = tuple(self._agreement)  # one read: the loop thread may clear it meanwhile
        return sum(agreement) / len(agreement) if agreement else 0.0

    @property
    def agreement_count(self) -> int:
        """How many comparisons the agreement is over (up to K)."""
        return len(self._agreement)

    def accept(self) -> None:
        """Confirm an offered takeover (with ``auto_accept=False``)."""
        self._accepted = self.offer

    def reset(self) -> None:
        """Start of an episode: the human drives again (takeover mode) and agreement is cleared."""
        self.driving = self.initial_driver
        self._agreement.clear()
        self.offer = self._accepted = False

    def decide(self, human: Command | None, policy: Command | None) -> Decision:
        """Choose the command for this frame from the two proposals."""
        if self.mode == "human":
            return Decision(human, "human" if human is not None else None)
        if self.mode == "policy":
            return Decision(policy, "policy" if policy is not None else None)
        if self.driving == "policy":
            if human is not None:
                self.driving = "human"
                self._agreement.clear()
                self.offer = self._accepted = False
                self.corrections += 1
                return Decision(human, "human", correction=True)
            return Decision(policy, "policy" if policy is not None else None)
        # The human drives; the policy earns the wheel by agreeing.
        if human is None:
            return Decision(None, None)
        if policy is not None:
            self._agreement.append(policy == human)
        earned = (
            policy is not None
            and len(self._agreement) == self.window
            and self.agreement >= self.threshold
        )
        self.offer = earned
        if earned and (self.auto_accept or self._accepted):
            # The human's command for this frame still counts; the policy drives from the next.
            self.driving = "policy"
            self.offer = self._accepted = False
            self.takeovers += 1
            return Decision(human, "human", takeover=True)
        return Decision(human, "human")
