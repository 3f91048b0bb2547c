"""The ``bc`` and ``cma-es`` methods: the paper's demonstration, then the same network fitted to
its cases by backprop (:func:`~lfd_track.learning.bc.fit_bc`) or by CMA-ES on Algorithm 3
(:func:`~lfd_track.learning.cmaes.fit_cmaes`) instead of the GA."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..learning.bc import BCConfig
from ..learning.cmaes import CMAESConfig
from ..learning.elman import fit_bc_elman
from ..learning.learners import learner_for
from ..learning.result import LearnerFit
from ..policy.controller import Controller
from ..policy.mlp import N_HIDDEN
from ..vision.road_library import RoadLibrary
from .common import Learned, MethodContext
from .offline import episodes, learned_offline, offline_cases, views_record
from .watched import choose_by_watching


def learn_bc(context: MethodContext) -> Learned:
    """The ``bc`` method: backprop with ``context.bc`` (``policy_kind`` ``"elman-sigmoid"``:
    an Elman network by backpropagation through time,
    :func:`~lfd_track.learning.elman.fit_bc_elman`)."""
    return fit_after_demonstration(context, context.bc)


def learn_cmaes(context: MethodContext) -> Learned:
    """The ``cma-es`` method: CMA-ES with ``context.cmaes``."""
    return fit_after_demonstration(context, context.cmaes)


def fit_after_demonstration(context: MethodContext, learner: BCConfig | CMAESConfig) -> Learned:
    """The paper's demonstration, then ``learner`` instead of the GA (same cases, same seed;
    ``shifted_views`` as for the ``paper`` method). An Elman network is trained by BC only."""
    elman = context.policy_kind == "elman-sigmoid"
    if elman and not isinstance(learner, BCConfig):
        raise ValueError("an Elman network is trained by the GA or by backprop, not CMA-ES")
    summary, demo, library, views, (x, a) = offline_cases(context)
    trainer = learner_for(learner)
    rng = np.random.default_rng(context.ga_seed)
    if elman and isinstance(learner, BCConfig):
        result = fit_bc_elman(x, a, learner, rng, episodes=episodes(demo, context.mirror))
    else:
        result = trainer.fit(x, a, rng)
    extra = {"learner": result.learner, **views_record(views)}
    counts, effort = None, None
    if isinstance(learner, BCConfig) and learner.watched_fits > 1:
        watched = choose_by_watching(
            context,
            learner.watched_fits,
            lambda: trainer.fit(x, a, rng),
            lambda fit: controller_of_fit(context, library, fit, learner),
            result,
        )
        result, controller, counts = watched.fit, watched.controller, watched.counts
        extra["watched"] = watched.record()
        effort = {"watched_laps": watched.laps}
    else:
        controller = controller_of_fit(context, library, result, learner)
    return learned_offline(
        context,
        summary,
        demo,
        controller,
        fitness_best=result.history.tolist(),
        fitness_mean=[],
        extra=extra,
        counts=counts,
        effort=effort,
    )


def controller_of_fit(
    context: MethodContext,
    library: RoadLibrary,
    fit: LearnerFit,
    learner: BCConfig | CMAESConfig,
) -> Controller:
    """The controller of ``fit``, made by the learner whose settings are ``learner`` (backprop or
    CMA-ES), driving with ``library`` and the context's inputs: what the ``bc`` and ``cma-es``
    methods write, and what ``hg-dagger`` and ``online`` with learner ``"bc"`` relabel as
    theirs."""
    return Controller(
        library,
        fit.weights,
        bias=learner.bias,
        learner=learner_for(learner).name,
        learner_config=learner.to_dict(),
        seed=context.ga_seed,
        fitness_history=fit.history.tolist(),
        memory=context.memory,
        features=context.features,
        policy_kind=context.policy_kind,
        frame_size=context.frame_size,
        map_geometry=context.map_geometry,
        hidden=learner.hidden if isinstance(learner, BCConfig) else N_HIDDEN,
    )


def learn_baseline(
    rep_dir: str | Path, *, learner: BCConfig | CMAESConfig, **context: Any
) -> Learned:
    """The ``bc`` or ``cma-es`` method by the type of ``learner``, with the context's fields as
    keywords (:class:`~lfd_track.methods.common.MethodContext`)."""
    if isinstance(learner, BCConfig):
        return learn_bc(MethodContext(Path(rep_dir), bc=learner, settings=learner, **context))
    return learn_cmaes(MethodContext(Path(rep_dir), cmaes=learner, settings=learner, **context))
