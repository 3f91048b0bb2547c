"""What every learning method shares: the context it learns in, what it returns, and the records
every method writes the same way (human effort, recording metadata, the demonstration's summary).

A method is a function ``learn(context: MethodContext) -> Learned``. The context holds what the
benchmark decides for a repetition (its seeds, preset, human, the policy's inputs, the track to
demonstrate on, the learners' settings, the map's geometry) and the method's own settings; the
method records what it needs under ``context.rep_dir`` and returns the controller with its
records.

A ``fresh_felt`` map with ``geometry = "calibrated"`` assumes the world's camera and the motion
per command that a calibration of the simulated rover measures in the world the policy is taught
in, before teaching (:func:`simulated_calibration`, the routine ``lfd-track hardware calibrate``
runs on a robot); the demonstration's map and the controller's both use it
(:attr:`MethodContext.map_geometry`).

Human effort (``Learned.effort``), counted the same way for every method (:func:`effort_record`):

* ``commands`` — commands the human gave (demonstration, library-only ones included, and
  corrections / interventions; for ``dagger`` every label, executed or not);
* ``corrections`` — times the human took control back from a driving policy;
* ``takeovers`` — times the policy took control;
* ``learning_drive_s`` — simulated seconds the robot drove while learning (whoever drove);
* ``autonomous_drive_s`` — of those, the seconds the policy drove;
* ``put_backs`` — times a person put the robot back on the felt by hand (``mu-plus-one``; 0 for
  every method whose robot is reset by the simulator or steered back by the human).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..dataset import Demonstration, load_demonstration
from ..demo.demonstrator import DemonstrationSummary, HumanConfig, run_demonstration
from ..demo.views import ViewCases
from ..envs.presets import Preset, load_preset
from ..envs.track_env import LfDTrackEnv
from ..hardware.profile import Calibration
from ..learning.bc import BCConfig
from ..learning.cmaes import CMAESConfig
from ..learning.ga import GAConfig
from ..learning.mirror import with_mirrored
from ..policy.controller import Controller
from ..policy.features import DEFAULT_FEATURES
from ..policy.map_geometry import MapGeometry
from ..policy.memory import FreshFeltConfig, MemoryConfig
from ..teaching.arbiter import Arbiter
from ..teaching.loop import LoopCounts, TeachingLoop
from ..teaching.observers import Observer
from ..vision.road_library import RoadLibrary

CALIBRATION_STREAM = 0x63616C69
"""Spawn key of a repetition's calibration stream (``geometry = "calibrated"``): a child of the
repetition's seed that no other stream of the repetition uses, so calibrating moves no other
draw."""


def calibrates(memory: MemoryConfig | None) -> bool:
    """Whether ``memory`` is a ``fresh_felt`` map whose motion comes from a calibration
    (``geometry = "calibrated"``)."""
    return isinstance(memory, FreshFeltConfig) and memory.geometry == "calibrated"


@dataclass(frozen=True)
class SimulatedCalibration:
    """What a calibration of the simulated rover measured before teaching, and the map geometry
    it gives (:func:`simulated_calibration`)."""

    geometry: MapGeometry
    """The map's geometry: the world's camera (as ``geometry = "world"``) with the measured
    forward step and pivot."""
    calibration: Calibration
    """The measurement: every run's per-command motion (medians and spreads derived)."""
    true_step_m: float
    """[m] the forward step the world calibrated in defines (forward speed x control period)."""
    true_pivot_deg: float
    """[deg] the pivot it defines (pivot rate x control period)."""

    def record(self) -> dict[str, Any]:
        """What results.json records of it: the measured step and pivot and their relative
        spreads, the world's own, and every run's measurement."""
        return {
            "step_m": self.calibration.step_m,
            "pivot_deg": self.calibration.pivot_deg,
            "step_spread": self.calibration.step_spread,
            "pivot_spread": self.calibration.pivot_spread,
            "true_step_m": self.true_step_m,
            "true_pivot_deg": self.true_pivot_deg,
            "runs": self.calibration.to_dict(),
        }


def simulated_calibration(preset: str | Preset, seed: int) -> SimulatedCalibration:
    """Calibrate the simulated rover of ``preset`` as ``lfd-track hardware calibrate --sim``
    does (:func:`~lfd_track.hardware.calibrate.calibrate`: the default runs, on the training
    track's straight, from camera frames alone, the camera taken as known), from the stream
    :data:`CALIBRATION_STREAM` of the repetition seed ``seed``; the map geometry is the
    preset's camera with the measured step and pivot.

    A preset with ``[randomization]`` draws a new world at every episode, and a calibration's
    runs must all see one: the rover is calibrated in one world drawn from the preset with that
    stream (first draw) and kept for its runs; the map's camera stays the preset's nominal one,
    as with ``geometry = "world"``. Raises :class:`~lfd_track.errors.CalibrationFailed`."""
    from ..hardware.calibrate import calibrate, strip_start  # the camera's geometry alone

    base = preset if isinstance(preset, Preset) else load_preset(preset)
    rng = np.random.default_rng(np.random.SeedSequence(seed, spawn_key=(CALIBRATION_STREAM,)))
    world = base
    if base.randomized:
        drawn = base.sample(rng)
        world = dataclasses.replace(drawn, name=f"{base.name}-calibration", randomization=())
    env = LfDTrackEnv(track="training", preset=world)
    try:
        calibration = calibrate(
            env,
            base.camera,
            reset_options={"pose": strip_start(env.track)},
            seed=int(rng.integers(2**31 - 1)),
        )
    finally:
        env.close()
    truth = MapGeometry.from_preset(world)
    geometry = dataclasses.replace(
        MapGeometry.from_preset(base), step_m=calibration.step_m, pivot_deg=calibration.pivot_deg
    )
    return SimulatedCalibration(geometry, calibration, truth.step_m, truth.pivot_deg)


def calibration_for(
    memory: MemoryConfig | None, preset: str | Preset, seed: int
) -> SimulatedCalibration | None:
    """The repetition's calibration (:func:`simulated_calibration` in its world ``preset``, from
    the repetition seed ``seed``'s stream :data:`CALIBRATION_STREAM`) when ``memory`` is a
    ``fresh_felt`` map with ``geometry = "calibrated"``; None (nothing run) for any other map.
    Raises :class:`~lfd_track.errors.CalibrationFailed`."""
    return simulated_calibration(preset, seed) if calibrates(memory) else None


def simulated_map_geometry(
    memory: MemoryConfig | None, preset: str | Preset, seed: int
) -> MapGeometry:
    """The map geometry of a policy taught in the simulated world ``preset`` outside a benchmark
    (``lfd-track teach``): the world's (:meth:`MapGeometry.from_preset`), or with ``geometry =
    "calibrated"`` the calibration's there (:func:`simulated_calibration`, ``seed`` as the
    repetition seed). Raises :class:`~lfd_track.errors.CalibrationFailed`."""
    calibration = calibration_for(memory, preset, seed)
    if calibration is not None:
        return calibration.geometry
    return MapGeometry.from_preset(preset if isinstance(preset, Preset) else load_preset(preset))


@dataclass(frozen=True)
class MethodContext:
    """Everything a method learns from in one repetition (one object, so a method's signature
    does not change when the benchmark gains an option)."""

    rep_dir: Path
    """Folder of the repetition's files (demonstration, rounds' recordings)."""
    demo_seed: int
    """Seed of the demonstration: the human's random stream and the env's."""
    ga_seed: int
    """Seed of the learner's random stream (GA, backprop or CMA-ES)."""
    preset: str | Preset = "paper"
    """Environment preset of every drive."""
    human: HumanConfig = field(default_factory=HumanConfig)
    """The scripted human (demonstration protocol and traits)."""
    memory: MemoryConfig | None = None
    """Memory inputs of the policy (None or kind ``"none"``: the paper's road values alone)."""
    mirror: bool = False
    """Learn from the cases and their mirror images (:mod:`lfd_track.learning.mirror`)."""
    track: str = "training"
    """Open track the human demonstrates on (and rounds of runs drive)."""
    features: str = DEFAULT_FEATURES
    """Per-region inputs of the policy (:mod:`lfd_track.policy.features`)."""
    shifted_views: bool = False
    """Learn also from the shifted and turned views of every case (:mod:`lfd_track.demo.views`);
    only methods registered with ``takes_views`` receive True."""
    policy_kind: str = "mlp-sigmoid"
    """The network to learn; a method receives only kinds it registered in ``policy_kinds``."""
    ga: GAConfig = field(default_factory=GAConfig)
    """The GA's settings (methods that evolve)."""
    bc: BCConfig = field(default_factory=BCConfig)
    """Backprop's settings (methods that fit by behaviour cloning)."""
    cmaes: CMAESConfig = field(default_factory=CMAESConfig)
    """CMA-ES's settings."""
    settings: Any = None
    """The method's own settings (an instance of its registered settings class, or None)."""
    extra_cases: str = ""
    """Saved cases the offline learners fit after the demonstration's own (a ``.npz`` or a folder
    of them, :mod:`lfd_track.learning.extra_cases`); empty: none."""
    calibration: SimulatedCalibration | None = None
    """With ``geometry = "calibrated"``: the calibration the benchmark ran before teaching
    (:func:`simulated_calibration`); None: calibrated when first needed, with ``demo_seed`` as
    the repetition seed. Unused by any other map."""

    def __post_init__(self) -> None:
        object.__setattr__(self, "rep_dir", Path(self.rep_dir))

    @property
    def period_s(self) -> float:
        """Seconds one command is held (the preset's control period)."""
        return period_s(self.preset)

    @property
    def frame_size(self) -> tuple[int, int]:
        """(width, height) [px] of the preset's camera frames, which the controller records."""
        p = self.preset if isinstance(self.preset, Preset) else load_preset(self.preset)
        return p.camera.frame_width_px, p.camera.frame_height_px

    @property
    def map_geometry(self) -> MapGeometry:
        """The camera and per-command motion the ``fresh_felt`` map assumes and the controller
        records: with ``geometry = "calibrated"`` the calibration's (:attr:`calibrated`), else
        the preset's world, which ``geometry = "world"`` assumes
        (:meth:`~lfd_track.policy.map_geometry.MapGeometry.from_preset`)."""
        if calibrates(self.memory):
            return self.calibrated.geometry
        p = self.preset if isinstance(self.preset, Preset) else load_preset(self.preset)
        return MapGeometry.from_preset(p)

    @functools.cached_property
    def calibrated(self) -> SimulatedCalibration:
        """The repetition's calibration: :attr:`calibration`, or one run now (once per context:
        kept) from ``demo_seed``'s calibration stream. Raises
        :class:`~lfd_track.errors.CalibrationFailed`."""
        if self.calibration is not None:
            return self.calibration
        return simulated_calibration(self.preset, self.demo_seed)


@dataclass
class Learned:
    """What the learning part of a repetition produced."""

    controller: Controller
    demo: dict[str, Any]
    """Demonstration summary (cases, counts, library …) for results.json."""
    fitness_best: list[float]
    fitness_mean: list[float]
    training_accuracy: float
    effort: dict[str, Any]
    """Human effort and robot driving during learning (see the module docstring)."""


def period_s(preset: str | Preset) -> float:
    """Seconds one command is held under ``preset``."""
    p = preset if isinstance(preset, Preset) else load_preset(preset)
    return float(p.rover.control_period_s)


def effort_record(
    period_s: float,
    *,
    demonstration_commands: int = 0,
    counts: LoopCounts | None = None,
    human_commands: int | None = None,
    put_backs: int = 0,
    **extra: Any,
) -> dict[str, Any]:
    """The effort fields of results.json (``period_s``: one command [s]).

    ``demonstration_commands``: commands of a demonstration the human drove alone (every one a
    human command and robot driving); ``counts``: what a teaching loop counted after it (the
    online demonstration, or rounds of runs), whose human commands are ``counts.human_commands``
    unless ``human_commands`` says otherwise (DAgger's labels, executed or not); ``put_backs``:
    times the robot was put back by hand. ``extra`` fields follow the six common ones.
    """
    counts = LoopCounts() if counts is None else counts
    human = counts.human_commands if human_commands is None else human_commands
    demonstration_s = round(demonstration_commands * period_s, 6)
    return {
        "commands": demonstration_commands + human,
        "corrections": counts.corrections,
        "takeovers": counts.takeovers,
        "learning_drive_s": round(demonstration_s + counts.steps * period_s, 6),
        "autonomous_drive_s": round(counts.policy_commands * period_s, 6),
        "put_backs": put_backs,
        **extra,
    }


def recording_metadata(method: str, library: RoadLibrary, **fields: Any) -> dict[str, Any]:
    """The header of a recording a method writes itself (``recording_writer``'s ``metadata``):
    simulated, the method's name, ``fields`` and the library's bins."""
    return {"kind": "simulated", "method": method, **fields, "bins": library.bins}


def add_counts(total: LoopCounts, part: LoopCounts) -> None:
    """Add the loop counts ``part`` to ``total``."""
    for f in dataclasses.fields(LoopCounts):
        setattr(total, f.name, getattr(total, f.name) + getattr(part, f.name))


def track_env(context: MethodContext, *, reverse: bool = False, **options: Any) -> LfDTrackEnv:
    """The simulated world of the method's drives: ``context.track`` under its preset."""
    return LfDTrackEnv(track=context.track, reverse=reverse, preset=context.preset, **options)


def drive_policy(
    env: LfDTrackEnv, controller: Any, *, seed: int | None, observers: Sequence[Observer] = ()
) -> TeachingLoop:
    """Drive one autonomous episode on ``env`` (reset with ``seed``) to its end and return the
    loop (its ``info`` and ``counts``): the teaching loop with ``controller`` (anything with
    ``perception()`` and ``commander()``) as the only commander, ``observers`` seeing each step.
    A :class:`Controller`'s map is told the world's geometry, so that it notes a world of
    another geometry; anything else brings its own perception."""
    if isinstance(controller, Controller):
        perception = controller.perception(world_geometry=MapGeometry.from_preset(env.base_preset))
    else:
        perception = controller.perception()
    loop = TeachingLoop(
        env, perception, Arbiter("policy"), policy=controller.commander(), observers=observers
    )
    loop.reset(seed=seed)
    loop.run()
    return loop


def demonstrate(
    context: MethodContext, *, shifted_views: bool = False
) -> tuple[DemonstrationSummary, Demonstration, RoadLibrary, ViewCases | None]:
    """Record the paper's demonstration on ``context.track`` in ``context.rep_dir``; (summary,
    cases, library, views): the shifted and turned views of every case with ``shifted_views``,
    else None."""
    views = ViewCases() if shifted_views else None
    demo_path = context.rep_dir / "demonstration.lfdemo"
    summary = run_demonstration(
        demo_path,
        seed=context.demo_seed,
        track=context.track,
        preset=context.preset,
        human=context.human,
        fsync=False,
        overwrite=True,
        memory=context.memory,
        views=views,
        # The teacher's map assumes what the controller's will; else the demonstrator's default
        # (the world's), so every other recording stays as it was.
        map_geometry=context.map_geometry if calibrates(context.memory) else None,
    )
    demo = load_demonstration(demo_path)
    return summary, demo, RoadLibrary.from_dict(demo.metadata["road_library"]), views


def demonstration_record(summary: DemonstrationSummary, **extra: Any) -> dict[str, Any]:
    """What results.json records of a demonstration (cases, counts, turn-arounds, library),
    followed by ``extra``."""
    return {
        "cases": summary.n_cases,
        "counts": summary.counts,
        "turnarounds": list(summary.turnarounds),
        "library_models": summary.library_models,
        "library_types": summary.library_types,
        "learned_off_felt": summary.learned_off_felt,
        **extra,
    }


def training_set(
    context: MethodContext, inputs: np.ndarray, actions: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """What a learner fits: the cases, followed by their mirror images with ``context.mirror``."""
    if not context.mirror:
        return inputs, actions
    return with_mirrored(inputs, actions, context.memory, context.features)
