"""A scripted "human" demonstrator and the paper's demonstration protocol (DESIGN §6).

The human is the privileged centreline driver (pure pursuit on the known track, not pixels) with
human traits: a heading dead-band, an occasional reaction delay (acting on the previous frame's
decision), occasional lapses (repeating the previous command), and a rate limit on direction
changes (never left straight after right or the reverse).

The protocol: 10 commands that only build the road library, then the training track from the right
end to the left end and back, twice; at each of the four arrivals the human stops about 0.35 m
before the end and pivots round, alternating left and right turn-arounds. Every frame is processed
as on the robot (library learning from the safe box, then road values of the 40 regions); each
command after the first 10 is recorded with the road values computed at that moment.

*Careful training*: the library learns only while the safe box is on the felt, as an operator
watching the phone's screen would; with ``careful=False`` it learns from every frame and the
library is poisoned with carpet (the paper's §6 warning).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..commands import Command
from ..env import LfDTrackEnv
from ..presets import Preset
from ..vision.road_library import RoadLibrary
from ..world.driver import CentrelineDriver, DriverConfig
from ..world.track import ProgressTracker, load_track
from .dataset import DemonstrationWriter, load_demonstration

PHASE_LIBRARY_ONLY = "library_only"
PHASE_DRIVE = "drive"
PHASE_TURNAROUND = "turnaround"


@dataclass(frozen=True)
class HumanConfig:
    """Traits of the scripted human and the demonstration protocol."""

    dead_band_deg: float = 15.0  # [deg] heading error tolerated before turning (> half a pivot)
    lookahead_m: float = 0.35  # [m] pure-pursuit lookahead along the centreline
    reaction_delay_prob: float = 0.10  # chance a command answers the previous frame, not this one
    lapse_prob: float = 0.03  # chance the human just repeats the previous command
    library_only_commands: int = 10  # initial commands that only build the library (not recorded)
    legs: int = 4  # end-to-end drives: right→left, left→right, twice
    stop_before_end_m: float = 0.35  # [m] where the human stops to turn round
    first_turnaround: str = "left"  # direction of the first turn-around; then they alternate
    careful: bool = True  # pause library learning while the safe box is off the felt
    max_commands: int = 1000  # give up (error) after this many commands

    def __post_init__(self) -> None:
        if not 0.0 <= self.dead_band_deg < 90.0:
            raise ValueError(f"dead_band_deg must be in [0, 90), got {self.dead_band_deg}")
        for name in ("reaction_delay_prob", "lapse_prob"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.first_turnaround not in ("left", "right"):
            raise ValueError("first_turnaround must be 'left' or 'right'")
        if self.legs < 1 or self.library_only_commands < 0:
            raise ValueError("legs must be >= 1 and library_only_commands >= 0")


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


class ScriptedHuman:
    """Turns privileged state into the paper's discrete commands, with human traits."""

    def __init__(self, config: HumanConfig, rng: np.random.Generator) -> None:
        self.config = config
        self.rng = rng
        self._pending: Command | None = None
        self.previous = Command.FORWARD

    def decide(self, driver: CentrelineDriver, pose: np.ndarray, progress_m: float) -> Command:
        """The command for this frame while driving along a leg."""
        intended = driver.act(pose, progress_m)
        cfg = self.config
        command = intended
        if self._pending is not None and self.rng.random() < cfg.reaction_delay_prob:
            command = self._pending  # reacting late: still answering the previous frame
        elif self.rng.random() < cfg.lapse_prob:
            command = self.previous  # a lapse: the thumb stays on the last button
        self._pending = intended
        # Rate limit: a human goes through forward when switching turn direction.
        if {command, self.previous} == {Command.LEFT, Command.RIGHT}:
            command = Command.FORWARD
        self.previous = command
        return command

    def turn(self, direction: Command) -> Command:
        """A command of a turn-around (always the chosen direction)."""
        self._pending = None
        self.previous = direction
        return direction


def run_demonstration(
    out: str | Path,
    *,
    seed: int,
    track: str = "training",
    preset: str | Preset = "paper",
    human: HumanConfig = HumanConfig(),
    library_factory: Callable[[], RoadLibrary] = RoadLibrary,
    fsync: bool = True,
    overwrite: bool = False,
    progress: Callable[[int], None] | None = None,
) -> DemonstrationSummary:
    """Record one demonstration on ``track`` to the file ``out`` and return a summary.

    The file is written case by case (crash-safe); the record-time road library is stored in its
    footer. ``progress`` is called with the number of commands given so far.
    """
    rng = np.random.default_rng(seed)
    env_seed = int(rng.integers(2**31 - 1))
    env = LfDTrackEnv(track=track, preset=preset, max_steps=10**9)
    forward = load_track(track)
    if forward.closed:
        raise ValueError(f"the demonstration protocol needs an open track, '{track}' is a loop")
    legs = [forward, load_track(track, reverse=True)]
    library = library_factory()
    person = ScriptedHuman(human, rng)
    driver_cfg = DriverConfig(lookahead_m=human.lookahead_m, dead_band_deg=human.dead_band_deg)
    frame, info = env.reset(seed=env_seed)
    metadata: dict[str, Any] = {
        "kind": "simulated",
        "track": track,
        "seed": seed,
        "env_seed": env_seed,
        "preset": preset if isinstance(preset, str) else preset.name,
        "human": dataclasses.asdict(human),
        "bins": library.bins,
    }
    turnarounds: list[str] = []
    learned_frames = off_felt_frames = learned_off_felt = 0
    commands = 0
    next_turn = Command.LEFT if human.first_turnaround == "left" else Command.RIGHT

    with DemonstrationWriter(
        out, metadata, bins=library.bins, fsync=fsync, overwrite=overwrite
    ) as writer:

        def observe_and_command(
            command_for: Callable[[], Command], phase: str, progress_m: float
        ) -> None:
            """One robot cycle: learn (if careful allows), road values, command, record, move."""
            nonlocal frame, info, commands, learned_frames, off_felt_frames, learned_off_felt
            box_on_felt = bool(info["safe_box_on_felt"])
            learn = box_on_felt or not human.careful
            if learn:
                library.learn(frame)
                learned_frames += 1
                learned_off_felt += 0 if box_on_felt else 1
            off_felt_frames += 0 if box_on_felt else 1
            hists = library.region_histograms(frame)
            values = library.road_values_from_histograms(hists)
            command = command_for()
            if commands >= human.library_only_commands:
                writer.append(
                    int(command),
                    values,
                    hists,
                    pose=env.rover_pose,
                    progress_m=progress_m,
                    phase=phase,
                    learned=learn,
                    step=commands,
                )
            frame, _, _, _, info = env.step(int(command))
            commands += 1
            if progress is not None:
                progress(commands)
            if commands > human.max_commands:
                raise RuntimeError(f"demonstration exceeded {human.max_commands} commands")

        for leg in range(human.legs):
            leg_track = legs[leg % 2]
            tracker = ProgressTracker(leg_track)
            tracker.update(env.rover_pose[:2])
            driver = CentrelineDriver(leg_track, driver_cfg)
            stop_at = leg_track.length_m - human.stop_before_end_m
            while tracker.progress_m < stop_at:
                pose = env.rover_pose
                phase = (
                    PHASE_DRIVE if commands >= human.library_only_commands else PHASE_LIBRARY_ONLY
                )
                observe_and_command(
                    lambda p=pose, s=tracker.progress_m, d=driver: person.decide(d, p, s),
                    phase,
                    tracker.progress_m,
                )
                tracker.update(env.rover_pose[:2])
            # Turn round towards the next leg, alternating the direction at every arrival.
            back = legs[(leg + 1) % 2]
            back_tracker = ProgressTracker(back)
            back_tracker.update(env.rover_pose[:2])
            back_driver = CentrelineDriver(back, driver_cfg)
            direction = next_turn
            turnarounds.append(direction.name.lower())
            next_turn = Command.RIGHT if direction == Command.LEFT else Command.LEFT
            dead_band = math.radians(human.dead_band_deg)
            for _ in range(40):
                error = back_driver.heading_error(env.rover_pose, back_tracker.progress_m)
                if abs(error) <= dead_band:
                    break
                observe_and_command(
                    lambda d=direction: person.turn(d), PHASE_TURNAROUND, tracker.progress_m
                )
        writer.close(
            {
                "road_library": library.to_dict(),
                "turnarounds": turnarounds,
                "library_models": library.n_models,
                "library_types": library.n_types,
                "learned_frames": learned_frames,
                "off_felt_frames": off_felt_frames,
                "learned_off_felt": learned_off_felt,
                "commands": commands,
            }
        )
    env.close()
    demo = load_demonstration(out)
    return DemonstrationSummary(
        path=str(out),
        n_cases=demo.n_cases,
        counts=demo.command_counts,
        turnarounds=tuple(turnarounds),
        library_models=library.n_models,
        library_types=library.n_types,
        learned_frames=learned_frames,
        off_felt_frames=off_felt_frames,
        learned_off_felt=learned_off_felt,
        commands=commands,
    )
