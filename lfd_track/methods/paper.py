"""The ``paper`` method: demonstration, then the GA offline (the paper, §4.2.5)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..learning.elman import evolve_elman
from ..learning.ga import evolve
from ..policy.controller import Controller
from .common import Learned, MethodContext
from .offline import episodes, learned_offline, offline_cases, views_record


def learn(context: MethodContext) -> Learned:
    """The paper: record a demonstration, then evolve offline (``context.ga``: 200 generations
    by default).

    ``mirror``: learn from the cases and their mirror images (:mod:`lfd_track.learning.mirror`).
    ``features``: the per-region inputs (:mod:`lfd_track.policy.features`), computed from the
    recorded histograms. ``shifted_views``: learn also from the shifted and turned views of
    every case (:mod:`lfd_track.demo.views`; mirrored too with ``mirror``). ``policy_kind``
    ``"elman-sigmoid"``: evolve an Elman network over the cases in order
    (:func:`~lfd_track.learning.elman.evolve_elman`; not with ``shifted_views``).
    """
    summary, demo, library, views, (x, a) = offline_cases(context)
    rng = np.random.default_rng(context.ga_seed)
    if context.policy_kind == "elman-sigmoid":
        result = evolve_elman(x, a, context.ga, rng, episodes=episodes(demo, context.mirror))
    else:
        result = evolve(x, a, context.ga, rng)
    controller = Controller.from_evolution(
        library,
        result,
        seed=context.ga_seed,
        memory=context.memory,
        features=context.features,
        policy_kind=context.policy_kind,
        frame_size=context.frame_size,
        map_geometry=context.map_geometry,
    )
    return learned_offline(
        context,
        summary,
        demo,
        controller,
        fitness_best=result.best_history.tolist(),
        fitness_mean=result.mean_history.tolist(),
        extra=views_record(views),
    )


def learn_paper(rep_dir: str | Path, **context: Any) -> Learned:
    """:func:`learn` with the context's fields as keywords (``demo_seed``, ``ga_seed``,
    ``preset``, ``human``, ``ga`` …; :class:`~lfd_track.methods.common.MethodContext`)."""
    return learn(MethodContext(Path(rep_dir), **context))
