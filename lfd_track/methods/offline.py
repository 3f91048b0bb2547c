"""What the methods that learn after one simulated demonstration share (``paper``, ``bc``,
``cma-es``): the demonstration with its views, the cases a learner fits, and what they record."""

from __future__ import annotations

from typing import Any

import numpy as np

from ..core.commands import Command
from ..dataset import Demonstration
from ..demo.demonstrator import DemonstrationSummary
from ..demo.views import ViewCases
from ..learning.elman import episode_starts, sequence_accuracy
from ..learning.extra_cases import with_extra_cases
from ..learning.fitness import training_accuracy
from ..policy.controller import Controller
from ..teaching.loop import LoopCounts
from ..vision.road_library import RoadLibrary
from .common import (
    Learned,
    MethodContext,
    demonstrate,
    demonstration_record,
    effort_record,
    training_set,
)


def offline_cases(
    context: MethodContext,
) -> tuple[
    DemonstrationSummary,
    Demonstration,
    RoadLibrary,
    ViewCases | None,
    tuple[np.ndarray, np.ndarray],
]:
    """Record the demonstration (with its views if ``context.shifted_views``) and make what an
    offline learner fits from it: (summary, cases, library, views, (inputs, commands)); with
    ``context.extra_cases`` the saved cases follow the demonstration's own."""
    if context.policy_kind == "elman-sigmoid" and context.shifted_views:
        # An Elman network learns from cases in the order they were driven: views have none.
        raise ValueError(
            "shifted views have no place in a driven sequence: not with an Elman network"
        )
    summary, demo, library, views = demonstrate(context, shifted_views=context.shifted_views)
    cases = training_set(context, *demonstration_cases(demo, views, context.features))
    if context.extra_cases:
        cases = with_extra_cases(context.extra_cases, *cases)
    return summary, demo, library, views, cases


def demonstration_cases(
    demo: Demonstration, views: ViewCases | None, features: str
) -> tuple[np.ndarray, np.ndarray]:
    """A demonstration's cases (inputs, commands), followed by its views when there are any."""
    x, a = demo.policy_inputs(features), demo.commands
    if views is None or not len(views):
        return x, a
    return (
        np.concatenate([x, views.policy_inputs(features)]),
        np.concatenate([np.asarray(a, dtype=np.int64), views.commands]),
    )


def views_record(views: ViewCases | None) -> dict[str, Any]:
    """What a repetition records of its views: their number per label (nothing without)."""
    if views is None:
        return {}
    counts = np.bincount(views.commands, minlength=len(Command))
    return {"views": {c.name.lower(): int(counts[c]) for c in Command}}


def episodes(demo: Demonstration, mirror: bool) -> list[int]:
    """The episodes an Elman network is fitted over: the demonstration's cases in order, one
    episode (the rover drives on through the turn-arounds), then its mirror image as another."""
    return [demo.n_cases] * (2 if mirror else 1)


def accuracy(controller: Controller, demo: Demonstration) -> float:
    """Share of a demonstration's cases whose command the controller's network would give (an
    Elman network run over the cases in order, its context from 0)."""
    x = demo.policy_inputs(controller.features)
    if controller.policy_kind == "elman-sigmoid":
        starts = episode_starts(len(demo.commands))
        return sequence_accuracy(controller.weights, x, demo.commands, starts, bias=controller.bias)
    return training_accuracy(controller.weights, x, demo.commands, hidden=controller.hidden)


def learned_offline(
    context: MethodContext,
    summary: DemonstrationSummary,
    demo: Demonstration,
    controller: Controller,
    *,
    fitness_best: list[float],
    fitness_mean: list[float],
    extra: dict[str, Any] | None = None,
    counts: LoopCounts | None = None,
    effort: dict[str, Any] | None = None,
) -> Learned:
    """What a repetition that learns after one demonstration produced; ``counts``: the robot's
    own driving after the demonstration, if any, and ``effort`` more fields of its effort record
    (:mod:`lfd_track.methods.watched`'s laps)."""
    return Learned(
        controller=controller,
        demo=demonstration_record(summary, **(extra or {})),
        fitness_best=fitness_best,
        fitness_mean=fitness_mean,
        training_accuracy=accuracy(controller, demo),
        effort=effort_record(
            context.period_s,
            demonstration_commands=summary.commands,
            counts=counts,
            **(effort or {}),
        ),
    )
