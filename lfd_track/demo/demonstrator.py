"""The paper's demonstration protocol (§4.2.5) on the simulated world, as a teaching loop.

The scripted human (:mod:`lfd_track.teaching.scripted`) drives the protocol: 10 commands that only
build the road library, then the training track from the right end to the left end and back,
twice, with alternating turn-arounds. Every frame goes through the loop's perception (library
learning from the safe box, then road values of the 40 regions); each command after the first 10
is recorded with the road values computed at that moment.

On a loop (a closed track) the same protocol drives laps: a leg is one lap, from the loop's
start round to ``stop_before_end_m`` short of it, then the human turns round and drives the next
leg the other way (``HumanConfig.legs`` legs in all; 2 is a lap each way). It lets a
demonstration show corners the training track lacks (sharp corners, turns both ways).

*Careful training*: the library learns only while the safe box is on the felt, as an operator
watching the phone's screen would; with ``careful=False`` it learns from every frame and the
library is poisoned with carpet (the paper's §6 warning).

Calibration targets of the default protocol (checked in ``tests/demo/test_demonstrator.py`` and
reported by the benchmark): 120–200 cases, at least 40 library models, forward the majority of
commands, as many left as right turn-arounds, and no library update from a frame whose safe box is
off the felt.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset import load_demonstration
from ..dataset.recording import recording_writer
from ..envs.presets import Preset
from ..envs.track_env import LfDTrackEnv
from ..errors import DemonstrationUnfinished
from ..policy.map_geometry import MapGeometry
from ..policy.memory import MemoryConfig
from ..teaching.arbiter import Arbiter
from ..teaching.loop import TeachingLoop
from ..teaching.observers import CallbackObserver, LearningTally, Recorder
from ..teaching.perception import Perception
from ..teaching.scripted import (
    PHASE_DRIVE,
    PHASE_LIBRARY_ONLY,
    PHASE_TURNAROUND,
    HumanConfig,
    ProtocolHuman,
    ScriptedHuman,
)
from ..vision.road_library import RoadLibrary
from ..world.track import load_track
from .views import PredecessorViews, ViewCases

__all__ = [
    "PHASE_DRIVE",
    "PHASE_LIBRARY_ONLY",
    "PHASE_TURNAROUND",
    "DemonstrationSummary",
    "HumanConfig",
    "ScriptedHuman",
    "run_demonstration",
]


@dataclass(frozen=True)
class DemonstrationSummary:
    """What a demonstration produced (the cases themselves are in the file)."""

    path: str
    n_cases: int
    counts: dict[str, int]
    turnarounds: tuple[str, ...]
    library_models: int
    library_types: int
    learned_frames: int
    off_felt_frames: int
    learned_off_felt: int
    commands: int


def protocol_human(
    track: str, human: HumanConfig, rng: np.random.Generator, **kwargs: Any
) -> ProtocolHuman:
    """The scripted human for the demonstration protocol on ``track`` (open: end to end and
    back; a loop: a lap per leg, alternating directions)."""
    return ProtocolHuman((load_track(track), load_track(track, reverse=True)), human, rng, **kwargs)


def run_demonstration(
    out: str | Path,
    *,
    seed: int,
    track: str = "training",
    preset: str | Preset = "paper",
    human: HumanConfig | None = None,
    library_factory: Callable[[], RoadLibrary] = RoadLibrary,
    fsync: bool = True,
    overwrite: bool = False,
    progress: Callable[[int], None] | None = None,
    memory: MemoryConfig | None = None,
    frames: Callable[[int, np.ndarray], None] | None = None,
    views: ViewCases | None = None,
    map_geometry: MapGeometry | None = None,
) -> DemonstrationSummary:
    """Record one demonstration on ``track`` to the file ``out`` and return a summary.

    The file is written case by case (crash-safe); the record-time road library is stored in its
    footer. ``progress`` is called with the number of commands given so far; ``human`` None
    means the default :class:`HumanConfig`. ``memory``: the policy's memory inputs, recorded
    with every case (none by default). ``frames``, if given, is called with the step index and
    the camera frame of every recorded case (the frames themselves are not recorded). ``views``,
    if given, receives the shifted and turned views of every case (:mod:`lfd_track.demo.views`;
    not recorded); the demonstration itself runs exactly as without them. ``map_geometry``: the
    camera and per-command motion the teacher's ``fresh_felt`` map assumes, recorded in the
    file's metadata (the controller learned from it must assume the same, e.g. a calibration's:
    ``geometry = "calibrated"``); None: the world's (:meth:`MapGeometry.from_preset` of the
    env's preset), not recorded.

    A protocol that has not ended after ``human.max_commands`` commands (the human is lost)
    raises :class:`~lfd_track.errors.DemonstrationUnfinished` ("demonstration exceeded N
    commands", with the loop's counts); the file is then incomplete.
    """
    human = human or HumanConfig()
    rng = np.random.default_rng(seed)
    env_seed = int(rng.integers(2**31 - 1))
    env = LfDTrackEnv(track=track, preset=preset, max_steps=10**9, continue_after_end=True)
    person = protocol_human(track, human, rng, memory=memory)
    library = library_factory()
    metadata: dict[str, Any] = {
        "kind": "simulated",
        "track": track,
        "seed": seed,
        "env_seed": env_seed,
        "preset": preset if isinstance(preset, str) else preset.name,
        "human": dataclasses.asdict(human),
        "bins": library.bins,
    }
    if map_geometry is not None:  # read back by evolve (only then: other files stay as they were)
        metadata["map_geometry"] = map_geometry.to_dict()
    perception = Perception(
        library,
        "careful" if human.careful else "always",
        memory,
        geometry=MapGeometry.from_preset(env.base_preset) if map_geometry is None else map_geometry,
    )
    tally = LearningTally()
    with recording_writer(out, metadata, perception, fsync=fsync, overwrite=overwrite) as writer:
        observers: list[Any] = [
            tally,
            Recorder(
                writer,
                lambda step: {
                    "pose": step.moment.pose,
                    "progress_m": person.progress_m,
                    "phase": person.phase,
                    "step": step.moment.step,
                },
            ),
        ]
        if progress is not None:
            observers.append(CallbackObserver(lambda step: progress(loop.counts.steps)))
        if frames is not None:
            observers.append(
                CallbackObserver(
                    lambda step: (
                        frames(step.moment.step, step.moment.frame) if step.is_case else None
                    )
                )
            )
        if views is not None:
            # Its own stream (the seed's second child), so the demonstration's draws do not move.
            view_rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(2)[1])
            observers.append(PredecessorViews(env, perception, view_rng, views))
        loop = TeachingLoop(
            env,
            perception,
            Arbiter("human"),
            human=person,
            observers=observers,
            stop_on_episode_end=False,  # the human steers back; the protocol decides the end
        )
        loop.reset(seed=env_seed)
        try:
            loop.run(max_steps=human.max_commands)
        except DemonstrationUnfinished as exc:  # the human got lost; any other error propagates
            env.close()
            raise DemonstrationUnfinished(
                f"demonstration exceeded {human.max_commands} commands", exc.counts
            ) from None
        commands = loop.counts.steps
        writer.close(
            {
                "road_library": library.to_dict(),
                "turnarounds": person.turnarounds,
                "library_models": library.n_models,
                "library_types": library.n_types,
                "learned_frames": tally.learned,
                "off_felt_frames": tally.off_felt,
                "learned_off_felt": tally.learned_off_felt,
                "commands": commands,
            }
        )
    env.close()
    demo = load_demonstration(out)
    return DemonstrationSummary(
        path=str(out),
        n_cases=demo.n_cases,
        counts=demo.command_counts,
        turnarounds=tuple(person.turnarounds),
        library_models=library.n_models,
        library_types=library.n_types,
        learned_frames=tally.learned,
        off_felt_frames=tally.off_felt,
        learned_off_felt=tally.learned_off_felt,
        commands=commands,
    )
