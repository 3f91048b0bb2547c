"""The ``direct`` and ``mu-plus-one`` methods: the paper's network evolved on the robot without a
human teacher, counted in robot time (:mod:`lfd_track.learning.direct`).

* ``direct`` — the paper's GA (Table 1 operators) with fitness = progress along the centreline
  of ``context.track``, every evaluation driven from the track's start once each way
  (:func:`~lfd_track.learning.direct.direct_evolution`). The simulator resets the robot to the
  start between drives, so it needs no hand to put it back.
* ``mu-plus-one`` — (μ+1)-ONLINE: μ genomes on board one robot that is never reset to the start,
  each evaluation driven where the robot stands; when it leaves the felt a person puts it back
  (counted as ``put_backs``; :func:`~lfd_track.learning.direct.mu_plus_one_online`).

Where the road library comes from: the network drives from the road values of a road library,
and a library is built by a person driving the rover over the felt. Both methods take it from
the repetition's own demonstration — the paper's protocol, recorded with ``context.demo_seed`` on
``context.track`` exactly as the ``paper`` method records it — and freeze it; the demonstration's
cases are not learned from. So the human's commands of that drive are counted as human commands
and its seconds as robot time while learning, beside the evolution's own robot time (every
command a candidate drove). The library is therefore the one the ``paper`` method of the same
seed and repetition builds, and the evolution draws its random stream from ``context.ga_seed``.

The controller is an ordinary controller file (the library, the 40-5-3 network, ``learner``
``direct`` or ``mu-plus-one`` with its settings): the benchmark's trials score it like any other.
Its ``training_accuracy`` is the share of the demonstration's cases whose command it would give
(it never saw them: how close evolution came to the human's driving).
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..learning.direct import (
    DirectConfig,
    DirectResult,
    MuPlusOneConfig,
    OnlineResult,
    direct_evolution,
    mu_plus_one_online,
)
from ..policy.controller import Controller
from ..policy.features import DEFAULT_FEATURES
from ..teaching.loop import LoopCounts
from .common import Learned, MethodContext, demonstrate, demonstration_record, effort_record
from .offline import accuracy
from .registry import MethodFlags

MAX_FLAG_GENERATIONS = 1_000_000
MAX_FLAG_EVALUATIONS = 10_000_000


def _check_context(context: MethodContext, name: str) -> None:
    """These methods evolve the paper's network on the road values alone: refuse what it would
    silently ignore (one line naming the option)."""
    if context.memory is not None and context.memory.kind != "none":
        raise ValueError(f"method '{name}' evolves the paper's network without memory inputs")
    if context.features != DEFAULT_FEATURES:
        raise ValueError(f"method '{name}' evolves on the paper's road values alone")
    if context.mirror:
        raise ValueError(f"method '{name}' learns from no cases: mirror does not apply")


def _evolve(
    context: MethodContext,
    name: str,
    evolve: Callable[..., DirectResult | OnlineResult],
    record: Callable[[Any], dict[str, Any]],
    best_key: str,
) -> Learned:
    """Demonstrate (the library), evolve with ``evolve`` on ``context.track``, and record the run
    (``record(result)`` in the demonstration record's ``evolution``; the curve's ``best_key``
    as the best fitness)."""
    config = context.settings
    _check_context(context, name)
    summary, demo, library, _ = demonstrate(context)
    result = evolve(library, config, context.ga_seed, track=context.track, preset=context.preset)
    controller = _controller(context, name, config.to_dict(), library, result)
    return _learned(
        context,
        summary,
        demo,
        controller,
        result,
        record(result),
        best=[p[best_key] for p in result.curve],
        mean=[p["mean"] for p in result.curve],
        # Direct evolution drives every evaluation from the start: no hand puts the robot back.
        put_backs=result.put_backs if isinstance(result, OnlineResult) else 0,
    )


def learn_direct(context: MethodContext) -> Learned:
    """Direct evolution on ``context.track`` with ``context.settings`` (:class:`DirectConfig`),
    seeded by ``context.ga_seed``; the library from the repetition's demonstration."""

    def record(result: DirectResult) -> dict[str, Any]:
        return {
            "generations": result.generations,
            "evaluations": result.evaluations,
            "world_seeds": result.world_seeds,
            "best_progress_m": result.best_fitness,
            "robot_s": result.robot_s,
            "steps": result.steps,
        }

    return _evolve(context, "direct", direct_evolution, record, "best_ever")


def learn_mu_plus_one(context: MethodContext) -> Learned:
    """(μ+1)-ONLINE on ``context.track`` with ``context.settings`` (:class:`MuPlusOneConfig`),
    seeded by ``context.ga_seed``; the library from the repetition's demonstration."""

    def record(result: OnlineResult) -> dict[str, Any]:
        return {
            "evaluations": result.evaluations,
            "children": result.children,
            "accepted": result.accepted,
            "reevaluations": result.reevaluations,
            "world_seed": result.world_seed,
            "best_fitness_m": result.best_fitness,
            "final_fitness": result.final_fitness,
            "robot_s": result.robot_s,
            "steps": result.steps,
            "put_backs": result.put_backs,
        }

    return _evolve(context, "mu-plus-one", mu_plus_one_online, record, "best")


def _controller(
    context: MethodContext,
    learner: str,
    settings: dict[str, Any],
    library: Any,
    result: DirectResult | OnlineResult,
) -> Controller:
    return Controller(
        library,
        result.best_weights,
        learner=learner,
        learner_config=settings,
        seed=context.ga_seed,
        fitness_history=[p.get("best_ever", p["best"]) for p in result.curve],
        frame_size=context.frame_size,
        map_geometry=context.map_geometry,
    )


def _learned(
    context: MethodContext,
    summary: Any,
    demo: Any,
    controller: Controller,
    result: DirectResult | OnlineResult,
    evolution: dict[str, Any],
    *,
    best: list[float],
    mean: list[float],
    put_backs: int,
) -> Learned:
    """What a repetition of either method produced: the demonstration's record with the
    evolution's beside it, and the effort of both (robot time: the demonstration's seconds plus
    every command a candidate drove)."""
    steps = result.steps
    return Learned(
        controller=controller,
        demo=demonstration_record(summary, cases_learned=False, evolution=evolution),
        fitness_best=[float(b) for b in best],
        fitness_mean=[float(m) for m in mean],
        training_accuracy=accuracy(controller, demo),
        effort=effort_record(
            context.period_s,
            demonstration_commands=summary.commands,
            counts=LoopCounts(steps=steps, policy_commands=steps),
            put_backs=put_backs,
            learning_steps=summary.commands + steps,
        ),
    )


# ------------------------------------------------------------------- command-line flags
@dataclass(frozen=True)
class CountFlag:
    """A method's one whole-number flag (``1..high``) of ``lfd-track benchmark``, setting
    ``field`` of its ``settings`` class (the class's defaults when not given). Its bound methods
    are the entry's :class:`MethodFlags` (picklable: a worker process is given the entry)."""

    flag: str
    field: str
    settings: type[Any]
    high: int
    help: str

    @property
    def dest(self) -> str:
        return self.flag.lstrip("-").replace("-", "_")

    def add(self, parser: argparse.ArgumentParser) -> None:
        from ..cli.types import whole_number_in

        parser.add_argument(
            self.flag, type=whole_number_in(1, self.high), default=None, metavar="N", help=self.help
        )

    def given(self, args: argparse.Namespace) -> list[str]:
        return [self.flag] if getattr(args, self.dest) is not None else []

    def from_flags(self, args: argparse.Namespace) -> Any:
        value = getattr(args, self.dest)
        return self.settings() if value is None else self.settings(**{self.field: value})

    def method_flags(self) -> MethodFlags:
        return MethodFlags(self.add, self.given, self.from_flags)


DIRECT_FLAGS = CountFlag(
    "--direct-generations",
    "generations",
    DirectConfig,
    MAX_FLAG_GENERATIONS,
    "with --method direct: generations at most (default: 25; the run also stops at its"
    " robot-time budget, 4000 s)",
)
"""``--direct-generations N``."""
MU_PLUS_ONE_FLAGS = CountFlag(
    "--mu-plus-one-evaluations",
    "evaluations",
    MuPlusOneConfig,
    MAX_FLAG_EVALUATIONS,
    "with --method mu-plus-one: evaluations at most, the first μ included (default: 500; the"
    " run also stops at its robot-time budget, 4000 s)",
)
"""``--mu-plus-one-evaluations N``."""


def learn_evolved(
    rep_dir: str | Path, *, settings: DirectConfig | MuPlusOneConfig, **context: Any
) -> Learned:
    """``direct`` or ``mu-plus-one`` by the type of ``settings``, with the context's fields as
    keywords (:class:`~lfd_track.methods.common.MethodContext`)."""
    learn = learn_direct if isinstance(settings, DirectConfig) else learn_mu_plus_one
    return learn(MethodContext(Path(rep_dir), settings=settings, **context))
