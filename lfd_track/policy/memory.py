"""Memory inputs: what the policy may know besides the current frame (beyond the paper, §6).

The paper's controller is purely reactive: 40 road values of one frame in, one command out. At a
sharp corner whose next strip is out of view (the testing track's 135° corner) the frame alone
cannot say which way the felt went, and a reactive network turns either way (or dithers). A
memory input carries that one fact forward from the commands the robot executed:

* ``"none"`` — no memory (the paper's 40 inputs);
* ``"last_bend"`` — one input saying which way the robot last turned by a whole bend: 1 after a
  left bend, 0 after a right bend, 0.5 before any. A *bend* is :data:`BEND_PIVOTS` (2) more pivots one way
  than the other since the last extreme of the running count (left +1, right -1; forward
  commands count nothing), so a wobble of one pivot left and one right changes nothing while
  two pivots the same way (45° with the paper's 23° pivots, the training track's gentlest bend)
  flip it;
* ``"previous_command"`` — a Jordan network's feedback: three inputs, the one-hot of the command
  executed at the previous step (forward, left, right), all 0 at an episode's first step. The
  network learns what to do with it, where ``last_bend`` fixes a latch by hand.

``previous_command`` feeds back the *executed* command, not the network's three output
activations: on recorded cases the previous executed command is known (teacher forcing: the
human's, or the policy's where it drove), so GA fitness and backprop over the static cases stay
valid, whereas the outputs a network would have produced depend on its own weights and are not
in any recording. The risk is the one of every such input: consecutive commands of a
demonstration mostly agree, so "repeat the previous command" alone already scores high and a
learner may lean on it (copying the last command) instead of on the road; when driving, one
wrong command is then fed back and repeated. Learning from a recording where corrections break
such runs, and reading the training accuracy with that baseline in mind, are the guards.

* ``"fresh_felt"`` — a dead-reckoned map of the felt seen lately, reduced to where the felt the
  robot has *not* driven along lies (:class:`FreshFeltMemory`). Three inputs: the bearing of
  that fresh felt's centre (``(1 + bearing / pi) / 2``: 0.5 straight ahead, above 0.5 to the
  left; with ``bearing_range_deg`` r below 180, ``(1 + bearing / r) / 2`` clipped to [0, 1], so
  that a network whose weights stay small can still tell 20° from straight ahead), how much of
  it there is, and how far its centre lies. Each frame's 40 road values are
  placed on the floor where their regions' centres look (the camera's geometry; the last
  :data:`MAP_FRAMES` frames are kept), and every executed command moves the map by the rover's
  nominal motion for it (a forward step, a pivot; with ``motion = "visual"``, by the motion the
  camera measures between the frames before and after it, :mod:`lfd_track.policy.odometry`,
  and the nominal one where that measurement is not reliable: the perception hands each frame
  to :meth:`FreshFeltMemory.arrive` before its road values). The camera and the motion are the map's
  :class:`~lfd_track.policy.map_geometry.MapGeometry`: with ``geometry = "world"`` (the
  default) those of the world the policy is taught in (the perception passes them; with
  ``geometry = "calibrated"`` the world's camera and the motion a calibration measured there),
  with ``geometry = "paper"`` the paper's constants (the paper preset's camera, forward
  :data:`STEP_M`, a pivot :data:`PIVOT_DEG`), as every map had before the setting. Felt within
  ``path_radius_m`` of a place the rover has been is *visited* (the strip it came along); what is
  left within ``reach_m`` ahead of its axle is *fresh*. At a sharp corner the next strip leaves
  the picture before the rover can turn, but the stub of it seen on the way in stays on the map,
  on the side it went, and the strip behind never counts. While no fresh felt is left the bearing
  input is 0.5, or with ``blank_bearing = "last"`` the bearing the fresh felt last had (which way
  it went: the side to pivot to at a blank corner). ``strip_link_m`` keeps only the felt
  connected *along felt* to the felt the rover stands on — a chain of felt points each within
  ``strip_link_m`` of the next, at most :data:`_STRIP_HOPS` links from felt within
  :data:`_STRIP_SEED_M` of the axle (further for a camera whose nearest region looks further
  ahead than the paper's, :func:`_strip_seed_m`; ``strip_picture_links``: regions touching in one frame's
  grid are linked too) — so that where two strips pass within reach of each other across
  carpet, the one the rover is not on does not pull it off its own; ``blank_reach_m`` looks
  again up to that distance while nothing is fresh within ``reach_m``, for a sharp corner whose
  outgoing strip lies within ``path_radius_m`` of the incoming one for its first half metre
  (``blank_distance = "reach"`` measures the distance input of felt found so against
  ``reach_m``, clipped to 1, so the input means what it means when the map did not look
  further); ``visited_fade_m`` lets a fresh point's weight rise linearly from 0 at
  ``path_radius_m`` from the rover's path to 1 that much further, so of two fresh patches in
  reach the one further from where the rover came from pulls harder (at the vertex of a 135°
  corner, the outgoing strip away from the incoming one, not the corner's tip); ``branch_side``
  adds a fourth input, the side felt branched off the rover's strip over its last metre, and
  ``branch_turn`` a fifth, how far the rover has pivoted toward that side since it was set
  (:mod:`~lfd_track.policy.branch_side`); ``visited_from = "strip"`` also counts felt within
  ``path_radius_m`` of the centre of the felt abeam just behind the axle, marked after each
  forward command, as visited, so that a strip the rover rode along one edge is visited across
  its width (its far half stays fresh otherwise, and at a hairpin a turning rover can stop on it
  and drive back); ``"centreline"`` counts only felt within 0.25 m of those centres (each sought
  along the last one's side offset) and ``"path_and_centreline"`` felt within ``path_radius_m``
  of the path or 0.25 m of the centres
  (``benchmarks/experiments/sharp_corners/README.md``, parts 8-11: of the three, ``"strip"``
  hides a hairpin's outgoing strip and ``"centreline"`` leaves its tip the only fresh felt);
  ``fresh_sight_m`` counts fresh only the felt the straight line from the axle reaches without
  crossing carpet on the map (rastered in cells of that size), so that the next leg of a short
  zig-zag, joined to the rover's strip round the corner and seen across the carpet inside it,
  does not draw the rover across (part 26 there). The settings, their bounds and their defaults (the goal's chosen map: every option above on)
  are :class:`~lfd_track.policy.memory_config.FreshFeltConfig`'s;
  :meth:`~lfd_track.policy.memory_config.FreshFeltConfig.plain` is the map with them off.
  A region's *felt level* rises from 0 at the carpet level to 1 at the felt level of road
  values: fixed at :data:`CARPET_LEVEL` and :data:`FELT_LEVEL` (the paper world's), or with
  ``felt_levels = "library"`` read from the road values the perception's library gave in the
  world it runs in (:mod:`lfd_track.vision.felt_levels`: where this world's carpet values end).
  The map knows nothing the robot could not: its own commands and what its camera saw.

The input is computed from *executed* commands, whoever gave them (the human demonstrating or
correcting, the policy driving), so a recorded case and an autonomous run see the same thing.
The teaching loop owns it through :class:`~lfd_track.teaching.perception.Perception`: the loop
notes each executed command and starts it afresh with each episode.

Length: one module, because the memory kinds share one life cycle (reset, note each executed
command, inputs of the frame, mirror) that the teaching loop, the recordings and the controllers
call alike, and the fresh-felt map's parts (placing the road values, moving by each command,
following the rover's own strip) act on the same arrays step after step; the settings live in
:mod:`~lfd_track.policy.memory_config` and the measured motion in
:mod:`~lfd_track.policy.odometry`.
"""

from __future__ import annotations

import copy
import functools
import math
from typing import TYPE_CHECKING

import numpy as np

from ..core.commands import Command
from ..core.frame import GRID_COLUMNS, N_REGIONS
from .branch_side import UNKNOWN as UNKNOWN_BRANCH
from .branch_side import BranchSide
from .features import frame_inputs
from .map_geometry import PAPER_GEOMETRY, MapGeometry
from .memory_config import (
    BLANK_BEARINGS,
    BLANK_DISTANCES,
    FULL_BEARING_RANGE_DEG,
    MEMORY_CONFIGS,
    MEMORY_KINDS,
    STRIP_STARTS,
    FreshFeltConfig,
    LastBendConfig,
    MemoryConfig,
    NoMemory,
    PreviousCommandConfig,
    memory_config,
    memory_table_from_v1,
)

if TYPE_CHECKING:
    from .odometry import FloorView, PlanarMotion

__all__ = [
    "BLANK_BEARINGS",
    "BLANK_DISTANCES",
    "FULL_BEARING_RANGE_DEG",
    "MEMORY_CONFIGS",
    "MEMORY_KINDS",
    "STRIP_STARTS",
    "UNKNOWN_SIDE",
    "FreshFeltConfig",
    "FreshFeltMemory",
    "LastBendConfig",
    "MapGeometry",
    "MemoryConfig",
    "NoMemory",
    "PreviousCommandConfig",
    "PreviousCommandMemory",
    "TurnMemory",
    "fresh_bearing_rad",
    "memory_config",
    "memory_for",
    "memory_table_from_v1",
    "policy_inputs",
    "region_floor_points",
]

#: Value of the ``last_bend`` input before the first bend of an episode.
UNKNOWN_SIDE = 0.5
#: ``last_bend``: net pivots one way that make a bend (45° with the paper's pivots).
BEND_PIVOTS = 2
#: ``fresh_felt``: frames the map remembers (the path is remembered for 40 commands).
MAP_FRAMES = 25
#: ``fresh_felt``: road value at or below which a region counts as carpet (felt level 0).
CARPET_LEVEL = 0.3
#: ``fresh_felt``: road value at or above which a region counts as felt (felt level 1).
FELT_LEVEL = 0.5
#: [m] ``fresh_felt`` with ``geometry = "paper"``: the advance per forward command (the paper's
#: constant, :data:`~lfd_track.policy.map_geometry.PAPER_GEOMETRY`).
STEP_M = PAPER_GEOMETRY.step_m
#: [deg] ``fresh_felt`` with ``geometry = "paper"``: the turn per pivot command (the paper's
#: constant; the paper preset's rate x period is 22.918 deg).
PIVOT_DEG = PAPER_GEOMETRY.pivot_deg


class TurnMemory:
    """The ``last_bend`` latch over executed commands (see the module docstring)."""

    def __init__(self, config: LastBendConfig) -> None:
        if config.kind != "last_bend":
            raise ValueError(f"TurnMemory implements 'last_bend', not {config.kind!r}")
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Start of an episode: no bend seen yet."""
        self._count = 0
        self._high = 0
        self._low = 0
        self.side = UNKNOWN_SIDE
        """1.0 after a left bend, 0.0 after a right bend, 0.5 before any."""

    def note(self, command: Command | int) -> None:
        """Count one executed command."""
        cmd = int(command)
        if cmd == Command.LEFT:
            self._count += 1
        elif cmd == Command.RIGHT:
            self._count -= 1
        else:
            return
        self._high = max(self._high, self._count)
        self._low = min(self._low, self._count)
        k = BEND_PIVOTS
        if self._count - self._low >= k:
            self.side = 1.0
            self._high = self._low = self._count
        elif self._high - self._count >= k:
            self.side = 0.0
            self._high = self._low = self._count

    def place_before(self, command: Command | int) -> None:
        """The rover stands where ``command`` would bring it here from (no command executed):
        this memory reads executed commands only, so nothing changes."""

    def see(self, values: np.ndarray) -> None:
        """A new frame's road values (this memory reads commands only)."""

    def inputs(self) -> np.ndarray:
        """The memory inputs now, (1,) float64."""
        return np.array([self.side])


class PreviousCommandMemory:
    """The ``previous_command`` feedback: the one-hot of the last executed command."""

    def __init__(self, config: PreviousCommandConfig) -> None:
        if config.kind != "previous_command":
            raise ValueError(
                f"PreviousCommandMemory implements 'previous_command', not {config.kind!r}"
            )
        self.config = config
        self.reset()

    def reset(self) -> None:
        """Start of an episode: no command executed yet (all three inputs 0)."""
        self._inputs = np.zeros(3)

    def note(self, command: Command | int) -> None:
        """The command just executed becomes the next step's input."""
        cmd = int(command)
        if cmd not in (0, 1, 2):
            raise ValueError(f"command must be 0, 1 or 2, got {command!r}")
        self._inputs = np.zeros(3)
        self._inputs[cmd] = 1.0

    def place_before(self, command: Command | int) -> None:
        """The rover stands where ``command`` would bring it here from (no command executed):
        this memory reads executed commands only, so nothing changes."""

    def see(self, values: np.ndarray) -> None:
        """A new frame's road values (this memory reads commands only)."""

    def inputs(self) -> np.ndarray:
        """The memory inputs now, (3,) float64."""
        return self._inputs.copy()


#: Commands of path the ``fresh_felt`` map remembers (4 m of forward driving).
_PATH_COMMANDS = 40
#: [m] ``fresh_felt`` with ``visited_from`` other than ``"path"``: the strip's centre abeam is
#: the felt-weighted mean of the felt points from ``_ABEAM_X_M[0]`` to ``_ABEAM_X_M[1]`` ahead of
#: the axle (behind it: seen by earlier frames) and within ``_ABEAM_LANE_M`` to either side, when
#: their felt sums to at least ``_ABEAM_MIN_FELT``.
_ABEAM_X_M, _ABEAM_LANE_M, _ABEAM_MIN_FELT = (-0.3, -0.1), 0.45, 3.0
#: [m] ``fresh_felt`` with ``visited_from = "centreline"`` or ``"path_and_centreline"``: the felt
#: abeam is taken within this of the last centre's side offset (the strip the rover follows), and
#: felt within this of a centre is visited (the widest strips' half width, 0.225 m, and a margin).
_CENTRELINE_LANE_M = 0.25
#: ``fresh_felt``: weighted felt below this is no fresh felt at all (inputs 0.5, 0, 0).
MIN_FRESH = 1.0
#: ``fresh_felt``: fresh felt counts from this far behind the axle on ([m]; 0: ahead only).
BEHIND_M = 0.05
#: [m] ``fresh_felt`` with ``fresh_sight_m``: the line from the axle to fresh felt is sampled from
#: this far ahead of the axle on, in a raster of the map's points within this either way.
_SIGHT_FROM_M, _SIGHT_WITHIN_M = 0.1, 1.5
#: ``fresh_felt``: the amount input is the weighted fresh felt over this (clipped to 1).
_FULL_FRESH = 20.0
#: ``fresh_felt`` with ``strip_link_m``: felt this close to the axle is the rover's own strip.
_STRIP_SEED_M = 0.3
#: ``fresh_felt`` with ``strip_link_m``: links along felt from the rover's strip at most.
_STRIP_HOPS = 8
#: ``fresh_felt`` with ``strip_link_m``: only felt this close to the axle is linked up [m].
_STRIP_WINDOW_M = 1.2
#: ``fresh_felt`` with ``strip_link_m``: bytes of a map point's row in the table of links, a bit
#: per map point (whole 64-bit words, so rows are OR-ed a word at a time).
_LINK_BYTES = -(-MAP_FRAMES * N_REGIONS // 64) * 8
#: ``fresh_felt`` with ``strip_link_m``: bytes of one frame's points in a row of links (the 40
#: regions fill five bytes, so a frame's bits never share a byte with another frame's).
_FRAME_BYTES = N_REGIONS // 8
#: [m^2] ``fresh_felt`` with ``strip_link_m``: a pair whose squared distance, when the newer of
#: its points is seen, lies this close to the squared link length is measured again at every
#: step (moving the map changes a distance by rounding only, some 1e-15 m^2).
_UNSURE_LINK_M2 = 1e-9


def _strip_seed_m(region_points: np.ndarray) -> float:
    """[m] How near the axle felt counts as the rover's own strip for a camera whose regions'
    centres look at ``region_points``: :data:`_STRIP_SEED_M` (set for the paper's camera, whose
    nearest region looks 0.29 m ahead), grown in proportion where a camera's nearest region looks
    further ahead, so that the seed ring still reaches the nearest row of the picture."""
    nearest = float(np.hypot(region_points[:, 0], region_points[:, 1]).min())
    paper = float(np.hypot(*PAPER_GEOMETRY.floor_points().T).min())
    return max(_STRIP_SEED_M, _STRIP_SEED_M * nearest / paper)


def region_floor_points(geometry: MapGeometry | None = None) -> np.ndarray:
    """(40, 2) float64 floor points [m] (x ahead, y left of the rover's axle) that the centres
    of the 40 regions see with the camera of ``geometry`` (default the paper's: 0.31 m high,
    pitched 30° down; read-only, computed once per geometry)."""
    return (PAPER_GEOMETRY if geometry is None else geometry).floor_points()


def fresh_bearing_rad(inputs: np.ndarray, range_deg: float = FULL_BEARING_RANGE_DEG) -> float:
    """The bearing [rad] (left positive) that ``fresh_felt`` inputs (bearing, amount, distance)
    encode in their first entry, with the bearing input's range ``range_deg`` (a bearing that
    was clipped decodes as the range's end)."""
    if range_deg == FULL_BEARING_RANGE_DEG:
        return (2.0 * float(inputs[0]) - 1.0) * math.pi
    return (2.0 * float(inputs[0]) - 1.0) * math.radians(range_deg)


class FreshFeltMemory:
    """The ``fresh_felt`` map (see the module docstring): felt seen lately, less where the
    rover has been, as (bearing, amount, distance) of what is left."""

    def __init__(self, config: FreshFeltConfig, geometry: MapGeometry | None = None) -> None:
        if config.kind != "fresh_felt":
            raise ValueError(f"FreshFeltMemory implements 'fresh_felt', not {config.kind!r}")
        self.config = config
        self.geometry = (
            PAPER_GEOMETRY if geometry is None or config.geometry == "paper" else geometry
        )
        """The camera and motion the map assumes: ``geometry`` (the world's, or its calibration's)
        with ``config.geometry = "world"`` or ``"calibrated"``, else (or without one) the paper's
        constants."""
        self._region_points = self.geometry.floor_points()
        self._seed_m = _strip_seed_m(self._region_points)
        self._step = self.geometry.step_m
        angle = math.radians(self.geometry.pivot_deg)
        self._cos, self._sin = math.cos(angle), math.sin(angle)
        # motion = "visual": the camera measures each command's motion (imported here: the
        # nominal map needs no image code).
        self._odometry = None
        if config.motion == "visual":
            from .odometry import floor_odometry

            self._odometry = floor_odometry(self.geometry, config.registration)
        self._branch = (
            BranchSide(config.branch_window, self.geometry.pivot_deg, config.branch_turn_from)
            if config.branch_side
            else None
        )
        self.reset()

    def __copy__(self) -> FreshFeltMemory:
        """A snapshot (the perception keeps one before each frame, and views place a copy of it
        elsewhere): the arrays are shared, since the map replaces them and never writes them,
        and the branch side's state is copied, since it changes in place."""
        twin = object.__new__(FreshFeltMemory)
        twin.__dict__.update(self.__dict__)
        if self._branch is not None:
            twin._branch = copy.copy(self._branch)
        return twin

    def reset(self) -> None:
        """Start of an episode: nothing seen, nowhere been."""
        self._points = np.zeros((0, 2))  # the remembered frames' floor points, oldest first
        self._felt = np.zeros(0)  # their felt levels in [0, 1]
        self._path = np.zeros((0, 2))  # places the rover has been, before the current one
        # visited_from other than "path": the strip's centres abeam after forward commands, and
        # whether the last command the map moved by was a forward one
        self._centres = np.zeros((0, 2))
        self._forward = False
        # visited_from = "centreline" or "path_and_centreline": the side offset the centre is
        # sought at (None: not following a strip, after a pivot or where none was found)
        self._lane_y: float | None = None
        self._inputs = np.array([0.5, 0.0, 0.0])
        self._side = UNKNOWN_BRANCH  # branch_side: the fourth input
        self._turn = UNKNOWN_BRANCH  # branch_turn: the fifth (no side, no turn)
        if self._branch is not None:
            self._branch.reset()
        # With strip_link_m, the links among the points' felt (bit j of row i: points i and j
        # at most strip_link_m apart, or touching regions of one frame with picture links).
        # Moving the map moves every point alike, so a pair's distance is measured once, when
        # the newer point is seen; pairs measured too close to the link length to be sure are
        # kept apart (index pairs) and measured again each step.
        self._linked = np.zeros((0, _LINK_BYTES), dtype=np.uint8)
        self._unsure = np.zeros((0, 2), dtype=np.int64)
        # motion = "visual": the command executed whose frame has not arrived yet, and the floor
        # view of the last frame that did.
        self._pending: int | None = None
        self._view: FloorView | None = None
        self.bearing_deg: float | None = None
        """The fresh felt's bearing after the last frame [deg, left positive], before the
        bearing input clips it to ``bearing_range_deg``; None while the map is blank."""
        self.visual_moves = 0
        """motion = "visual": this episode's commands the map moved by the measured motion."""
        self.nominal_moves = 0
        """motion = "visual": this episode's commands moved by the nominal one (no reliable
        measurement, or no frame)."""

    def _moved(self, points: np.ndarray, command: int) -> np.ndarray:
        """``points`` (N, 2) in the rover frame after it executed ``command`` (element by
        element, so the same bits on every processor)."""
        if command == Command.FORWARD:
            return points - np.array([self._step, 0.0])
        # A pivot turns the rover by +-angle: the map turns the other way.
        sin = -self._sin if command == Command.LEFT else self._sin
        x, y = points[:, 0], points[:, 1]
        return np.column_stack([self._cos * x - sin * y, sin * x + self._cos * y])

    def note(self, command: Command | int) -> None:
        """The rover executed ``command``: move the map by its nominal motion (with ``motion =
        "visual"``, by the motion measured when the frame after it arrives, :meth:`arrive`)."""
        cmd = int(command)
        if cmd not in (0, 1, 2):
            raise ValueError(f"command must be 0, 1 or 2, got {command!r}")
        if self._odometry is not None:
            self._settle_without_frame()  # two commands without a frame between them
            self._pending = cmd
            return
        self._move(cmd)

    def arrive(self, frame: np.ndarray) -> None:
        """With ``motion = "visual"``: the camera's frame ((H, W, 3) uint8) after the last
        executed command, before its road values are seen. The map moves by the motion
        :class:`~lfd_track.policy.odometry.FloorOdometry` measures between the previous frame
        and this one, or by the command's nominal motion where that measurement is not
        reliable or no previous frame arrived; a frame of another size than the map's camera
        (a controller driving on frames of another size than it learned on) is measured nothing
        from, as if it had not arrived. Without ``motion = "visual"`` nothing happens."""
        if self._odometry is None:
            return
        if np.shape(frame)[:2] != self._odometry.frame_shape:
            self._settle()
            self._view = None
            return
        view = self._odometry.view(frame)
        if self._pending is not None:
            measured = None
            if self._view is not None:
                found = self._odometry.motion(self._view, view, self._nominal(self._pending))
                measured = found.motion if found.reliable else None
            self._settle(measured)
        self._view = view

    def _nominal(self, command: int) -> PlanarMotion:
        """The geometry's motion for ``command`` (a forward step, or a pivot)."""
        from .odometry import PlanarMotion

        if command == Command.FORWARD:
            return PlanarMotion(self._step, 0.0, 0.0)
        pivot = self.geometry.pivot_deg
        return PlanarMotion(0.0, 0.0, pivot if command == Command.LEFT else -pivot)

    def _settle(self, measured: PlanarMotion | None = None) -> None:
        """Move the map by the pending command's ``measured`` motion (None: its nominal one)."""
        command, self._pending = self._pending, None
        if command is None:
            return
        self._move(command, measured)
        if measured is None:
            self.nominal_moves += 1
        else:
            self.visual_moves += 1

    def _settle_without_frame(self) -> None:
        """A pending command whose frame never arrived: its nominal motion, and the last view
        forgotten (the next frame's motion from it would span two commands)."""
        if self._pending is not None:
            self._settle()
            self._view = None

    def _move(self, command: int, measured: PlanarMotion | None = None) -> None:
        """Move the map and the path by ``command``'s ``measured`` motion (None: its nominal
        one)."""
        path = np.vstack([self._path, np.zeros((1, 2))])[-_PATH_COMMANDS:]
        if self._branch is not None:
            self._branch.moved(command)
        self._forward = command == Command.FORWARD
        if measured is None:
            self._points = self._moved(self._points, command)
            self._path = self._moved(path, command)
            self._centres = self._moved(self._centres, command)
        else:
            self._points = measured.move_points(self._points)
            self._path = measured.move_points(path)
            self._centres = measured.move_points(self._centres)

    def place_before(self, command: Command | int) -> None:
        """The rover stands where ``command`` would bring it here from: one step behind for a
        forward command, turned one pivot the other way for a pivot (the command's nominal
        motion undone). The map and the path move with it; no place is added to the path."""
        cmd = int(command)
        if cmd not in (0, 1, 2):
            raise ValueError(f"command must be 0, 1 or 2, got {command!r}")
        self._settle_without_frame()
        if cmd == Command.FORWARD:
            back = np.array([self._step, 0.0])
            self._points, self._path = self._points + back, self._path + back
            self._centres = self._centres + back
            return
        undo = Command.RIGHT if cmd == Command.LEFT else Command.LEFT
        self._points = self._moved(self._points, undo)
        self._path = self._moved(self._path, undo)
        self._centres = self._moved(self._centres, undo)

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        """Add a frame's road values (40,) to the map and compute the inputs. ``levels``:
        the road values ``(carpet, felt)`` of felt levels 0 and 1 (with ``felt_levels =
        "library"``, from :class:`~lfd_track.vision.felt_levels.RoadValueLevels`); None: the
        fixed :data:`CARPET_LEVEL` and :data:`FELT_LEVEL`."""
        self._settle_without_frame()
        cfg = self.config
        v = np.asarray(values, dtype=np.float64).reshape(N_REGIONS)
        carpet, felt_at = (CARPET_LEVEL, FELT_LEVEL) if levels is None else levels
        felt = np.clip((v - carpet) / (felt_at - carpet), 0.0, 1.0)
        keep = MAP_FRAMES * N_REGIONS
        full = len(self._points) == keep  # the oldest frame leaves the map
        self._points = np.vstack([self._points, self._region_points])[-keep:]
        self._felt = np.concatenate([self._felt, felt])[-keep:]
        if cfg.strip_link_m:
            self._link_newest_frame(full)
        if self._branch is not None:
            self._side = self._branch.see(self._points, self._felt, self._path, N_REGIONS)
            self._turn = self._branch.turned()
        if cfg.visited_from != "path":
            if self._forward:
                self._mark_strip_centre()
            else:
                self._lane_y = None
        self._forward = False
        points = self._points
        dist = np.hypot(points[:, 0], points[:, 1])
        ahead = points[:, 0] > -BEHIND_M
        if cfg.strip_link_m:
            ahead &= self._own_strip(dist)
        reach = cfg.reach_m
        weights = self._fresh(dist < reach, ahead)
        mass = float(weights.sum())
        if mass < MIN_FRESH and cfg.blank_reach_m:  # nothing near: look further
            weights = self._fresh(dist < cfg.blank_reach_m, ahead)
            mass = float(weights.sum())
            if cfg.blank_distance == "blank_reach":
                reach = cfg.blank_reach_m
        if mass < MIN_FRESH:
            last = self._inputs[0] if cfg.blank_bearing == "last" else 0.5
            self._inputs = np.array([last, 0.0, 0.0])
            self.bearing_deg = None
            if self._branch is not None:
                self._side = self._branch.contradicted(self._side, None)
            return
        centre_x = float((weights * points[:, 0]).sum()) / mass
        centre_y = float((weights * points[:, 1]).sum()) / mass
        bearing = math.atan2(centre_y, centre_x)
        self.bearing_deg = math.degrees(bearing)
        if self._branch is not None:
            self._side = self._branch.contradicted(self._side, bearing)
        if cfg.bearing_range_deg == FULL_BEARING_RANGE_DEG:  # the same bits as before the option
            encoded = 0.5 * (1.0 + bearing / math.pi)
        else:
            half = 0.5 * (1.0 + bearing / math.radians(cfg.bearing_range_deg))
            encoded = min(1.0, max(0.0, half))
        self._inputs = np.array(
            [
                encoded,
                min(1.0, mass / _FULL_FRESH),
                min(1.0, math.hypot(centre_x, centre_y) / reach),
            ]
        )

    def _mark_strip_centre(self) -> None:
        """With ``visited_from`` other than ``"path"``: add the centre of the felt abeam
        just behind the axle (:data:`_ABEAM_X_M`) to the places whose felt counts as visited,
        when there is felt enough there. ``"strip"`` takes the felt within
        :data:`_ABEAM_LANE_M` of the axle; ``"centreline"`` and ``"path_and_centreline"`` within
        :data:`_CENTRELINE_LANE_M` of the last centre's side offset while the rover drives on, so
        that a strip running beside its own (a hairpin's outgoing one) does not pull it over, and
        after a pivot or where none was found within :data:`_CENTRELINE_LANE_M` of the axle
        (``"centreline"``) or :data:`_ABEAM_LANE_M` (``"path_and_centreline"``: a strip the
        rover rides beside)."""
        x, y = self._points[:, 0], self._points[:, 1]
        visited_from = self.config.visited_from
        if self._lane_y is not None and visited_from != "strip":  # following a strip
            lane = np.abs(y - self._lane_y) <= _CENTRELINE_LANE_M
        else:
            lane = np.abs(y) <= (
                _CENTRELINE_LANE_M if visited_from == "centreline" else _ABEAM_LANE_M
            )
        abeam = (x >= _ABEAM_X_M[0]) & (x <= _ABEAM_X_M[1]) & lane
        weights = self._felt * abeam
        mass = float(weights.sum())
        if mass < _ABEAM_MIN_FELT:
            self._lane_y = None
            return
        centre = [float((weights * x).sum()) / mass, float((weights * y).sum()) / mass]
        self._lane_y = centre[1]
        self._centres = np.vstack([self._centres, centre])[-_PATH_COMMANDS:]

    def _kept(self, where: np.ndarray) -> np.ndarray | None:
        """(N,) float64: how much of the felt of each map point ``where`` (N,) bool is fresh for
        having lain away from every place the rover has been — 0 within ``path_radius_m`` of one,
        else 1, or with ``visited_fade_m`` rising linearly to 1 that much further (with
        ``visited_from``, from the strip's centres too or instead); 0 at the other points (None
        before the rover has been anywhere)."""
        if not len(self._path):
            return None
        visited_from = self.config.visited_from
        chosen, centres = self._points[where], self._centres
        marks, radius = self._path, self.config.path_radius_m
        if len(centres) and visited_from == "centreline":
            marks, radius = centres, _CENTRELINE_LANE_M
        elif len(centres) and visited_from == "strip":
            marks = np.vstack([marks, centres])
        kept = np.zeros(len(self._points))
        kept[where] = self._away(chosen, marks, radius)
        if len(centres) and visited_from == "path_and_centreline":
            kept[where] = np.minimum(kept[where], self._away(chosen, centres, _CENTRELINE_LANE_M))
        return kept

    def _away(self, chosen: np.ndarray, marks: np.ndarray, radius: float) -> np.ndarray:
        """(N,) float64: how fresh each of the points ``chosen`` (N, 2) is for lying away from
        every one of ``marks`` (M, 2): 0 within ``radius``, else 1, or with ``visited_fade_m``
        rising linearly to 1 that much further."""
        gap_x = chosen[:, 0, None] - marks[None, :, 0]
        gap_y = chosen[:, 1, None] - marks[None, :, 1]
        nearest = (gap_x * gap_x + gap_y * gap_y).min(axis=1)
        fade = self.config.visited_fade_m
        if not fade:
            return (nearest > radius**2).astype(np.float64)
        return np.clip((np.sqrt(nearest) - radius) / fade, 0.0, 1.0)

    def _fresh(self, near: np.ndarray, ahead: np.ndarray) -> np.ndarray:
        """Weights of the felt that is fresh: felt ``near`` the axle (within the reach) and
        ``ahead`` of it (and on the rover's own strip, with ``strip_link_m``), times what
        :meth:`_kept` keeps of it."""
        inside = near & ahead
        weights = self._felt * inside
        kept = self._kept(inside & (self._felt > 0.0))  # only felt inside can weigh
        if kept is not None:
            weights = weights * kept
        cell = self.config.fresh_sight_m
        if cell:
            where = np.flatnonzero(weights > 0.0)
            weights[where[_across_carpet(self._points, self._felt, where, cell)]] = 0.0
        return weights

    def _link_newest_frame(self, full: bool) -> None:
        """Add the links of the newest frame's felt to the table of links (:meth:`reset`); with
        ``full`` the oldest frame has just left the map, and its links with it."""
        n = len(self._points)
        first = n - N_REGIONS  # the newest frame's first point
        frame = first // N_REGIONS
        table = np.zeros((n, _LINK_BYTES), dtype=np.uint8)
        unsure = self._unsure
        if full:
            table[:first, : _LINK_BYTES - _FRAME_BYTES] = self._linked[N_REGIONS:, _FRAME_BYTES:]
            unsure = unsure[(unsure >= N_REGIONS).all(axis=1)] - N_REGIONS
        else:
            table[:first] = self._linked
        felt = np.flatnonzero(self._felt >= 0.5)
        newest = felt[felt >= first]
        if len(newest):
            points = self._points
            gap_x = points[newest, 0, None] - points[None, felt, 0]
            gap_y = points[newest, 1, None] - points[None, felt, 1]
            squared = gap_x * gap_x + gap_y * gap_y
            link_squared = self.config.strip_link_m**2
            unclear = np.abs(squared - link_squared) <= _UNSURE_LINK_M2
            linked = (squared <= link_squared) & ~unclear
            if unclear.any():
                pairs = np.nonzero(unclear)
                unsure = np.concatenate(
                    [unsure, np.column_stack([newest[pairs[0]], felt[pairs[1]]])]
                )
            rows = np.zeros((len(newest), 8 * _LINK_BYTES), dtype=bool)
            rows[:, felt] = linked
            if self.config.strip_picture_links:
                rows[:, first:n] |= _touching_regions()[newest - first]
            table[newest] = np.packbits(rows, axis=1, bitorder="little")
            # The older felt's rows get the newest frame's bytes: the bits of the regions each
            # is linked to, summed as whole numbers (exact in float64).
            older = felt < first
            bits = linked[:, older].T.astype(np.float64) @ _region_bits()[newest - first]
            columns = slice(frame * _FRAME_BYTES, (frame + 1) * _FRAME_BYTES)
            table[felt[older], columns] = bits.astype(np.uint8)
        self._linked, self._unsure = table, unsure

    def _own_strip(self, dist: np.ndarray) -> np.ndarray:
        """(N,) bool: map points on felt connected along felt to the felt the rover stands on
        (links of at most ``strip_link_m``, at most :data:`_STRIP_HOPS` of them, among felt points
        within :data:`_STRIP_WINDOW_M`; see the module docstring)."""
        return self._strip_hops(dist) >= 0

    def _strip_hops(self, dist: np.ndarray) -> np.ndarray:
        """(N,) int: by how many links each map point is first reached from the felt the rover
        stands on (0: that felt itself; -1: off the rover's strip), as :meth:`_own_strip` joins
        them; ``dist`` (N,): each point's distance from the axle."""
        hops = np.full(len(dist), -1)
        candidate = (dist < _STRIP_WINDOW_M) & (self._felt >= 0.5)
        if not candidate.any():
            return hops
        seed_m = self._seed_m
        if self.config.strip_from == "nearest":
            seed_m = max(seed_m, float(dist[candidate].min()) + self.config.strip_link_m)
        reached = candidate & (dist <= seed_m)
        hops[reached] = 0
        src, dst = self._unsure_links(candidate)
        frontier = reached  # the points reached by the last hop
        for hop in range(1, _STRIP_HOPS + 1):
            words = self._linked[frontier].view(np.uint64)
            near = np.bitwise_or.reduce(words, axis=0).view(np.uint8)
            linked = np.unpackbits(near, count=len(dist), bitorder="little").view(bool)
            if len(src):
                linked[dst[frontier[src]]] = True
            frontier = linked & candidate & ~reached
            if not frontier.any():
                break
            hops[frontier] = hop
            reached = reached | frontier
        return hops

    def _unsure_links(self, candidate: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The links among the pairs kept apart as unsure (:meth:`reset`) whose points are both
        ``candidate`` (N,) bool, measured now, as index arrays ``(src, dst)`` of both ways."""
        pairs = self._unsure[candidate[self._unsure].all(axis=1)]
        if not len(pairs):
            return pairs[:, 0], pairs[:, 1]
        gap = self._points[pairs[:, 0]] - self._points[pairs[:, 1]]
        pairs = pairs[np.einsum("ij,ij->i", gap, gap) <= self.config.strip_link_m**2]
        return np.concatenate([pairs[:, 0], pairs[:, 1]]), np.concatenate(
            [pairs[:, 1], pairs[:, 0]]
        )

    def inputs(self) -> np.ndarray:
        """The memory inputs now, (3,) float64: bearing, amount, distance, each in [0, 1]; with
        ``branch_side`` (4,): and the side felt branched off (:mod:`.branch_side`); with
        ``branch_turn`` (5,): and the turn toward that side since it was set."""
        if self._branch is None:
            return self._inputs.copy()
        if self.config.branch_turn:
            return np.append(self._inputs, [self._side, self._turn])
        return np.append(self._inputs, self._side)


def _across_carpet(
    points: np.ndarray, felt: np.ndarray, where: np.ndarray, cell: float
) -> np.ndarray:
    """(P,) bool: whether the straight line from the axle to each of the map points ``where``
    (P,) crosses carpet (``fresh_sight_m``). The map's points within :data:`_SIGHT_WITHIN_M`
    either way are rastered in squares of ``cell`` metres, a square's felt the mean of its
    points' (a square with no point is not carpet: nothing was seen there); the line is sampled
    every ``cell`` from :data:`_SIGHT_FROM_M` ahead of the axle to one cell short of the point,
    and crosses carpet where a sample falls in a square whose felt is below 0.5."""
    half = int(_SIGHT_WITHIN_M / cell) + 1
    size = 2 * half + 1
    inside = (np.abs(points) < _SIGHT_WITHIN_M).all(axis=1)
    keys = np.floor(points[inside] / cell).astype(np.int64) + half
    index = keys[:, 0] * size + keys[:, 1]
    total = np.bincount(index, weights=felt[inside], minlength=size * size)
    count = np.bincount(index, minlength=size * size)
    carpet = (count > 0) & (total < 0.5 * count)
    targets = points[where]
    length = np.hypot(targets[:, 0], targets[:, 1])
    steps = np.arange(_SIGHT_FROM_M, _SIGHT_WITHIN_M, cell)
    unit = targets / np.maximum(length, 1e-9)[:, None]
    cells = np.floor(unit[:, None, :] * steps[None, :, None] / cell).astype(np.int64) + half
    cells = np.clip(cells, 0, size - 1)
    sampled = steps[None, :] < length[:, None] - cell
    return (carpet[cells[..., 0] * size + cells[..., 1]] & sampled).any(axis=1)


@functools.lru_cache(maxsize=1)
def _region_bits() -> np.ndarray:
    """(40, 5) float64: region r's bit in the five bytes of its frame in a row of links
    (2 ** (r % 8) in byte r // 8; sums of them are whole numbers below 256, exact in float64)."""
    regions = np.arange(N_REGIONS)
    bits = np.zeros((N_REGIONS, _FRAME_BYTES))
    bits[regions, regions // 8] = 2.0 ** (regions % 8)
    bits.flags.writeable = False
    return bits


@functools.lru_cache(maxsize=1)
def _touching_regions() -> np.ndarray:
    """(40, 40) bool: the pairs of regions that touch in the 8 x 5 grid (side or corner)."""
    row, column = np.divmod(np.arange(N_REGIONS), GRID_COLUMNS)
    touching = (np.abs(row[:, None] - row[None, :]) <= 1) & (
        np.abs(column[:, None] - column[None, :]) <= 1
    )
    np.fill_diagonal(touching, False)
    touching.flags.writeable = False
    return touching


def policy_inputs(config: MemoryConfig | None, features: str = "road_values") -> int:
    """Inputs of a network with memory ``config`` (None: no memory) reading the per-region
    ``features`` (:mod:`lfd_track.policy.features`; default the paper's 40 road values)."""
    return frame_inputs(features) + (config or NoMemory()).n_inputs


def memory_for(
    config: MemoryConfig | None, geometry: MapGeometry | None = None
) -> TurnMemory | PreviousCommandMemory | FreshFeltMemory | None:
    """The memory part for ``config`` (None for no memory); a ``fresh_felt`` map with
    ``geometry = "world"`` or ``"calibrated"`` takes ``geometry`` (the world's, or its
    calibration's; None: the paper's constants)."""
    if isinstance(config, PreviousCommandConfig):
        return PreviousCommandMemory(config)
    if isinstance(config, FreshFeltConfig):
        return FreshFeltMemory(config, geometry)
    if isinstance(config, LastBendConfig):
        return TurnMemory(config)
    return None
