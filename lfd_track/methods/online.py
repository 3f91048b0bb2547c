"""The ``online`` method: the GA learns while the scripted human demonstrates; the policy takes
over when it agrees, and the human takes control back by the intervention rule.

The GA runs ``generations_per_case`` ask/tell generations per new case while the scripted human
demonstrates; once the policy agreed with the human on at least ``threshold`` of the last
``window`` commands it drives, and the human watches, taking control back by the intervention
rule (:class:`~lfd_track.teaching.scripted.InterventionConfig`); corrections are flagged cases
and learned like the rest. The controller is the best individual of the run.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset.recording import recording_writer
from ..demo.demonstrator import protocol_human
from ..learning.fitness import training_accuracy
from ..learning.ga import ga_rescore, ga_result
from ..policy.controller import Controller
from ..teaching.arbiter import Arbiter
from ..teaching.commanders import PolicyCommander
from ..teaching.learner_feed import GALearnerFeed
from ..teaching.loop import TeachingLoop
from ..teaching.observers import LearningTally, Recorder
from ..teaching.perception import Perception
from ..vision.road_library import RoadLibrary
from . import common
from .common import Learned, MethodContext, effort_record, recording_metadata, training_set
from .takeover import TakeoverConfig


@dataclass(frozen=True)
class OnlineConfig(TakeoverConfig):
    """Settings of the ``online`` method (evolution during the demonstration, with takeover)."""

    settings_name = "online"

    generations_per_case: int = 2
    """GA generations (ask/tell, population re-scored on all cases so far) after each new case
    (1..10 000)."""

    def __post_init__(self) -> None:
        super().__post_init__()
        self._check_count("generations_per_case", 10_000)


def learn(context: MethodContext) -> Learned:
    """Demonstrate on ``context.track`` while the GA learns; the policy takes over when it agrees.

    The protocol, the human's random stream and the env seed are the paper's (same
    ``demo_seed``); the cases, including flagged corrections, are written to
    ``rep_dir/demonstration.lfdemo`` (the footer lists the correction case indices).
    """
    online: OnlineConfig = context.settings
    ga, human, memory, features = context.ga, context.human, context.memory, context.features
    rng = np.random.default_rng(context.demo_seed)
    env_seed = int(rng.integers(2**31 - 1))
    env = common.track_env(context, max_steps=10**9, continue_after_end=True)
    person = protocol_human(
        context.track,
        human,
        rng,
        intervention=online.intervention,
        rover=env.preset.rover,
        memory=memory,
    )
    library = RoadLibrary()
    perception = Perception(
        library,
        "careful" if human.careful else "always",
        memory,
        features,
        geometry=context.map_geometry,
    )
    policy = PolicyCommander(None)
    feed = GALearnerFeed(
        ga,
        np.random.default_rng(context.ga_seed),
        online.generations_per_case,
        policy,
        perception.n_inputs,
        training_set=lambda x, a: training_set(context, x, a),
    )
    preset = context.preset
    metadata = recording_metadata(
        "online",
        library,
        track=context.track,
        seed=context.demo_seed,
        env_seed=env_seed,
        preset=preset if isinstance(preset, str) else preset.name,
        human=dataclasses.asdict(human),
        online=online.to_dict(),
    )
    path = context.rep_dir / "demonstration.lfdemo"
    tally = LearningTally()
    with recording_writer(path, metadata, perception, fsync=False, overwrite=True) as w:
        recorder = Recorder(
            w,
            lambda step: {
                "pose": step.moment.pose,
                "progress_m": person.progress_m,
                "phase": "correction" if step.decision.correction else person.phase,
                "step": step.moment.step,
            },
        )
        loop = TeachingLoop(
            env,
            perception,
            Arbiter("takeover", window=online.window, threshold=online.threshold),
            human=person,
            policy=policy,
            observers=[recorder, feed, tally],
            stop_on_episode_end=False,
        )
        loop.reset(seed=env_seed)
        loop.run(max_steps=human.max_commands)
        x, a = feed.cases.arrays()
        state = ga_rescore(feed.state, *feed.training_set(x, a), ga)  # the best on every case
        corrections = [i for i, c in enumerate(feed.cases.corrections) if c]
        w.close(
            {
                "road_library": library.to_dict(),
                "turnarounds": person.turnarounds,
                "library_models": library.n_models,
                "library_types": library.n_types,
                "commands": loop.counts.steps,
                "correction_cases": corrections,
                "interventions": dict(person.interventions),
            }
        )
    env.close()
    result = ga_result(state, ga, feed.rng_state)
    evolved = Controller.from_evolution(
        library,
        result,
        seed=context.ga_seed,
        memory=memory,
        features=features,
        frame_size=context.frame_size,
        map_geometry=context.map_geometry,
    )
    controller = evolved.relabelled("online", {**online.to_dict(), "ga": ga.to_dict()})
    counts = np.bincount(a, minlength=3)
    return Learned(
        controller=controller,
        demo={
            "cases": int(len(a)),
            "counts": {"forward": int(counts[0]), "left": int(counts[1]), "right": int(counts[2])},
            "turnarounds": list(person.turnarounds),
            "library_models": library.n_models,
            "library_types": library.n_types,
            "learned_off_felt": tally.learned_off_felt,
            "off_felt_frames": tally.off_felt,
            "correction_cases": len(corrections),
            "interventions": dict(person.interventions),
            "generations": state.generation,
        },
        fitness_best=list(state.best_history),
        fitness_mean=list(state.mean_history),
        training_accuracy=training_accuracy(state.best_weights, x, a),
        effort=effort_record(float(env.preset.rover.control_period_s), counts=loop.counts),
    )


def learn_online(rep_dir: str | Path, *, online: OnlineConfig, **context: Any) -> Learned:
    """:func:`learn` with the settings ``online`` and the context's fields as keywords
    (:class:`~lfd_track.methods.common.MethodContext`)."""
    return learn(MethodContext(Path(rep_dir), settings=online, **context))
