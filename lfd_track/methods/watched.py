"""Fits chosen by watching them drive (``BCConfig.watched_fits``, the ``bc`` method).

Backprop's fits to one demonstration differ by their starting weights alone, and a policy's
laps move more between its fits than between demonstrations
(``benchmarks/experiments/human_goal/round20/``); now and then the learned policy fails a room
whose rule on the same map laps. A person who has just taught a robot tries it on the track it
was taught on. With ``watched_fits = k > 1`` the learned policy drives the demonstration track
:data:`WATCHED_LAPS` times each way; while it does not lap every one, backprop fits again from
new starting weights (the same cases, the same generator drawn on), up to k fits, and the fit
that lapped most is kept (ties: the earlier). Every fit is watched on the same worlds (their
seeds drawn from the repetition's learning seed, apart from the fits' own stream), so the first
fit is the one ``watched_fits = 1`` keeps unwatched.

The watched laps cost the human no command. They are robot time (``autonomous_drive_s`` and
``learning_drive_s``) and laps a person judges by watching (``watched_laps``); the simulator
puts the robot back at the track's start for each, as the benchmark's trials do, and the episode
judges the lap by the track, as that person would.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..learning.result import LearnerFit
from ..policy.controller import Controller
from ..teaching.loop import LoopCounts
from .common import MethodContext, add_counts, drive_policy, track_env

WATCHED_LAPS = 2
"""Laps of the demonstration track each way a fit is watched over."""
WATCH_STREAM = 0x77617463
"""Spawn key of the watched laps' world seeds, beside the repetition's learning seed (so that
drawing them moves nothing the fits draw)."""


@dataclass(frozen=True)
class Watched:
    """The fit the watching kept, with what was watched."""

    fit: LearnerFit
    controller: Controller
    lapped: tuple[int, ...]
    """Laps each fit lapped of its ``2 * WATCHED_LAPS``, in the order they were fitted."""
    chosen: int
    """Index of the kept fit in :attr:`lapped`."""
    counts: LoopCounts
    """The watched laps' commands, every one the policy's."""

    @property
    def laps(self) -> int:
        """Laps watched in all."""
        return 2 * WATCHED_LAPS * len(self.lapped)

    def record(self) -> dict[str, Any]:
        """What results.json records of the watching (the demonstration record's ``watched``)."""
        return {"laps_each": 2 * WATCHED_LAPS, "lapped": list(self.lapped), "chosen": self.chosen}


def watch_seeds(context: MethodContext) -> list[int]:
    """The world seeds of a fit's watched laps each way (the same for every fit)."""
    rng = np.random.default_rng([context.ga_seed, WATCH_STREAM])
    return [int(s) for s in rng.integers(0, 2**62, WATCHED_LAPS)]


def watched_laps(context: MethodContext, controller: Controller, counts: LoopCounts) -> int:
    """Laps ``controller`` laps of :data:`WATCHED_LAPS` each way on the demonstration track
    (``context.track`` under ``context.preset``); their steps are added to ``counts``."""
    lapped = 0
    seeds = watch_seeds(context)
    for reverse in (False, True):
        env = track_env(context, reverse=reverse)
        try:
            for seed in seeds:
                loop = drive_policy(env, controller, seed=seed)
                lapped += bool(loop.info["success"])
                add_counts(counts, loop.counts)
        finally:
            env.close()
    return lapped


def choose_by_watching(
    context: MethodContext,
    fits: int,
    fit_again: Callable[[], LearnerFit],
    controller_of: Callable[[LearnerFit], Controller],
    first: LearnerFit,
) -> Watched:
    """Watch ``first`` and, while the last fit did not lap every watched lap, fits drawn by
    ``fit_again`` (at most ``fits`` in all); keep the one that lapped most (ties: the earlier).
    ``controller_of`` makes a fit's controller."""
    counts = LoopCounts()
    watched: list[tuple[LearnerFit, Controller]] = []
    lapped: list[int] = []
    fit = first
    while True:
        controller = controller_of(fit)
        watched.append((fit, controller))
        lapped.append(watched_laps(context, controller, counts))
        if lapped[-1] == 2 * WATCHED_LAPS or len(lapped) == fits:
            break
        fit = fit_again()
    chosen = lapped.index(max(lapped))  # the first of the most
    return Watched(*watched[chosen], tuple(lapped), chosen, counts)
