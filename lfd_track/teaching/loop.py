"""The teaching loop: frame → perception → commanders → arbiter → command → world → observers.

The world is any Gymnasium env whose observation is the RGB camera frame (the simulated
``LfDTrackEnv`` or the hardware env). :meth:`TeachingLoop.step` runs one command; a teaching
station can call it whenever its human pushed a command, a benchmark calls :meth:`run`.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..errors import DemonstrationUnfinished
from .arbiter import Arbiter, Decision
from .commanders import Commander
from .observers import Observer
from .perception import Percept, Perception
from .types import Moment, Step


@dataclass
class LoopCounts:
    """What happened in a loop so far (counted the same way for every arrangement)."""

    steps: int = 0
    """Commands executed."""
    human_commands: int = 0
    """Commands executed that the human gave (demonstration and corrections)."""
    policy_commands: int = 0
    """Commands executed that the policy gave."""
    corrections: int = 0
    """Human commands that took control back from the policy."""
    takeovers: int = 0
    """Times the policy took control."""
    cases: int = 0
    """Steps that counted as teaching cases."""


class TeachingLoop:
    """One loop, many parts.

    Args:
        env: Gymnasium env with camera-frame observations (``info`` may hold ``pose`` and
            ``safe_box_on_felt``).
        perception: library + learning rule.
        arbiter: who drives.
        human: the human commander (scripted, keys, browser) or None.
        policy: the policy commander or None.
        observers: receive every executed step, after the command ran.
        stop_on_episode_end: end :meth:`run` when the env terminates or truncates (a
            demonstration keeps going: its human steers back).
    """

    def __init__(
        self,
        env: Any,
        perception: Perception,
        arbiter: Arbiter,
        *,
        human: Commander | None = None,
        policy: Commander | None = None,
        observers: Sequence[Observer] = (),
        stop_on_episode_end: bool = True,
    ) -> None:
        self.env = env
        self.perception = perception
        self.arbiter = arbiter
        self.human = human
        self.policy = policy
        self.observers = list(observers)
        self.stop_on_episode_end = stop_on_episode_end
        self.counts = LoopCounts()
        self.frame: np.ndarray | None = None
        self.info: dict[str, Any] = {}
        self.episode_over = False
        self.terminated = False
        """The env reported a terminal state (failure, success, a hardware fault)."""
        self._episode_steps = 0

    def attach(
        self, frame: np.ndarray, info: dict[str, Any] | None = None, *, keep_memory: bool = False
    ) -> None:
        """Start from an env the caller already reset (its first frame and info).

        ``keep_memory``: the robot was not moved (e.g. a real robot re-armed after a stop where
        it stands), so the perception's memory inputs carry on instead of starting afresh.
        """
        self.frame, self.info = frame, dict(info or {})
        self.episode_over = self.terminated = False
        self._episode_steps = 0
        self.arbiter.reset()
        if not keep_memory:
            self.perception.start_episode()
        for part in (self.human, self.policy):
            if part is not None:
                part.reset()
        for observer in self.observers:
            observer.start(self.info)

    def reset(
        self,
        seed: int | None = None,
        options: dict[str, Any] | None = None,
        *,
        keep_memory: bool = False,
    ) -> None:
        """Reset the env and every part's per-episode state (the memory too, unless
        ``keep_memory``; see :meth:`attach`)."""
        frame, info = self.env.reset(seed=seed, options=options)
        self.attach(frame, info, keep_memory=keep_memory)

    @property
    def done(self) -> bool:
        """The episode ended (and the loop stops on that) or the human's script finished."""
        finished = getattr(self.human, "finished", None)
        if finished is not None and finished(self.info):
            return True
        return self.stop_on_episode_end and self.episode_over

    def step(self) -> Step:
        """Perceive the current frame, ask the commanders, execute the arbiter's command."""
        if self.frame is None:
            raise RuntimeError("call reset() before step()")
        if self.arbiter.driving == "human":
            claim = getattr(self.human, "claim", None)
            if claim is not None and not claim():
                return self._waiting(self.frame)
        reset = getattr(self.human, "memory_reset", None)
        if reset is not None and reset():  # the human's script starts a leg afresh
            self.perception.start_episode()
        started = time.perf_counter_ns()
        percept = self.perception.perceive(self.frame, self.info.get("safe_box_on_felt"))
        moment = Moment(
            step=self._episode_steps,
            frame=self.frame,
            values=percept.values,
            info=self.info,
            driving=self.arbiter.driving,
            inputs=percept.inputs,
        )
        human = self.human.propose(moment) if self.human is not None else None
        policy = self.policy.propose(moment) if self.policy is not None else None
        decision = self.arbiter.decide(human, policy)
        decision_ms = (time.perf_counter_ns() - started) / 1e6
        if decision.command is None:
            return Step(
                moment, percept, human, policy, decision, is_case=False, decision_ms=decision_ms
            )
        is_case = decision.driver == "human" and bool(getattr(self.human, "records", True))
        frame, _, terminated, truncated, info = self.env.step(int(decision.command))
        self.perception.note(decision.command)
        self.frame, self.info = frame, info
        self.terminated = bool(terminated)
        self.episode_over = self.episode_over or bool(terminated or truncated)
        self._episode_steps += 1
        c = self.counts
        c.steps += 1
        c.human_commands += decision.driver == "human"
        c.policy_commands += decision.driver == "policy"
        c.corrections += decision.correction
        c.takeovers += decision.takeover
        c.cases += is_case
        step = Step(
            moment, percept, human, policy, decision, is_case, info_after=info,
            decision_ms=decision_ms,
        )  # fmt: skip
        for observer in self.observers:
            observer.observe(step)
        return step

    def _waiting(self, frame: np.ndarray) -> Step:
        """A step where nobody commands and nothing is perceived (the human has no input)."""
        none = Decision(None, None)
        moment = Moment(self._episode_steps, frame, np.zeros(0), self.info, "human")
        percept = Percept(np.zeros(0), np.zeros(0, dtype=np.float32), False, None)
        return Step(moment, percept, None, None, none, is_case=False)

    def run(self, max_steps: int | None = None) -> LoopCounts:
        """Step until :attr:`done` (or ``max_steps`` commands, then
        :class:`~lfd_track.errors.DemonstrationUnfinished` with the counts so far)."""
        executed = 0
        while not self.done:
            step = self.step()
            if step.command is None and self.human is not None and not self.done:
                # A scripted run never waits; a commander with no opinion would spin forever.
                raise RuntimeError("no commander proposed a command")
            executed += step.command is not None
            if max_steps is not None and executed > max_steps:
                raise DemonstrationUnfinished(
                    f"the loop exceeded {max_steps} commands", self.counts
                )
        return self.counts
