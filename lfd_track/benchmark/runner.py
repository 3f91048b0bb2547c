"""The paper protocol on the simulated world (paper §4.2.5, §5).

One *repetition* is a fresh demonstration (new seed) → evolution → autonomous trials: by default 3
runs in each direction on the training track and 3 counter-clockwise + 3 clockwise laps on the
testing track, starting at corner 4. Repetitions run in a process pool; every random draw comes
from the repetition's own seed (spawned from the benchmark seed), so results are identical for a
given seed whatever the number of workers. A repetition whose demonstration cannot finish (the
scripted human still lost after its ``max_commands``:
:class:`~lfd_track.errors.DemonstrationUnfinished`) learns no controller: it is recorded as failed
(:attr:`RepetitionResult.failed`) and every trial it would have run is scored as a failure
(:data:`~lfd_track.benchmark.tables.NO_CONTROLLER`), while the other repetitions run as ever; so
is one whose map's calibration cannot converge (``geometry = "calibrated"``:
:class:`~lfd_track.errors.CalibrationFailed`); any other
exception is a fault and propagates. What a run does is a
:class:`~lfd_track.benchmark.config.BenchmarkConfig` (imported here too, with
:func:`~lfd_track.benchmark.config.config_dict`).
"""

from __future__ import annotations

import dataclasses
import os
import time
from collections.abc import Callable, Collection
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..envs.presets import Preset, load_preset
from ..envs.track_env import LfDTrackEnv
from ..errors import CalibrationFailed, DemonstrationUnfinished, LfdTrackError
from ..learning.result import check_int
from ..methods import Learned, Method, MethodContext, get_method
from ..methods.common import (
    SimulatedCalibration,
    calibration_for,
    drive_policy,
    effort_record,
    period_s,
)
from ..policy.controller import Controller
from ..teaching.loop import LoopCounts, Step
from ..teaching.observers import CallbackObserver, TrajectoryObserver
from ..world.track import load_track
from .config import (
    MAX_REPETITIONS,
    MAX_SEED,
    MAX_TRIALS_PER_DIRECTION,
    BenchmarkConfig,
    config_dict,
    settings_arguments,
)
from .loops import MAX_DRAWS_PER_LOOP, loop_draws, teacher_lap
from .tables import NO_CONTROLLER, TrialOutcome

__all__ = [
    "DIRECTIONS",
    "MAX_REPETITIONS",
    "MAX_SEED",
    "MAX_TRIALS_PER_DIRECTION",
    "MAX_WORKERS",
    "BenchmarkConfig",
    "ROOM_STREAM",
    "RepetitionResult",
    "check_demo_track",
    "check_test_tracks",
    "check_tracks",
    "check_workers",
    "config_dict",
    "learn_repetition",
    "repetition_preset",
    "repetition_seeds",
    "repetition_streams",
    "run_benchmark",
    "run_repetition",
    "run_trial",
    "run_trials",
    "settings_arguments",
    "trial_worlds",
    "trial_directions",
    "unfinished_effort",
]

#: (track, reverse, direction name in the tables), in the order trials are run.
DIRECTIONS: tuple[tuple[str, bool, str], ...] = (
    ("training", False, "direction_1"),
    ("training", True, "direction_2"),
    ("testing", False, "ccw"),
    ("testing", True, "cw"),
)

MAX_WORKERS = 1_024
"""Most worker processes of one benchmark."""


@dataclass
class RepetitionResult:
    """Everything one repetition produced."""

    index: int
    outcomes: list[TrialOutcome]
    demo: dict[str, Any]
    fitness_best: list[float]
    fitness_mean: list[float]
    training_accuracy: float | None
    """None when the repetition learned no controller (:attr:`failed`)."""
    timing_s: dict[str, float] = field(default_factory=dict)
    effort: dict[str, Any] = field(default_factory=dict)
    """Human commands, corrections, takeovers and driving seconds during learning (of a failed
    repetition: those of the loop that did not finish, empty when unknown)."""
    random_loops: dict[str, Any] = field(default_factory=dict)
    """The procedural loops drawn (``drawn``) and those the teacher could not lap
    (``excluded``: name and the teacher's outcome per direction); empty without them."""
    failed: str | None = None
    """Why the repetition learned no controller (e.g. "demonstration exceeded 1000 commands"),
    None when it learned one; its ``outcomes`` are then every trial it would have run, each an
    undriven :data:`~lfd_track.benchmark.tables.NO_CONTROLLER` failure, and ``demo`` and the
    fitness curves are empty."""
    calibration: dict[str, Any] = field(default_factory=dict)
    """With ``geometry = "calibrated"``: what the calibration before teaching measured
    (:meth:`~lfd_track.methods.common.SimulatedCalibration.record`); empty otherwise, and when
    it failed (:attr:`failed` says why)."""


def trial_directions(test_tracks: tuple[str, ...]) -> list[tuple[str, bool, str]]:
    """(track, reverse, direction) of every trial direction, in the order they are run.

    The training track's two directions, the testing track's (if listed), then each other loop
    counter-clockwise and clockwise: extra loops come last, so adding one leaves the random
    streams, and so the results, of the paper's directions unchanged.
    """
    directions = [d for d in DIRECTIONS if d[0] == "training" or "testing" in test_tracks]
    for track in test_tracks:
        if track != "testing":
            directions += [(track, False, "ccw"), (track, True, "cw")]
    return directions


def check_test_tracks(test_tracks: tuple[str, ...]) -> None:
    """Raise (a one-line ``LfdTrackError``/``ValueError``) unless every test track is a loop
    with corners."""
    for track in test_tracks:
        loaded = load_track(track)
        if not loaded.closed:
            raise ValueError(f"test track '{track}' is not a loop (laps need a closed track)")
        if not loaded.corners:
            raise ValueError(
                f"test track '{track}' has no corners (a lap is scored corner by corner)"
            )


def check_demo_track(track: str) -> None:
    """Raise a one-line error unless ``track`` loads (an open track, driven end to end and back,
    or a loop, driven a lap per leg: :mod:`lfd_track.demo.demonstrator`)."""
    load_track(track)


def check_tracks(config: BenchmarkConfig) -> None:
    """Raise a one-line error unless every track the run drives works with its preset.

    Loads the preset, checks the test tracks (:func:`check_test_tracks`) and the demonstration
    track (:func:`check_demo_track`; and the track a method's rounds drive, when it has one of its
    own), then builds, without painting its floor, the environment
    of every track the run drives (the demonstration track, the training track and each test
    loop, both ways): that applies the environment's own
    checks, among them that the ground texture the preset would paint around the track fits the
    renderer's cap (``MAX_TEXTURE_BYTES``, ``env._check_ground_fits``). So a track that cannot
    be driven fails in milliseconds, before anything is learned or written.
    """
    preset = load_preset(config.preset)
    check_test_tracks(config.test_tracks)
    check_demo_track(config.demo_track)
    drives = [(config.demo_track, False), (config.demo_track, True)]
    round_track = getattr(config.settings_of(), "round_track", None)
    if round_track is not None:  # hg-dagger's rounds on a track of their own
        check_demo_track(round_track)
        drives += [(round_track, False), (round_track, True)]
    drives += [(t, r) for t, r, _ in trial_directions(config.test_tracks)]
    for track, reverse in dict.fromkeys(drives):
        try:
            LfDTrackEnv(track=track, reverse=reverse, preset=preset).close()
        except LfdTrackError:
            raise
        except ValueError as exc:
            message = str(exc).strip().splitlines()[0] if str(exc).strip() else repr(exc)
            # A track given as a file is named in the message by its file, not only its name.
            named = f"'{track}'" in message
            raise LfdTrackError(message if named else f"{track}: {message}") from None


def check_workers(workers: int) -> None:
    """Raise ``ValueError`` unless ``workers`` is an integer in 1..MAX_WORKERS."""
    check_int("workers", workers, 1, MAX_WORKERS)


def repetition_seeds(seed: int, repetitions: int) -> list[int]:
    """One independent 63-bit seed per repetition, spawned from the benchmark seed."""
    children = np.random.SeedSequence(seed).spawn(repetitions)
    return [int(c.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1)) for c in children]


def repetition_streams(seed: int) -> tuple[int, int, int]:
    """(demonstration, learning, trials) seeds of the repetition with seed ``seed``."""
    rng = np.random.default_rng(seed)
    demo_seed, ga_seed, trial_seed = (int(x) for x in rng.integers(0, 2**62, size=3))
    return demo_seed, ga_seed, trial_seed


ROOM_STREAM = 0x726F6F6D
"""Spawn key of a repetition's room draw (``room = "per_repetition"``): a child of the
repetition's seed that no other stream of the repetition uses."""


def repetition_preset(config: BenchmarkConfig, seed: int) -> str | Preset:
    """The preset every env of the repetition with seed ``seed`` uses: ``config.preset`` itself,
    or, with ``room = "per_repetition"`` and a preset that has ``[randomization]``, one world
    drawn from it (:meth:`~lfd_track.envs.presets.Preset.sample`, from the repetition's own room
    stream :data:`ROOM_STREAM`) with its randomization removed, so no episode redraws it. A
    preset without randomization is returned as it is (it has one world either way)."""
    if config.room != "per_repetition":
        return config.preset
    preset = load_preset(config.preset)
    if not preset.randomized:
        return config.preset
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(ROOM_STREAM,)))
    return dataclasses.replace(preset.sample(rng), name=f"{preset.name}-room", randomization=())


def trial_worlds(trial_seed: int, test_tracks: tuple[str, ...]) -> list[tuple[str, bool, str, int]]:
    """(track, reverse, direction, world seed) of every trial direction, in the order they are
    run: each direction's floor is built once, from its own seed drawn from ``trial_seed``."""
    rng = np.random.default_rng(trial_seed)
    return [
        (track, reverse, direction, int(rng.integers(0, 2**62)))
        for track, reverse, direction in trial_directions(test_tracks)
    ]


def run_trial(
    env: LfDTrackEnv,
    controller: Controller,
    *,
    seed: int | None,
    on_step: Callable[[np.ndarray, np.ndarray, dict[str, Any]], None] | None = None,
    on_loop_step: Callable[[Step], None] | None = None,
) -> tuple[dict[str, Any], np.ndarray, int]:
    """Drive one autonomous episode; returns (last info, trajectory (N, 2), steps).

    An arrangement of the teaching loop: the controller's library (frozen, or learning from every
    frame when ``controller.learn``), the controller as the only commander.
    ``on_step(frame, road_values, info)`` sees each frame after its command was chosen;
    ``on_loop_step(step)`` sees the loop's whole :class:`Step` (its ``command`` included).
    """
    trajectory = TrajectoryObserver()
    observers: list[Any] = [trajectory]
    if on_step is not None:
        observers.append(
            CallbackObserver(lambda s: on_step(s.moment.frame, s.percept.values, s.moment.info))
        )
    if on_loop_step is not None:
        observers.append(CallbackObserver(on_loop_step))
    loop = drive_policy(env, controller, seed=seed, observers=observers)
    return loop.info, trajectory.array(), loop.counts.steps


def trial_outcome(
    track: str,
    env: LfDTrackEnv,
    direction: str,
    info: dict[str, Any],
    trajectory: np.ndarray,
    steps: int,
    repetition: int,
    trial: int,
) -> TrialOutcome:
    """The outcome of one trial on ``track`` (as the run names it; ``env`` drives it) from its
    last ``info`` (a run that neither succeeded nor failed ran out of steps: ``"timeout"``)."""
    failure = info["failure"]
    if not info["success"] and failure is None:
        failure = "timeout"
    return TrialOutcome(
        track=track,
        direction=direction,
        corner_order=tuple(c.label for c in env.track.corners),
        corners_reached=tuple(info["corners_reached"]),
        corners_negotiated=tuple(info["corners_negotiated"]),
        failure=failure,
        success=bool(info["success"]),
        repetition=repetition,
        trial=trial,
        steps=steps,
        trajectory=trajectory,
    )


def unlearned_outcome(
    track: str, env: LfDTrackEnv, direction: str, repetition: int, trial: int
) -> TrialOutcome:
    """The outcome of a trial on ``track`` (``env`` would drive it) that was never driven because
    its repetition learned no controller: a :data:`NO_CONTROLLER` failure, no corner reached,
    0 steps."""
    return TrialOutcome(
        track=track,
        direction=direction,
        corner_order=tuple(c.label for c in env.track.corners),
        corners_reached=(),
        corners_negotiated=(),
        failure=NO_CONTROLLER,
        success=False,
        repetition=repetition,
        trial=trial,
        steps=0,
    )


def run_trials(
    controller: Any | None,
    *,
    trial_seed: int,
    test_tracks: tuple[str, ...],
    trials_per_direction: int,
    preset: str | Preset,
    repetition: int = 0,
    tracks: Collection[str] | None = None,
    progress: Callable[[TrialOutcome], None] | None = None,
) -> list[TrialOutcome]:
    """The autonomous trials of one repetition: every direction of :func:`trial_worlds`, each
    ``trials_per_direction`` times, in order; returns their outcomes (trajectories included).

    ``controller`` is anything with ``perception()`` and ``commander()`` (a :class:`Controller`,
    or an evaluated policy, :mod:`lfd_track.benchmark.evaluate`); its state carries over from one
    trial to the next, as a controller's library does when it keeps learning. None: the
    repetition learned no controller, and every trial is an undriven :func:`unlearned_outcome`. ``tracks``, when
    given, runs only the directions of those tracks; the others' world seeds are still drawn, so
    a direction's trials do not depend on which other tracks run. ``progress(outcome)`` sees each
    trial as it ends.
    """
    outcomes: list[TrialOutcome] = []
    for track, reverse, direction, env_seed in trial_worlds(trial_seed, test_tracks):
        if tracks is not None and track not in tracks:
            continue
        env = LfDTrackEnv(track=track, reverse=reverse, preset=preset)
        for trial in range(trials_per_direction):
            if controller is None:
                outcomes.append(unlearned_outcome(track, env, direction, repetition, trial))
                continue
            # The floor is built once per direction (seeded); later trials redraw the rover,
            # exposure and noise from the env's own stream.
            info, trajectory, steps = run_trial(
                env, controller, seed=env_seed if trial == 0 else None
            )
            outcomes.append(
                trial_outcome(track, env, direction, info, trajectory, steps, repetition, trial)
            )
            if progress is not None:
                progress(outcomes[-1])
        env.close()
    return outcomes


def run_loop_trials(
    controller: Any | None,
    *,
    trial_seed: int,
    config: BenchmarkConfig,
    repetition: int = 0,
    preset: str | Preset | None = None,
) -> tuple[list[TrialOutcome], dict[str, Any]]:
    """The repetition's laps of ``config.random_loops`` procedural loops (:mod:`.loops`): loops
    drawn in order from the repetition's stream, each admitted once the teacher laps it both
    ways in the worlds of its two directions, then lapped once each way by ``controller`` (None:
    no controller was learned, each lap is an undriven :func:`unlearned_outcome`; the draw is
    the same). ``preset``: the repetition's (:func:`repetition_preset`; default
    ``config.preset``). Returns the outcomes and the draw's record (``drawn``, ``excluded``)."""
    world_preset = config.preset if preset is None else preset
    outcomes: list[TrialOutcome] = []
    excluded: list[dict[str, Any]] = []
    drawn = admitted = 0
    draws = loop_draws(trial_seed, config.random_split)
    while admitted < config.random_loops:
        if drawn >= MAX_DRAWS_PER_LOOP * config.random_loops:
            raise LfdTrackError(
                f"the teacher lapped {admitted} of {drawn} procedural loops drawn from"
                f" '{config.random_split}' in preset '{config.preset}' both ways: too few to score"
            )
        name, worlds = next(draws)
        drawn += 1
        envs = {
            direction: (LfDTrackEnv(track=name, reverse=reverse, preset=world_preset), world)
            for reverse, direction, world in ((False, "ccw", worlds[0]), (True, "cw", worlds[1]))
        }
        teacher = {direction: teacher_lap(env, world) for direction, (env, world) in envs.items()}
        if all(t["success"] for t in teacher.values()):
            admitted += 1
            for direction, (env, world) in envs.items():
                if controller is None:
                    outcomes.append(unlearned_outcome(name, env, direction, repetition, 0))
                    continue
                info, trajectory, steps = run_trial(env, controller, seed=world)
                outcomes.append(
                    trial_outcome(name, env, direction, info, trajectory, steps, repetition, 0)
                )
        else:
            excluded.append({"track": name, "teacher": teacher})
        for env, _ in envs.values():
            env.close()
    return outcomes, {"drawn": drawn, "excluded": excluded}


def learn_repetition(
    config: BenchmarkConfig,
    rep_dir: Path,
    *,
    demo_seed: int,
    ga_seed: int,
    method: Method | None = None,
    preset: str | Preset | None = None,
    calibration: SimulatedCalibration | None = None,
) -> Learned:
    """Learn one repetition's controller by ``config.method`` (its registry entry, or
    ``method``) under ``preset`` (the repetition's, :func:`repetition_preset`; default
    ``config.preset``); its files go to ``rep_dir``. ``calibration``: the repetition's, which a
    ``geometry = "calibrated"`` map assumes."""
    method = get_method(config.method) if method is None else method
    context = MethodContext(
        rep_dir,
        demo_seed=demo_seed,
        ga_seed=ga_seed,
        preset=config.preset if preset is None else preset,
        human=config.human,
        memory=config.memory,
        mirror=config.mirror,
        track=config.demo_track,
        features=config.features,
        shifted_views=config.shifted_views,
        policy_kind=config.policy_kind,
        ga=config.ga,
        bc=config.bc,
        cmaes=config.cmaes,
        settings=config.settings_of(method),
        extra_cases=config.extra_cases,
        calibration=calibration,
    )
    return method.learn(context)


def run_repetition(
    index: int, seed: int, config: BenchmarkConfig, work_dir: str, method: Method | None = None
) -> RepetitionResult:
    """Demonstrate, evolve and test once; artefacts go to ``work_dir/rep_<index>/``.

    ``method``: the registry entry of ``config.method`` (default: looked up here; a worker
    process is given it, so a method registered outside the package runs there too when its
    functions can be imported). A demonstration that cannot finish
    (:class:`~lfd_track.errors.DemonstrationUnfinished`), or a map's calibration that cannot
    converge (:class:`~lfd_track.errors.CalibrationFailed`, "calibration failed: ..."), makes a
    failed repetition (:attr:`RepetitionResult.failed`, no ``controller.json``); any other
    exception propagates."""
    import cv2

    cv2.setNumThreads(1)  # one repetition per core; OpenCV's own threads would only contend
    demo_seed, ga_seed, trial_seed = repetition_streams(seed)
    preset = repetition_preset(config, seed)
    rep_dir = Path(work_dir) / f"rep_{index:02d}"
    rep_dir.mkdir(parents=True, exist_ok=True)
    timing: dict[str, float] = {}

    t0 = time.perf_counter()
    learned: Learned | None = None
    controller: Controller | None = None
    calibration: SimulatedCalibration | None = None
    try:
        # Before teaching, in the repetition's world (with room = "per_repetition", its room);
        # passed on only when there is one, so a learner standing in need not know of it.
        calibration = calibration_for(config.memory, preset, seed)
        extra = {} if calibration is None else {"calibration": calibration}
        learned = learn_repetition(
            config,
            rep_dir,
            demo_seed=demo_seed,
            ga_seed=ga_seed,
            method=method,
            preset=preset,
            **extra,
        )
    except CalibrationFailed as exc:  # the map cannot know its robot: a failed repetition
        failed: str | None = f"calibration failed: {exc}"
        effort = {}
    except DemonstrationUnfinished as exc:  # the teacher got lost: a failed repetition
        failed = str(exc)
        effort = unfinished_effort(exc, preset)
    else:
        failed, effort = None, learned.effort
        controller = learned.controller
        controller.learn = config.keep_learning
        controller.save(rep_dir / "controller.json")
    timing["learning"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    outcomes = run_trials(
        controller,
        trial_seed=trial_seed,
        test_tracks=config.test_tracks,
        trials_per_direction=config.trials_per_direction,
        preset=preset,
        repetition=index,
    )
    loop_record: dict[str, Any] = {}
    if config.random_loops:
        loop_outcomes, loop_record = run_loop_trials(
            controller, trial_seed=trial_seed, config=config, repetition=index, preset=preset
        )
        outcomes += loop_outcomes
    timing["trials"] = time.perf_counter() - t0
    return RepetitionResult(
        index=index,
        outcomes=outcomes,
        demo={} if learned is None else learned.demo,
        fitness_best=[] if learned is None else learned.fitness_best,
        fitness_mean=[] if learned is None else learned.fitness_mean,
        training_accuracy=None if learned is None else learned.training_accuracy,
        timing_s=timing,
        effort=effort,
        random_loops=loop_record,
        failed=failed,
        calibration={} if calibration is None else calibration.record(),
    )


def unfinished_effort(exc: DemonstrationUnfinished, preset: str | Preset) -> dict[str, Any]:
    """The human effort and robot driving of the loop that did not finish (the effort record
    every method writes, from the counts ``exc`` carries); empty when it carries none."""
    if not isinstance(exc.counts, LoopCounts):
        return {}
    return effort_record(period_s(preset), counts=exc.counts)


def _run_packed(args: tuple[int, int, BenchmarkConfig, str, Method]) -> RepetitionResult:
    return run_repetition(*args)


def run_benchmark(
    config: BenchmarkConfig,
    work_dir: str | Path,
    *,
    workers: int = 1,
    progress: Callable[[RepetitionResult], None] | None = None,
) -> list[RepetitionResult]:
    """Run every repetition (in ``workers`` processes) and return them in repetition order.

    Every track is checked against the preset first (:func:`check_tracks`), so a track that
    cannot be driven fails before anything is written to ``work_dir``.
    """
    check_workers(workers)
    check_tracks(config)
    seeds = repetition_seeds(config.seed, config.repetitions)
    method = get_method(config.method)
    jobs = [(i, s, config, str(work_dir), method) for i, s in enumerate(seeds)]
    results: list[RepetitionResult] = []
    if workers == 1:
        for job in jobs:
            results.append(_run_packed(job))
            if progress:
                progress(results[-1])
    else:
        # Spawned workers start clean (no inherited OpenCV/pymunk state).
        import multiprocessing

        ctx = multiprocessing.get_context("spawn" if os.name != "posix" else "forkserver")
        with ProcessPoolExecutor(max_workers=min(workers, len(jobs)), mp_context=ctx) as pool:
            for result in pool.map(_run_packed, jobs):
                results.append(result)
                if progress:
                    progress(result)
    return sorted(results, key=lambda r: r.index)
