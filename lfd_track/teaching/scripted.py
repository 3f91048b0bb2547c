"""The scripted "human": the paper's demonstration protocol as a commander (the paper, §4.2.5).

The human is the privileged centreline driver (pure pursuit on the known track, not pixels) with
human traits: a heading dead-band, an occasional reaction delay (acting on the previous frame's
decision), occasional lapses (repeating the previous command), and a rate limit on direction
changes (never left straight after right or the reverse). With ``HumanConfig.steers_by =
"picture"`` it steers each leg by what the phone shows instead: the fresh-felt rule
(:class:`~lfd_track.teaching.handwritten.FreshFeltRule`) on the policy's ``fresh_felt`` map
inputs, with the same traits.

:class:`ProtocolHuman` drives the protocol: the training track from the right end to the left end
and back, twice; at each of the four arrivals it stops about 0.35 m before the end and pivots
round, alternating left and right turn-arounds (``HumanConfig.turnarounds`` changes that rule
for ablations: always one way, or not recorded as cases). While a policy drives (takeover), the same human
keeps watching and intervenes by the rule in :class:`InterventionConfig`.
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from ..core.commands import Command
from ..policy.memory import FreshFeltConfig, MemoryConfig
from ..world.driver import CentrelineDriver, DriverConfig
from ..world.rover import RoverConfig
from ..world.track import ProgressTracker, Track
from .handwritten import FreshFeltRule, FreshFeltRuleConfig
from .types import Moment

PHASE_LIBRARY_ONLY = "library_only"
PHASE_DRIVE = "drive"
PHASE_TURNAROUND = "turnaround"
#: Turn-around rules of the protocol (``HumanConfig.turnarounds``).
TURNAROUND_RULES = (
    "alternate",
    "one_sided",
    "unrecorded",
    "toward_last_bend",
    "toward_next_bend",
)

#: What the scripted human steers by while driving a leg (``HumanConfig.steers_by``).
STEERING = ("centreline", "picture")

#: Which pivot a deliberate nudge presses (``HumanConfig.nudge_side``).
NUDGE_SIDES = ("random", "last_pivot")


@dataclass(frozen=True)
class HumanConfig:
    """Traits of the scripted human and the demonstration protocol."""

    dead_band_deg: float = 15.0  # [deg] heading error tolerated before turning (> half a pivot)
    lookahead_m: float = 0.35  # [m] pure-pursuit lookahead along the centreline
    reaction_delay_prob: float = 0.10  # chance a command answers the previous frame, not this one
    lapse_prob: float = 0.03  # chance the human just repeats the previous command
    library_only_commands: int = 10  # initial commands that only build the library (not recorded)
    legs: int = 4  # end-to-end drives: right→left, left→right, twice (on a loop: laps)
    stop_before_end_m: float = 0.35  # [m] where the human stops to turn round
    first_turnaround: str = "left"  # direction of the first turn-around; then they alternate
    # Turn-around rule: "alternate" (left, right, left, ...), "one_sided" (always the first
    # direction), "unrecorded" (alternate, but the turn-around commands are not recorded) or
    # "toward_last_bend" (turn the way the leg's last bend turned: where the felt came from; on
    # the training track that is right, left, right, ..., i.e. alternating from the right) or
    # "toward_next_bend" (turn the way the next leg's first bend turns: where the felt goes; on
    # the training track that is left, right, left, ...; kept because the limits experiment's
    # human_models.toml sets it, where it lapped no more than the default).
    # The other human-model options of a study are the traits above: dead_band_deg,
    # lookahead_m, reaction_delay_prob and lapse_prob (0 and 0: a noise-free human).
    turnarounds: str = "alternate"
    careful: bool = True  # pause library learning while the safe box is off the felt
    max_commands: int = 1000  # give up (error) after this many commands
    # What the human steers by while driving a leg: "centreline" (the privileged pure pursuit
    # above) or "picture" (what the phone shows, as a person at the browser station sees it:
    # the fresh-felt rule, lfd_track.teaching.handwritten.FreshFeltRule, on the policy's
    # fresh_felt map inputs, pivoting beyond picture_turn_deg; needs memory kind fresh_felt).
    # The human traits (reaction delay, lapses, rate limit), the library-only start, the stops
    # and turn-arounds and the rule for intervening are the same for both ("picture" is the
    # chosen configuration's human, chosen.toml).
    steers_by: str = "centreline"
    # [deg] "picture": the rule's turn threshold (kept because the goal's round 17 study,
    # selection_round17.toml, sets 15 for a candidate that lost to the default 20).
    picture_turn_deg: float = 20.0
    # Start the policy's memory afresh at each leg after a turn-around, as at an episode's start
    # (for the fresh_felt map: the strip ahead is the one just driven, which would not count as
    # fresh, and a picture-steering human would pivot round looking for fresh felt). Kept
    # because the goal's round 3 study, selection_round3.toml, sets it (it halved what the
    # learners lapped; no later round uses it).
    clear_memory_per_leg: bool = False
    # The teacher's deliberate nudges: with this chance per command while the human drives a
    # leg (after the library-only start), the human presses a pivot to a random side on purpose
    # and the station does not record it as a case; the commands that bring the robot back are
    # recorded as usual. They teach recovery from states the human's own line never visits (the
    # perturbations of DART, Laskey et al. 2017). A nudge counts as one of the human's commands.
    # Kept because the human-goal study's round 5, selection_round5.toml, sets it.
    nudge_prob: float = 0.0
    # Which pivot a nudge presses: a random side, or the pivot the human itself last gave while
    # driving ("last_pivot"; a random side before its first). At a corner that turns the robot
    # further than the human would, into the states a learned policy that pivots on past the
    # corner reaches, and records how the human gets out of them. The nudges come at the same
    # moments either way (the same draws); only the side differs. Kept because the human-goal
    # study's round 19, selection_round19.toml, sets it (it lost there).
    nudge_side: str = "random"

    def __post_init__(self) -> None:
        if not 0.0 <= self.dead_band_deg < 90.0:
            raise ValueError(f"dead_band_deg must be in [0, 90), got {self.dead_band_deg}")
        for name in ("reaction_delay_prob", "lapse_prob"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {value}")
        if self.first_turnaround not in ("left", "right"):
            raise ValueError("first_turnaround must be 'left' or 'right'")
        if self.turnarounds not in TURNAROUND_RULES:
            raise ValueError(f"turnarounds must be one of {', '.join(TURNAROUND_RULES)}")
        if self.legs < 1 or self.library_only_commands < 0:
            raise ValueError("legs must be >= 1 and library_only_commands >= 0")
        if self.steers_by not in STEERING:
            raise ValueError(f"steers_by must be one of {', '.join(STEERING)}")
        if not (math.isfinite(self.picture_turn_deg) and 0.0 <= self.picture_turn_deg < 180.0):
            raise ValueError("picture_turn_deg must lie in [0, 180)")
        if not (math.isfinite(self.nudge_prob) and 0.0 <= self.nudge_prob <= 0.5):
            raise ValueError(f"nudge_prob must be in [0, 0.5], got {self.nudge_prob}")
        if self.nudge_side not in NUDGE_SIDES:
            raise ValueError(f"nudge_side must be one of {', '.join(NUDGE_SIDES)}")

    @property
    def driver(self) -> DriverConfig:
        """The pure-pursuit settings of this human."""
        return DriverConfig(lookahead_m=self.lookahead_m, dead_band_deg=self.dead_band_deg)


@dataclass(frozen=True)
class InterventionConfig:
    """When a watching human takes control back from the policy (any one of the three).

    The human watches the robot, not the network: it intervenes when its own judgement says the
    policy is wrong *and it matters* — small disagreements inside the dead-band are let go.
    """

    heading_error_deg: float = 35.0
    """[deg] the robot points this far off the human's aim point (dead-band 15° + one pivot
    step ≈ 23°, plus margin: a policy one pivot late is not yet corrected)."""
    tread_overhang_m: float = 0.03
    """[m] an outer tread edge hangs this far over the felt edge (the strip is 0.30 m, the rover
    0.225 m: 3.75 cm of play each side before any overhang)."""
    progress_drop_m: float = 0.10
    """[m] progress fell this far below its maximum on the leg (the robot turned back)."""
    stall_commands: int = 8
    """The policy drove this many commands in a row ..."""
    stall_progress_m: float = 0.05
    """[m] ... and gained less progress than this (dithering left/right in place)."""

    def __post_init__(self) -> None:
        if isinstance(self.stall_commands, bool) or self.stall_commands < 1:
            raise ValueError("stall_commands must be an integer >= 1")
        for name in (
            "heading_error_deg",
            "tread_overhang_m",
            "progress_drop_m",
            "stall_progress_m",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value!r}")

    def to_dict(self) -> dict[str, float]:
        """Plain JSON-friendly dict."""
        return dataclasses.asdict(self)


class ScriptedHuman:
    """Turns privileged state into the paper's discrete commands, with human traits."""

    def __init__(self, config: HumanConfig, rng: np.random.Generator) -> None:
        self.config = config
        self.rng = rng
        self._pending: Command | None = None
        self.previous = Command.FORWARD

    def decide(
        self,
        driver: CentrelineDriver,
        pose: np.ndarray,
        progress_m: float,
        intended: Command | None = None,
    ) -> Command:
        """The command for this frame while driving along a leg: ``intended`` (what the human
        makes of the picture) or the centreline driver's, through the human traits."""
        if intended is None:
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


class Watcher:
    """The intervention rule: does the human take control back from the policy here?"""

    def __init__(self, config: InterventionConfig, rover_half_width_m: float) -> None:
        self.config = config
        self._heading_rad = math.radians(config.heading_error_deg)
        self._half_width_m = rover_half_width_m

    def reason(
        self,
        track: Track,
        driver: CentrelineDriver,
        tracker: ProgressTracker,
        max_progress_m: float,
        pose: np.ndarray,
    ) -> str | None:
        """Why the human intervenes (``heading``, ``edge``, ``progress``) or None."""
        cfg = self.config
        if abs(driver.heading_error(pose, tracker.progress_m)) > self._heading_rad:
            return "heading"
        centre, _ = track.point_at(min(max(tracker.progress_m, 0.0), track.length_m))
        offset = float(np.hypot(pose[0] - centre[0], pose[1] - centre[1]))
        if offset + self._half_width_m > track.width_m / 2.0 + cfg.tread_overhang_m:
            return "edge"
        if tracker.progress_m < max_progress_m - cfg.progress_drop_m:
            return "progress"
        return None

    def stalled(self, recent_progress_m: deque[float]) -> bool:
        """Whether the policy drove ``stall_commands`` commands without real progress."""
        cfg = self.config
        return (
            len(recent_progress_m) > cfg.stall_commands
            and recent_progress_m[-1] - recent_progress_m[0] < cfg.stall_progress_m
        )


class ProtocolHuman:
    """The demonstration protocol as a commander (needs the privileged pose in ``info``).

    Args:
        legs: the track in its two directions ``(forward, reverse)``: open (a leg drives it end
            to end) or a loop (a leg is one lap from its start).
        config: traits and protocol settings.
        rng: the human's own random stream (reaction delays, lapses).
        intervention: the rule for taking control back while a policy drives (None: never
            watches; a demonstration without takeover).
        rover: rover settings (its width matters for the tread-overhang rule).
        label_all: while a policy drives and the human lets it, still decide what the human
            would command here (:attr:`label`, for DAgger's labels); the policy keeps driving.
    """

    def __init__(
        self,
        legs: tuple[Track, Track],
        config: HumanConfig,
        rng: np.random.Generator,
        *,
        intervention: InterventionConfig | None = None,
        rover: RoverConfig | None = None,
        label_all: bool = False,
        memory: MemoryConfig | None = None,
    ) -> None:
        self.legs = legs
        self.label_all = bool(label_all)
        self.label: Command | None = None
        """The human's command for the latest frame proposed on: the command it gave, or with
        ``label_all`` the one it would have given while it let the policy drive."""
        self.config = config
        self.person = ScriptedHuman(config, rng)
        # Nudges draw from their own stream, split off only when there are any, so a human
        # without them draws exactly what it drew before the setting existed.
        self._nudge_rng = (
            np.random.default_rng(int(rng.integers(2**63))) if config.nudge_prob > 0 else None
        )
        self._nudged = False
        self._last_pivot: Command | None = None  # the human's last pivot while driving a leg
        self.nudges = 0
        """Nudges pressed so far (commands executed, not recorded as cases)."""
        rover = rover or RoverConfig()
        self.watcher = (
            None if intervention is None else Watcher(intervention, rover.body_width_m / 2.0)
        )
        self._dead_band = math.radians(config.dead_band_deg)
        self._next_turn = Command.LEFT if config.first_turnaround == "left" else Command.RIGHT
        self.turnarounds: list[str] = []
        self.interventions: dict[str, int] = {
            "heading": 0,
            "edge": 0,
            "progress": 0,
            "stall": 0,
            "turn": 0,
        }
        stall = intervention.stall_commands if intervention is not None else 1
        self._watched: deque[float] = deque(maxlen=stall + 1)
        self.leg = 0
        self.phase = PHASE_LIBRARY_ONLY
        self.progress_m = 0.0
        self.done = False
        self._state = "drive"
        self._tracker: ProgressTracker | None = None
        self._driver: CentrelineDriver | None = None
        self._max_progress = -math.inf
        self._turns = 0
        self._back: tuple[CentrelineDriver, float] | None = None
        self._direction = self._next_turn
        self._step = 0
        self._advanced_for: dict | None = None
        # The picture's map is the policy's (``memory``): its bearing input's range says how to
        # read it.
        if config.steers_by == "picture" and memory is not None and memory.kind != "fresh_felt":
            raise ValueError(
                "human steers_by 'picture' reads the fresh_felt map: the policy needs memory"
                " kind 'fresh_felt'"
            )
        self._picture: FreshFeltRule | None = None
        if config.steers_by == "picture":
            turn_deg = config.picture_turn_deg
            self._picture = FreshFeltRule(
                FreshFeltRuleConfig(turn_deg=turn_deg, memory=memory)
                if isinstance(memory, FreshFeltConfig)
                else FreshFeltRuleConfig(turn_deg=turn_deg)
            )
        self._clear_memory = False

    @property
    def records(self) -> bool:
        """Commands after the first ``library_only_commands`` are teaching cases (turn-around
        commands not, under the ``"unrecorded"`` turn-around rule)."""
        if self.phase == PHASE_TURNAROUND and self.config.turnarounds == "unrecorded":
            return False
        if self._nudged:  # a deliberate nudge is not a case
            return False
        return self._past_library_only

    @property
    def _past_library_only(self) -> bool:
        return self._step >= self.config.library_only_commands

    def reset(self) -> None:
        pass  # the protocol spans the whole demonstration, not an episode

    def finished(self, info: dict) -> bool:
        """Whether the protocol is over at the frame with this ``info`` (before perceiving it)."""
        self._advance(info)
        return self.done

    def _advance(self, info: dict) -> None:
        """Move the protocol's state machine to the pose in ``info`` (once per frame)."""
        if info is self._advanced_for or self.done:
            return
        self._advanced_for = info
        pose = np.asarray(info["pose"], dtype=np.float64)
        while True:
            if self._state == "drive":
                leg_track = self.legs[self.leg % 2]
                if self._tracker is None:
                    self._tracker = ProgressTracker(leg_track)
                    self._driver = CentrelineDriver(leg_track, self.config.driver)
                    self._max_progress = -math.inf
                self._tracker.update(pose[:2])
                self.progress_m = self._tracker.progress_m
                self._max_progress = max(self._max_progress, self.progress_m)
                if self.progress_m < leg_track.length_m - self.config.stop_before_end_m:
                    return
                self._start_turnaround(pose)
            assert self._back is not None  # set when the leg's drive ended
            driver, back_progress = self._back
            error = driver.heading_error(pose, back_progress)
            if self._turns < 40 and abs(error) > self._dead_band:
                return
            self.leg += 1
            self._state = "drive"
            self._tracker = None
            if self.leg >= self.config.legs:
                self.done = True
                return
            self._clear_memory = self.config.clear_memory_per_leg
            self._last_pivot = None

    def propose(self, moment: Moment) -> Command | None:
        self._step = moment.step
        self.label = None
        self._nudged = False
        self._advance(moment.info)
        if self.done:
            return None
        pose = moment.pose
        assert pose is not None  # _advance has read the same info["pose"]
        watcher = self.watcher if moment.driving == "policy" else None
        watching = watcher is not None
        if self._state == "drive":
            driver, tracker = self._driver, self._tracker
            assert driver is not None and tracker is not None  # _advance started this leg
            self.phase = PHASE_DRIVE if self._past_library_only else PHASE_LIBRARY_ONLY
            # What the human makes of the picture: every frame, driving or watching.
            seen = self._look(moment)
            if watcher is not None:
                self._watched.append(self.progress_m)
                why = watcher.reason(
                    self.legs[self.leg % 2],
                    driver,
                    tracker,
                    self._max_progress,
                    pose,
                )
                if why is None and watcher.stalled(self._watched):
                    why = "stall"
                if why is None:
                    if self.label_all:
                        self.label = self.person.decide(driver, pose, self.progress_m, seen)
                    return None
                self.interventions[why] += 1
            self._watched.clear()
            nudge = self._nudge_rng
            if (
                nudge is not None
                and not watching
                and self._past_library_only
                and nudge.random() < self.config.nudge_prob
            ):
                self._nudged = True
                self.nudges += 1
                side = Command.LEFT if nudge.random() < 0.5 else Command.RIGHT
                if self.config.nudge_side == "last_pivot" and self._last_pivot is not None:
                    side = self._last_pivot
                return side
            self.label = self.person.decide(driver, pose, self.progress_m, seen)
            if self.label != Command.FORWARD:
                self._last_pivot = self.label
            return self.label
        self._turns += 1
        self.phase = PHASE_TURNAROUND
        if watching:
            self.interventions["turn"] += 1
        self.label = self.person.turn(self._direction)
        return self.label

    def memory_reset(self) -> bool:
        """Whether the policy's memory starts afresh before the next frame: once, when a leg
        begins after a turn-around, with ``clear_memory_per_leg``."""
        clear, self._clear_memory = self._clear_memory, False
        return clear

    def _look(self, moment: Moment) -> Command | None:
        """With ``steers_by = "picture"`` and the library built, the command the picture's map
        calls for; None: steer by the centreline."""
        if self._picture is None or not self._past_library_only:
            return None
        inputs = moment.inputs
        n_map = self._picture.config.memory.n_inputs
        if inputs is None or len(inputs) < n_map:  # the map's inputs come last
            raise ValueError(
                "human steers_by 'picture' reads the fresh_felt map: the policy needs memory"
                " kind 'fresh_felt'"
            )
        return self._picture.act(np.asarray(inputs[-n_map:], dtype=np.float64))

    def _start_turnaround(self, pose: np.ndarray) -> None:
        # Turn round towards the next leg, alternating the direction at every arrival.
        back = self.legs[(self.leg + 1) % 2]
        back_tracker = ProgressTracker(back)
        back_tracker.update(pose[:2])
        self._back = (CentrelineDriver(back, self.config.driver), back_tracker.progress_m)
        self._direction = self._next_turn
        if self.config.turnarounds in ("toward_last_bend", "toward_next_bend"):
            last = self.config.turnarounds == "toward_last_bend"
            turns = self.legs[(self.leg + (0 if last else 1)) % 2].vertex_turns_rad
            bends = turns[np.abs(turns) > 1e-9]
            if len(bends):
                bend = bends[-1] if last else bends[0]
                self._direction = Command.LEFT if bend > 0 else Command.RIGHT
        self.turnarounds.append(self._direction.name.lower())
        if self.config.turnarounds != "one_sided":
            self._next_turn = Command.RIGHT if self._direction == Command.LEFT else Command.LEFT
        self._turns = 0
        self._state = "turn"
