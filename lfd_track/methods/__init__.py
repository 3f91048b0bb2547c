"""How a repetition learns its controller: the paper's offline pipeline, or interactive methods.

Every method is one module with a function ``learn(context) -> Learned`` over one
:class:`MethodContext` (seeds, preset, human, the policy's inputs, the track, the learners'
settings and its own), plus one :class:`Method` entry in the registry below, which the
benchmark, the study files and the command line read. Every method is an arrangement of the
teaching loop (:mod:`lfd_track.teaching`) and ends with a controller plus a record of the
human's effort, counted the same way for every method (:func:`effort_record`).

Methods:

* ``paper`` — demonstration, then the GA offline (the paper, §4.2.5; :mod:`.paper`).
* ``online`` — the GA (or, with ``learner = "bc"``, backprop) learns while the scripted human
  demonstrates; the policy takes over when it agrees, the human takes control back by the
  intervention rule (:mod:`.online`).
* ``hg-dagger`` — the paper's demonstration and GA, then rounds of autonomous runs with the
  human intervening; the GA re-run on all cases after each round (:mod:`.hg_dagger`; with
  ``learner = "bc"`` backprop in the GA's place).
* ``bc`` / ``cma-es`` — the paper's demonstration, then the same network fitted by backprop or
  by CMA-ES instead of the GA (:mod:`.baseline`).
* ``dagger`` — classic DAgger: rounds of runs in which the human labels every visited state
  (:mod:`.dagger`).
* ``direct`` / ``mu-plus-one`` — no teacher: the network evolved on the robot on progress along
  the track, from the start of the track each time (``direct``) or on board one robot that is
  never reset, put back by hand when it leaves the felt ((μ+1)-ONLINE); the road library is the
  repetition's demonstration's, whose cases are not learned from (:mod:`.evolution`).

"The training track" of a method is the paper's unless the benchmark gives another track
(``BenchmarkConfig.demo_track``, open or a loop): the human then demonstrates, and the rounds
drive, there.

Adding a method is one module with its ``learn`` (and settings class, if any) plus one
``register_method(Method(...))`` (``docs/learning-api.md``, "Adding a method").
"""

from __future__ import annotations

from ..learning.bc import BCConfig
from ..learning.cmaes import CMAESConfig
from ..learning.direct import DirectConfig, MuPlusOneConfig
from . import baseline, dagger, evolution, hg_dagger, online, paper
from .baseline import learn_baseline
from .common import Learned, MethodContext, effort_record, recording_metadata
from .dagger import DaggerConfig, learn_dagger
from .evolution import learn_evolved
from .hg_dagger import HGDaggerConfig, learn_hg_dagger
from .online import OnlineConfig, learn_online
from .paper import learn_paper
from .registry import (
    Method,
    MethodFlags,
    get_method,
    method_names,
    method_of_table,
    methods,
    register_method,
    registered,
    unregister_method,
)
from .takeover import TakeoverConfig

ELMAN = ("mlp-sigmoid", "elman-sigmoid")

register_method(
    Method(
        "paper",
        paper.learn,
        takes_views=True,
        policy_kinds=ELMAN,
        summary="demonstrate, then evolve",
    )
)
register_method(
    Method(
        "online",
        online.learn,
        OnlineConfig,
        summary="learn while demonstrating, policy takes over, human corrects; see"
        " --online-learner",
        flags=MethodFlags(online.add_flags, online.flags_given, online.settings_from_flags),
    )
)
register_method(
    Method(
        "hg-dagger",
        hg_dagger.learn,
        HGDaggerConfig,
        summary="rounds of runs with interventions; see --hg-dagger-learner",
        flags=MethodFlags(
            hg_dagger.add_flags, hg_dagger.flags_given, hg_dagger.settings_from_flags
        ),
    )
)
register_method(
    Method(
        "bc",
        baseline.learn_bc,
        BCConfig,
        takes_views=True,
        policy_kinds=ELMAN,
        summary="demonstrate, then backprop",
    )
)
register_method(
    Method(
        "cma-es",
        baseline.learn_cmaes,
        CMAESConfig,
        table="cmaes",
        takes_views=True,
        summary="demonstrate, then CMA-ES",
    )
)
register_method(
    Method(
        "dagger",
        dagger.learn,
        DaggerConfig,
        summary="rounds of runs where the human labels every visited state, noise-free; the"
        " learner re-fitted on all cases; see --dagger-learner, --hidden, --label-noise",
        flags=MethodFlags(dagger.add_flags, dagger.flags_given, dagger.settings_from_flags),
    )
)
register_method(
    Method(
        "direct",
        evolution.learn_direct,
        DirectConfig,
        summary="no teacher: the GA evolves the network on progress along the track, every drive"
        " from the start; see --direct-generations",
        flags=evolution.DIRECT_FLAGS.method_flags(),
    )
)
register_method(
    Method(
        "mu-plus-one",
        evolution.learn_mu_plus_one,
        MuPlusOneConfig,
        summary="no teacher: (mu+1)-ONLINE evolves on board one robot never reset, put back by"
        " hand when it leaves the felt; see --mu-plus-one-evaluations",
        flags=evolution.MU_PLUS_ONE_FLAGS.method_flags(),
    )
)

__all__ = [
    "DaggerConfig",
    "DirectConfig",
    "HGDaggerConfig",
    "Learned",
    "Method",
    "MethodContext",
    "MethodFlags",
    "MuPlusOneConfig",
    "OnlineConfig",
    "TakeoverConfig",
    "effort_record",
    "get_method",
    "learn_baseline",
    "learn_dagger",
    "learn_evolved",
    "learn_hg_dagger",
    "learn_online",
    "learn_paper",
    "method_names",
    "method_of_table",
    "methods",
    "recording_metadata",
    "register_method",
    "registered",
    "unregister_method",
]
