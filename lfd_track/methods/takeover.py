"""What the methods in which the policy drives and the human steps in share (``online``,
``hg-dagger``, ``dagger``): when the policy may drive and when the human takes control, and the
rounds of runs in which the current controller drives the track once each way."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..core.config import DictConfig
from ..demo.demonstrator import HumanConfig
from ..learning.result import check_int
from ..policy.controller import Controller
from ..teaching.arbiter import Arbiter
from ..teaching.loop import LoopCounts, TeachingLoop
from ..teaching.scripted import InterventionConfig, ProtocolHuman
from ..world.track import load_track
from . import common
from .common import MethodContext


@dataclass(frozen=True)
class TakeoverConfig(DictConfig):
    """What ``online``, ``hg-dagger`` and ``dagger`` share: when the policy may drive, when the
    human steps in."""

    window: int = 10
    """K: the agreement is measured over the human's last K commands (1..10 000)."""
    threshold: float = 0.9
    """Share of those K the policy must have agreed with to drive (9 of 10 by default)."""
    intervention: InterventionConfig = field(default_factory=InterventionConfig)
    """When the watching human takes control (back)."""

    def _check_count(self, name: str, maximum: int) -> None:
        """The setting ``name`` must be an integer in 1..maximum (the error names the method)."""
        check_int(f"{self.settings_name} {name}", getattr(self, name), 1, maximum)

    def __post_init__(self) -> None:
        self._check_count("window", 10_000)
        if not 0.0 < self.threshold <= 1.0:
            raise ValueError(f"{self.settings_name} threshold must be in (0, 1]")


@dataclass
class RoundTally:
    """What the runs of one round counted: the loops' counts and the human's reasons to step in."""

    counts: LoopCounts = field(default_factory=LoopCounts)
    reasons: dict[str, int] = field(default_factory=dict)


def drive_both_ways(
    context: MethodContext,
    controller: Controller,
    human: HumanConfig,
    takeover: TakeoverConfig,
    rngs: tuple[np.random.Generator, np.random.Generator],
    observers: Callable[[ProtocolHuman], list[Any]],
    tally: RoundTally,
    *,
    label_all: bool = False,
) -> list[tuple[TeachingLoop, ProtocolHuman]]:
    """One round's runs: ``controller`` (library frozen) drives ``context.track`` once each way
    with the scripted ``human`` watching, stepping in by ``takeover``'s rule.

    ``rngs`` is (the human's stream, the round's stream, which seeds each run's env);
    ``observers(person)`` gives each run's observers. Returns each run's (loop, human), its env
    closed; ``tally`` has counted them.
    """
    human_rng, round_rng = rngs
    runs = []
    for reverse in (False, True):
        env = common.track_env(context, reverse=reverse)
        legs = (env.track, load_track(context.track, reverse=not reverse))
        person = ProtocolHuman(
            legs,
            human,
            human_rng,
            intervention=takeover.intervention,
            rover=env.preset.rover,
            label_all=label_all,
            memory=context.memory,
        )
        loop = TeachingLoop(
            env,
            controller.perception("frozen", world_geometry=context.map_geometry),
            Arbiter(
                "takeover",
                window=takeover.window,
                threshold=takeover.threshold,
                initial_driver="policy",
            ),
            human=person,
            policy=controller.commander(),
            observers=observers(person),
        )
        loop.reset(seed=int(round_rng.integers(2**62)))
        loop.run()
        common.add_counts(tally.counts, loop.counts)
        for why, n in person.interventions.items():
            tally.reasons[why] = tally.reasons.get(why, 0) + n
        env.close()
        runs.append((loop, person))
    return runs
