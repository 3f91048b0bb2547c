"""Privileged centreline driver: decision rule, and closed loop with the rover on paper tracks."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import pytest

from lfd_track.core.commands import Command
from lfd_track.world.driver import CentrelineDriver, DriverConfig
from lfd_track.world.rover import Rover, RoverConfig
from lfd_track.world.track import ProgressTracker, Track, load_track

REVERSE_MARGIN_M = 0.30  # lfd_track/world/episode.py
END_MARGIN_M = 0.40  # open track: the end is reached this far before the far end


@dataclass
class Drive:
    commands: list[Command] = field(default_factory=list)
    progress: list[float] = field(default_factory=list)  # at each decision [m]
    any_tread_on_felt: list[bool] = field(default_factory=list)  # after each command
    max_drop_m: float = 0.0
    completed: bool = False


def drive(track: Track, config: DriverConfig, seed: int, max_commands: int = 400) -> Drive:
    """Closed loop: rover physics + privileged driver, no rendering."""
    rng = np.random.default_rng(seed)
    rover = Rover(RoverConfig())
    start, heading = track.point_at(0.0)
    rover.reset((start[0], start[1], heading), rng)
    tracker = ProgressTracker(track)
    driver = CentrelineDriver(track, config)
    goal = track.length_m if track.closed else track.length_m - END_MARGIN_M
    best = tracker.update(rover.pose[:2])
    out = Drive()
    while len(out.commands) < max_commands:
        command = driver.act(rover.pose, tracker.progress_m)
        out.commands.append(command)
        out.progress.append(tracker.progress_m)
        rover.step(command, rng)
        progress = tracker.update(rover.pose[:2])
        best = max(best, progress)
        out.max_drop_m = max(out.max_drop_m, best - progress)
        out.any_tread_on_felt.append(bool(track.on_felt(rover.tread_points()).any()))
        if best >= goal:
            out.completed = True
            break
    return out


def _near_corner(track: Track, progress_m: float, margin_m: float) -> bool:
    """Whether ``progress_m`` is within ``margin_m`` of a bend (or a loop's start) [m]."""
    bends = [c.s_m for c in track.corners] + ([0.0, track.length_m] if track.closed else [])
    s = progress_m % track.length_m if track.closed else progress_m
    return any(abs(s - b) < margin_m for b in bends)


def _flips_on_straights(track: Track, run: Drive, margin_m: float) -> int:
    flips = 0
    for i in range(1, len(run.commands)):
        pair = {run.commands[i - 1], run.commands[i]}
        if pair == {Command.LEFT, Command.RIGHT} and not (
            _near_corner(track, run.progress[i - 1], margin_m)
            or _near_corner(track, run.progress[i], margin_m)
        ):
            flips += 1
    return flips


TRACKS = [
    pytest.param("testing", False, id="testing-ccw"),
    pytest.param("testing", True, id="testing-cw"),
    pytest.param("training", False, id="training-dir1"),
    pytest.param("training", True, id="training-dir2"),
]


def _load(name: str, reverse: bool) -> Track:
    kwargs = {"start_corner": "4"} if name == "testing" else {}
    return load_track(name, reverse=reverse, **kwargs)


# ---- closed loop ---------------------------------------------------------------------------
@pytest.mark.parametrize("name, reverse", TRACKS)
@pytest.mark.parametrize("seed", [0, 1])
def test_driver_completes_the_paper_tracks(name: str, reverse: bool, seed: int) -> None:
    track = _load(name, reverse)
    config = DriverConfig()
    run = drive(track, config, seed)
    assert run.completed, f"stopped after {len(run.commands)} commands"
    assert all(run.any_tread_on_felt), "both treads completely off the felt"
    assert run.max_drop_m < REVERSE_MARGIN_M
    assert _flips_on_straights(track, run, margin_m=config.lookahead_m + 0.15) == 0
    # Command budget (measured: testing lap ~92-106, training ~35-40 commands).
    budget = 130 if track.closed else 50
    assert len(run.commands) < budget
    assert run.commands.count(Command.FORWARD) > 0.7 * len(run.commands)


def test_loop_turns_match_the_driving_direction() -> None:
    ccw = drive(_load("testing", False), DriverConfig(), seed=0)
    cw = drive(_load("testing", True), DriverConfig(), seed=0)
    # Counter-clockwise laps turn left at every corner; clockwise laps turn right.
    assert ccw.commands.count(Command.LEFT) > 3 * ccw.commands.count(Command.RIGHT)
    assert cw.commands.count(Command.RIGHT) > 3 * cw.commands.count(Command.LEFT)


def test_narrow_dead_band_flips_endlessly() -> None:
    # Half a pivot command is ~11.5°: a 6° band is overshot by every pivot (lfd_track/world/driver.py).
    track = _load("training", False)
    narrow = drive(track, DriverConfig(dead_band_deg=6.0), seed=0, max_commands=150)
    wide = drive(track, DriverConfig(dead_band_deg=15.0), seed=0, max_commands=150)
    # margin 0: count every left/right flip, wherever it happens.
    assert _flips_on_straights(track, narrow, margin_m=0.0) > 50
    assert not narrow.completed
    assert _flips_on_straights(track, wide, margin_m=0.0) == 0
    assert wide.completed


# ---- decision rule -------------------------------------------------------------------------
def test_target_is_lookahead_along_the_centreline() -> None:
    track = _load("testing", False)
    driver = CentrelineDriver(track, DriverConfig(lookahead_m=0.4))
    assert driver.target(0.0) == pytest.approx([0.4, 0.0])
    assert driver.target(2.8) == pytest.approx([3.0, 0.2])  # around corner 1
    assert driver.target(track.length_m + 1.0) == pytest.approx([1.4, 0.0])  # next lap


def test_target_continues_past_an_open_end() -> None:
    track = _load("training", False)
    driver = CentrelineDriver(track, DriverConfig(lookahead_m=0.35))
    target = driver.target(track.length_m)
    assert target == pytest.approx([-0.35 / math.sqrt(2), 0.6364 + 0.35 / math.sqrt(2)], abs=1e-4)


def test_heading_error_sign_and_dead_band() -> None:
    track = _load("testing", False)  # first strip along +x from (0, 0)
    driver = CentrelineDriver(track, DriverConfig(lookahead_m=0.35, dead_band_deg=15.0))
    on_line = np.array([1.0, 0.0, 0.0])
    assert driver.heading_error(on_line, 1.0) == pytest.approx(0.0)
    assert driver.act(on_line, 1.0) is Command.FORWARD
    # Facing 20° to the right of the strip: the target is to the left.
    turned_right = np.array([1.0, 0.0, math.radians(-20.0)])
    assert driver.heading_error(turned_right, 1.0) == pytest.approx(math.radians(20.0))
    assert driver.act(turned_right, 1.0) is Command.LEFT
    assert driver.act(np.array([1.0, 0.0, math.radians(20.0)]), 1.0) is Command.RIGHT
    # Inside the band: keep going.
    assert driver.act(np.array([1.0, 0.0, math.radians(14.0)]), 1.0) is Command.FORWARD
    # Offset to the left of the centreline by 0.1 m: the target is ~16° to the right.
    offset = np.array([1.0, 0.1, 0.0])
    assert driver.heading_error(offset, 1.0) == pytest.approx(-math.atan2(0.1, 0.35))
    assert driver.act(offset, 1.0) is Command.RIGHT


def test_heading_error_is_wrapped() -> None:
    track = _load("testing", False)
    driver = CentrelineDriver(track)
    facing_back = np.array([1.0, 0.0, math.pi])
    assert driver.heading_error(facing_back, 1.0) == pytest.approx(math.pi)
    almost_back = np.array([1.0, 0.0, -math.pi + 0.1])
    assert driver.heading_error(almost_back, 1.0) == pytest.approx(math.pi - 0.1)


def test_act_is_a_pure_function_of_pose_and_progress() -> None:
    driver = CentrelineDriver(_load("testing", True), DriverConfig())
    pose = np.array([0.5, 0.2, 0.3])
    first = driver.act(pose, 0.4)
    assert all(driver.act(pose.copy(), 0.4) is first for _ in range(3))


@pytest.mark.parametrize(
    "change, message",
    [
        ({"lookahead_m": 0.0}, "lookahead_m"),
        ({"lookahead_m": float("inf")}, "lookahead_m"),
        ({"dead_band_deg": -1.0}, "dead_band_deg"),
        ({"dead_band_deg": 95.0}, "dead_band_deg"),
    ],
)
def test_bad_driver_config_is_rejected(change: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        DriverConfig(**change)
