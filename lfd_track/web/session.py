"""The teaching session the web app drives: the teaching loop, stepped in a background thread.

:class:`LoopSession` arranges the one teaching loop (:mod:`lfd_track.teaching`) for a browser: the
human commander is a :class:`~lfd_track.web.commander.BrowserCommander` fed by the server; with
``--online`` a policy commander drives with what the loop's learner feed (the GA, or backprop)
has learned from the cases so far, and the arbiter offers a takeover once the policy agrees with
the human. The loop is stepped from a background thread at most once per control period, only
when someone has a command (the human pressed, or the policy drives). Observers record every case
to a crash-safe ``.lfdemo`` and count cases and corrections; after each step the session
publishes the annotated camera view and the simulator's map. Nothing moves unless the controlling
page holds the lease (:class:`~lfd_track.web.contract.Lease`).
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.commands import Command
from ..dataset import DemonstrationWriter
from ..dataset.recording import RecordingTarget, ReplacingWriter
from ..methods.common import calibrates, simulated_map_geometry
from ..methods.online import OnlineConfig
from ..policy.map_geometry import MapGeometry, hardware_geometry
from ..policy.memory import MemoryConfig, NoMemory
from ..teaching.arbiter import Arbiter
from ..teaching.commanders import PolicyCommander
from ..teaching.loop import TeachingLoop
from ..teaching.observers import CaseTally, Recorder
from ..teaching.perception import Perception
from ..vision.road_library import RoadLibrary
from .commander import BrowserCommander
from .contract import LEASE_S, Lease, View
from .view import make_view

if TYPE_CHECKING:
    from ..envs.track_env import LfDTrackEnv
    from ..hardware.env import HardwareEnv

HUMAN = "human"
AUTONOMOUS = "autonomous"
PHASE_TEACH = "drive"
PHASE_CORRECTION = "correction"


@dataclass(frozen=True)
class TeachConfig:
    """What ``lfd-track teach`` asked for (each setting's meaning: :mod:`lfd_track.cli.teach`)."""

    out: Path
    """The demonstration file to write (``.lfdemo``)."""
    backend: str = "sim"
    """``"sim"`` or ``"hardware"``."""
    track: str = "training"
    preset: str = "paper"
    seed: int = 0
    """Seed of the world and of the online learner."""
    camera: str | None = None
    """The phone camera's stream URL (hardware)."""
    serial: str | None = None
    """The serial port or pyserial URL of the board (hardware)."""
    period_s: float | None = None
    """[s] control period; None: the preset's (sim) or 0.4 s (hardware)."""
    profile: MapGeometry | None = None
    """The robot's calibrated map geometry (hardware: a robot profile's); None: the paper's."""
    online: bool = False
    """Evolve a policy while the person teaches; it is offered the wheel when it agrees."""
    takeover: OnlineConfig = field(default_factory=OnlineConfig)
    """How the policy learns (the learner, its steps per case) and earns the wheel (window,
    threshold); the intervention settings are the benchmark's only."""
    population_size: int = 40
    """GA population of the online learner (the paper's 40)."""
    memory: MemoryConfig = field(default_factory=NoMemory)
    """Memory inputs recorded with every case, and their settings (one of the kinds'
    classes of :mod:`lfd_track.policy.memory_config`)."""
    features: str = "road_values"
    """Per-region inputs of the online policy (``features.FEATURE_SETS``; ``"none"``: memory only)."""
    ga_bias: bool = False
    """With ``online``: networks with biases (``GAConfig.bias``, or ``BCConfig.bias`` with
    learner ``"bc"``)."""
    mutation_delta: float = 0.1
    """With ``online``: the GA's mutation step (``GAConfig.mutation_delta``, the paper's 0.1)."""
    class_balance: float = 1.0
    """With learner ``"bc"``: backprop's ``BCConfig.class_balance`` (1: each command the same)."""
    ensemble: int = 1
    """With learner ``"bc"``: ``BCConfig.ensemble``, recorded only (the policy is one network)."""
    mirror: bool = False
    """With ``online``: the learner fits the cases and their mirror images (``--mirror``)."""
    library_only: int = 0
    """The first N commands only build the road library and are not recorded."""
    force: bool = False
    """Replace an existing ``out`` (kept until the new recording holds a case)."""
    fps: float = 10.0
    """[frames/s] live view rate of a standing robot's camera."""


class LoopSession:
    """A teaching station on the sim or the real robot (see the module docstring).

    Args:
        loop: the teaching loop (its env, perception, arbiter, commanders, observers).
        commander: the loop's human commander, fed by the web server.
        writer: the demonstration file the loop's recorder appends to; closed by :meth:`close`.
        tally: the loop's case-counting observer.
        backend: ``"sim"`` or ``"hardware"``.
        period_s: [s] control period; the loop steps at most once per period.
        learner: the online learner feed (``generation``, ``best_fitness``), None without one.
        policy: the policy commander, None without ``--online``.
        seed: world seed of the first reset (simulator), None on the real robot.
        stop_robot: stops the real robot at once (e-stop), None in the simulator.
        rearm_options: ``reset`` options that make the robot drive again after a stop (the real
            robot's e-stop is cleared by the next command the human gives), or None.
        topdown: returns the simulator's map picture, None on the real robot.
        live_frame: the real robot's newest camera frame and its number without taking it from
            the loop (:meth:`~lfd_track.hardware.camera.MjpegStreamSource.latest`), shown while
            the robot stands; None in the simulator, whose camera renders once per command.
        preview_fps: [frames/s] how often a standing robot's camera view is refreshed.
        lease_s: [s] heartbeat lease of the controlling page.
    """

    def __init__(
        self,
        loop: TeachingLoop,
        commander: BrowserCommander,
        writer: DemonstrationWriter,
        tally: CaseTally,
        *,
        backend: str,
        period_s: float,
        learner: Any = None,
        policy: PolicyCommander | None = None,
        seed: int | None = None,
        stop_robot: Callable[[str], None] | None = None,
        rearm_options: dict[str, Any] | None = None,
        topdown: Callable[[], np.ndarray | None] | None = None,
        live_frame: Callable[[], tuple[int, np.ndarray] | None] | None = None,
        preview_fps: float = 10.0,
        lease_s: float = LEASE_S,
    ) -> None:
        self.loop = loop
        self.commander = commander
        self.writer = writer
        self.tally = tally
        self.backend = backend
        self.online = policy is not None
        self.period_s = float(period_s)
        self.learner = learner
        self.policy = policy
        self.seed = seed
        self._stop_robot = stop_robot
        self._rearm_options = rearm_options
        self._topdown = topdown
        self._live_frame = live_frame
        self._preview_period_s = 1.0 / preview_fps
        self._previewed = -1
        self._cond = threading.Condition()
        self._closed = False
        self._started = False
        self._rearm = False
        self._driving = False
        self._stopped_reason: str | None = None
        self._error: str | None = None
        self._view: View | None = None
        self._view_seq = 0
        self.takeovers = 0
        self.lease = Lease(self._lease_lapsed, lease_s)
        self._thread = threading.Thread(target=self._run, name="lfd-track teaching loop")
        self._thread.daemon = True

    @property
    def arbiter(self) -> Arbiter:
        return self.loop.arbiter

    # ----------------------------------------------------------------------------- commands
    def start(self) -> LoopSession:
        """Reset the robot, publish the first view and start stepping."""
        self.loop.reset(seed=self.seed)
        self._publish()
        self._started = True
        self._thread.start()
        return self

    def heartbeat(self) -> None:
        self.lease.renew()

    def end_lease(self) -> None:
        self.lease.revoke()

    def press(self, command: Command) -> None:
        if not self.lease.alive:
            return  # no lease, no motion
        with self._cond:
            self._stopped_reason = None
            # While the policy drives, the arbiter makes this a correction.
            self.commander.press(command)
            self._cond.notify_all()

    def release(self) -> None:
        self.commander.release()

    def stop(self, reason: str = "stop") -> None:
        with self._cond:
            self.commander.clear()
            if self._driving or self.arbiter.driving == "policy" or self.loop.counts.steps:
                self._stopped_reason = reason
            self.arbiter.reset()  # the human drives; the policy earns the wheel again
            self._rearm = self._rearm_options is not None
            self._cond.notify_all()
        if self._stop_robot is not None:
            self._stop_robot(reason)

    def set_learning_paused(self, paused: bool) -> None:
        self.loop.perception.rule = "paused" if paused else "careful"

    def take_over(self) -> None:
        if self.policy is None:
            raise ValueError("no policy to drive: start the station with --online")
        if not self.lease.alive:
            return
        with self._cond:
            if self.policy.weights is None:
                raise ValueError("no policy yet: demonstrate a few commands first")
            self.commander.clear()
            if self.arbiter.driving != "policy":
                # The person confirms (or overrules) the arbiter's offer: the policy drives from
                # the next frame; any human command then takes control back as a correction.
                self.arbiter.driving = "policy"
                self.arbiter.offer = False
                self.takeovers += 1
            self._stopped_reason = None
            self._cond.notify_all()

    # ----------------------------------------------------------------------------- reading
    def status(self) -> dict[str, Any]:
        arbiter, perception = self.arbiter, self.loop.perception
        with self._cond:
            box_on_felt = self.loop.info.get("safe_box_on_felt")
            status: dict[str, Any] = {
                "cases": self.writer.n_cases,
                "counts": self.tally.counts,
                "corrections": self.tally.corrections,
                "mode": AUTONOMOUS if arbiter.driving == "policy" else HUMAN,
                "learning_paused": perception.rule == "paused",
                "learning_auto_paused": perception.rule == "careful"
                and not perception.would_learn(box_on_felt),
                "library_models": perception.library.n_models,
                "generation": None,
                "best_fitness": None,
                "agreement": arbiter.agreement if arbiter.agreement_count else None,
                "agreement_over": arbiter.agreement_count,
                "policy_ready": self.policy is not None and self.policy.weights is not None,
                "takeover_offered": bool(arbiter.offer) and arbiter.driving != "policy",
                "takeovers": self.takeovers,
                "steps": self.loop.counts.steps,
                "driving": self._driving,
                "stopped_reason": self._stopped_reason,
                "error": self._error,
                "lease_alive": self.lease.alive,
            }
            if not self.online:
                status["agreement"] = None
            if self.learner is not None and self.learner.generation > 0:
                status["generation"] = int(self.learner.generation)
                status["best_fitness"] = float(self.learner.best_fitness)
            elif self.learner is not None:
                status["generation"] = 0
        return status

    def latest_view(self) -> View | None:
        with self._cond:
            return self._view

    # ----------------------------------------------------------------------------- lifecycle
    def close(self) -> None:
        with self._cond:
            if self._closed:
                return
            self._closed = True
            self.commander.clear()
            self._cond.notify_all()
        if self._thread.is_alive():
            self._thread.join(timeout=10.0)
        self.lease.close()
        try:
            library = self.loop.perception.library
            self.writer.close(
                {
                    "road_library": library.to_dict(),
                    "library_models": library.n_models,
                    "library_types": library.n_types,
                    "commands": self.loop.counts.steps,
                    "corrections": self.tally.corrections,
                    "takeovers": self.takeovers,
                }
            )
        finally:
            self.loop.env.close()

    def __enter__(self) -> LoopSession:
        return self.start()

    def __exit__(self, *exc: object) -> None:
        self.close()

    # ----------------------------------------------------------------------------- the thread
    def _has_work(self) -> bool:
        return self.arbiter.driving == "policy" or self.commander.pending

    def _run(self) -> None:
        next_step_at = 0.0
        while True:
            with self._cond:
                preview = False
                while not self._closed and not (self._has_work() and self.lease.alive):
                    if self._has_work():  # commands but no lease: drop them, nothing moves
                        self.commander.clear()
                        self.arbiter.reset()
                    if self._live_frame is None:
                        self._cond.wait()
                    elif not self._cond.wait(self._preview_period_s):
                        preview = True
                        break
                if self._closed:
                    return
                if not preview:
                    # Pace the simulator like the robot: one command per control period.
                    remaining = next_step_at - time.monotonic()
                    if remaining > 0:
                        self._cond.wait(remaining)
                        continue
                    rearm, self._rearm = self._rearm, False
                    driver = self.arbiter.driving
                    self._driving = True
            if preview:
                try:
                    self._show_live_frame()
                except Exception as exc:  # noqa: BLE001 - shown on the page, as below
                    self._report(exc)
                continue
            started = time.monotonic()
            try:
                if rearm:  # a command after a stop: clear the e-stop, take a fresh frame
                    # The robot stands where it stopped: the same run, the same memory.
                    self.loop.reset(options=self._rearm_options, keep_memory=True)
                    self._keep_driver(driver)
                step = self.loop.step()
                if self.loop.episode_over:
                    self._episode_ended()
            except Exception as exc:  # noqa: BLE001 - shown on the page; the station keeps serving
                with self._cond:
                    self._error = f"{type(exc).__name__}: {exc}"
                    self.commander.clear()
                    self.arbiter.reset()
                    self._rearm = self._rearm_options is not None
                    self._driving = False
                continue
            with self._cond:
                self._driving = False
                if step.command is not None:
                    self._error = None  # the robot drives again
            if step.command is not None:
                next_step_at = started + self.period_s
                try:
                    self._publish()
                except Exception as exc:  # noqa: BLE001 - the step ran; the view is what failed
                    self._report(exc)

    def _report(self, exc: Exception) -> None:
        """Show an error of the loop thread on the page (the thread keeps serving)."""
        with self._cond:
            self._error = f"{type(exc).__name__}: {exc}"

    def _lease_lapsed(self) -> None:
        """The lease watchdog's stop; a failed one (e.g. a lost serial link) is shown on the page
        and does not end the watchdog, so the next lapse stops the robot again."""
        try:
            self.stop("no heartbeat from the page for 1 s")
        except Exception as exc:  # noqa: BLE001 - the watchdog must live on
            self._report(exc)

    def _keep_driver(self, driver: str) -> None:
        """After the re-arm's reset (which hands the wheel to the human): a "let it drive" given
        since the stop still holds, unless another stop (it asks for a re-arm again) or the end
        of the lease came meanwhile."""
        with self._cond:
            if driver == "policy" and not self._rearm and self.lease.alive:
                self.arbiter.driving = "policy"

    def _episode_ended(self) -> None:
        """Off the felt, reversed, or the real robot's link or camera failed: stop, start over."""
        info = self.loop.info
        reason = str(info.get("error") or info.get("failure") or "the episode ended")
        with self._cond:
            self.commander.clear()
            self.arbiter.reset()
        if self._rearm_options is None:  # the simulator: back to the start of the track
            self.loop.reset()
            reason += ": back to the start"
        with self._cond:
            self._stopped_reason = reason
            self._rearm = self._rearm_options is not None

    def _show_live_frame(self) -> None:
        """Publish the standing robot's newest camera frame, if it is new."""
        latest = self._live_frame() if self._live_frame is not None else None
        if latest is not None and latest[0] != self._previewed:
            self._previewed = latest[0]
            self._publish(latest[1])

    def _publish(self, frame: np.ndarray | None = None) -> None:
        """Publish the view of ``frame`` (default: the loop's current frame)."""
        frame = self.loop.frame if frame is None else frame
        assert frame is not None, "the session publishes only after the loop's reset"
        values = self.loop.perception.look(frame)  # looking never counts as a selection
        topdown = self._topdown() if self._topdown is not None else None
        with self._cond:
            self._view_seq += 1
            seq = self._view_seq
        view = make_view(seq, frame, values, topdown)
        with self._cond:
            self._view = view


# ------------------------------------------------------------------------------- arrangement
def open_session(config: TeachConfig) -> LoopSession:
    """The session ``lfd-track teach`` asked for, started (close it when done)."""
    out = Path(config.out)
    metadata: dict[str, Any] = {
        "source": "teach",
        "backend": config.backend,
        "online": config.online,
    }
    env: LfDTrackEnv | HardwareEnv
    topdown: Callable[[], np.ndarray | None] | None
    if config.backend == "sim":
        from ..envs.track_env import LfDTrackEnv

        env = LfDTrackEnv(
            track=config.track, preset=config.preset, render_mode="rgb_array", max_steps=10**9
        )
        period_s = config.period_s or env.preset.rover.control_period_s
        # The world it is taught in (its motion calibrated there with geometry = "calibrated").
        map_geometry = simulated_map_geometry(config.memory, env.base_preset, config.seed)
        metadata.update(kind="simulated", track=config.track, preset=config.preset)
        metadata["seed"] = config.seed
        stop_robot = None
        topdown = env.render
        rearm = None
        live_frame = None
    else:
        from ..hardware.env import HardwareEnv  # lazy: the serial link and the camera stream

        period_s = config.period_s or 0.4
        # The robot's map geometry: its profile once calibrated; until then the paper's.
        map_geometry = hardware_geometry(config.profile, period_s=period_s)
        if config.camera is None or config.serial is None:
            raise ValueError("the hardware backend needs both a camera stream and a serial port")
        # Each command runs one period, then the motors stop: a page that gives no command
        # leaves the robot standing (as the paper's remote did).
        robot = env = HardwareEnv(
            camera_url=config.camera,
            serial_url=config.serial,
            control_period_s=period_s,
            between_steps="stop",
        )
        metadata.update(kind="hardware", camera=config.camera, control_period_s=period_s)

        def stop_robot(reason: str) -> None:
            robot.link.estop()  # latched: a drive already on its way is refused by the board

        topdown = None
        rearm = {"clear_estop": True}
        live_frame = getattr(robot.camera, "latest", None)
    if calibrates(config.memory) or (config.backend != "sim" and config.profile is not None):
        metadata["map_geometry"] = map_geometry.to_dict()  # evolve teaches the map with it
    takeover = config.takeover
    if config.online:
        metadata["online_settings"] = {
            "generations_per_case": takeover.generations_per_case,
            "window": takeover.window,
            "threshold": takeover.threshold,
            "population_size": config.population_size,
            **({"mirror": True} if config.mirror else {}),  # written only when on, as learner
        }
        if takeover.learner != "ga":  # a recording taught with the GA reads as it always did
            bc = {"class_balance": config.class_balance, "ensemble": config.ensemble}
            balance = {k: v for k, v in bc.items() if v != 1}  # the settings given, as learner
            metadata["online_settings"].update(
                learner=takeover.learner, epochs_per_case=takeover.epochs_per_case, **balance
            )
    # As ``lfd-track demo --force``: an existing file is kept until the new recording is closed
    # (then replaced, if it holds a case); until then the recording has a name of its own.
    target = RecordingTarget(out, replace=config.force and out.exists())
    writer: Any
    try:
        perception = Perception(
            RoadLibrary(),
            "careful",
            config.memory,
            config.features,
            geometry=map_geometry,
        )
        writer = target.writer(metadata, perception, fsync=True, overwrite=config.force)
    except BaseException:
        env.close()
        raise
    if target.replacing:
        writer = ReplacingWriter(writer, target, "teach")
    commander = BrowserCommander(library_only=config.library_only)
    tally = CaseTally()
    observers: list[Any] = [
        Recorder(
            writer,
            lambda step: {
                "pose": step.moment.pose,
                "phase": PHASE_CORRECTION if step.decision.correction else PHASE_TEACH,
                "source": "correction" if step.decision.correction else "demonstration",
                "step": step.moment.step,
            },
        ),
        tally,
    ]
    policy = learner = None
    if config.online:
        policy, learner = _online_parts(config, perception.n_inputs)
        observers.append(learner)
    loop = TeachingLoop(
        env,
        perception,
        Arbiter(
            "takeover" if config.online else "human",
            window=takeover.window,
            threshold=takeover.threshold,
            auto_accept=False,  # offered on the page; the person lets it drive
        ),
        human=commander,
        policy=policy,
        observers=observers,
        stop_on_episode_end=False,
    )
    session = LoopSession(
        loop,
        commander,
        writer,
        tally,
        backend=config.backend,
        period_s=period_s,
        learner=learner,
        policy=policy,
        seed=config.seed if config.backend == "sim" else None,
        stop_robot=stop_robot,
        rearm_options=rearm,
        topdown=topdown,
        live_frame=live_frame,
        preview_fps=config.fps,
    )
    try:
        return session.start()
    except BaseException:
        if target.replacing:
            writer.quiet = True  # the error is the message
        session.close()
        if not target.replacing:
            out.unlink(missing_ok=True)  # nothing was taught: leave no empty recording behind
        raise


def _online_parts(config: TeachConfig, n_inputs: int) -> tuple[PolicyCommander, Any]:
    """The policy commander and the loop's learner feed (the GA, or backprop with learner
    ``"bc"``), which updates its weights."""
    from ..learning.bc import BCConfig
    from ..learning.ga import GAConfig
    from ..learning.mirror import with_mirrored
    from ..teaching.learner_feed import BCLearnerFeed, GALearnerFeed

    policy = PolicyCommander(None)  # no policy until the first case was learned
    mirrored = partial(with_mirrored, memory=config.memory, features=config.features)
    training_set = mirrored if config.mirror else None  # what the learner fits
    rng = np.random.default_rng(config.seed)
    if config.takeover.learner == "bc":
        bc = BCConfig(
            bias=config.ga_bias, class_balance=config.class_balance, ensemble=config.ensemble
        )
        epochs = config.takeover.epochs_per_case
        return policy, BCLearnerFeed(bc, rng, epochs, policy, n_inputs, training_set)
    ga = GAConfig(
        population_size=config.population_size,
        bias=config.ga_bias,
        mutation_delta=config.mutation_delta,
    )
    steps = config.takeover.generations_per_case
    return policy, GALearnerFeed(ga, rng, steps, policy, n_inputs, training_set)
