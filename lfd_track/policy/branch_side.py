"""The ``fresh_felt`` map's fourth input (``branch_side``): which side felt branched off the
rover's strip over its last metre of driving.

At a corner sharper than the camera can see round, the map's bearing of fresh felt often points
the wrong way at the vertex (the corner's tip, read from a rover riding the strip's inner edge,
lies to the outer side), while the felt that left the strip on the way in says which side the
corner turns. This input carries that: 1 when the felt branched off to the left, 0 to the right,
0.5 when it gives no side. It is a fact of the map for a learner to weigh, not a command; the
hand-written rule on the same inputs uses it only while the map has no fresh felt
(:class:`~lfd_track.teaching.handwritten.FreshFeltRule`).

Computed at every frame from the map's own arrays (rover frame: x ahead, y left of the axle):

1. the path's direction u: walking back from the axle along the places the rover has been, the
   oldest place p within :data:`PATH_M` of path; none while ``|p|`` < :data:`MIN_PATH_M` (the
   frame adds nothing); else u = -p / ``|p|`` and n = u turned 90° left;
2. over felt points (level >= 0.5), s = point . u and l = point . n; the strip's centre c is the
   felt-weighted mean of l over points with -:data:`BEHIND_M` <= s <= 0 and ``|l|`` <
   :data:`LANE_M` (0 when their felt sums below :data:`MIN_LANE_FELT`);
3. the frame's value b: the felt levels times the sign of l - c, summed over points with
   0 < s <= :data:`AHEAD_M` and :data:`NEAR_M` < ``|l - c|`` < :data:`FAR_M` (felt off to one
   side of the strip ahead);
4. the side: the sign of the sum of b over the frames seen since the last
   :data:`WINDOW_FORWARD` forward commands (1 m of the paper's steps), when its size exceeds
   :data:`MIN_SUM`; else none. With ``branch_window = "commands"``, over the frames that
   followed a forward command among the last :data:`WINDOW_FORWARD` commands of any kind: a
   frame seen after a pivot adds nothing, and pivots count toward the window, so the side
   expires while the rover only pivots (with ``"forward"`` it never does, and every frame seen
   while pivoting adds the whole map's branching felt again: a side that is stale after a corner
   keeps growing; ``benchmarks/experiments/human_goal/round07/README.md``). With
   ``branch_window = "new_felt"``, as with ``"commands"``, and each frame's value counts only
   the felt that frame placed (the map's newest points), not the whole map's again: felt that
   branched off is counted once for each forward step the camera sees it, not once for each
   step it stays on the map.
   With ``branch_window = "heading"``, as with ``"commands"``, and a frame's value is also
   forgotten once the rover has turned more than :data:`TURNED_DEG` from its heading when it saw
   the frame (net pivots times the map's pivot angle): a side says where the felt branched off
   relative to the rover as it was then, and after a quarter turn toward it the branch lies ahead,
   after a quarter turn away it lies behind; either way it no longer says which way to pivot.
   With ``branch_window = "behind"``, as with ``"commands"``, and the side is forgotten (every
   frame's value dropped) when the map's fresh felt lies more than :data:`BEHIND_DEG` off to the
   other side: felt the rover has turned its back on, on the side opposite the one the input
   gives, says that side is wrong (``benchmarks/experiments/human_goal/round11/README.md``).
   With ``branch_window = "crossed"``, as with ``"commands"``, and the side is spent (every
   frame's value dropped) once a pivot toward it has carried the fresh felt across from the
   side's own side to the other: the rover has turned past the felt the side pointed it to
   (``benchmarks/experiments/human_goal/round10/README.md``, the reversal trace). A corner's
   tip read on the outer side from the start does not spend it.
   With ``branch_window = "blank"``, as with ``"commands"``, and the input gives the side only
   while the map has no fresh felt (none otherwise; the frames' values are kept): the input as
   the hand-written rule on it uses it, for a learner to weigh
   (``benchmarks/experiments/human_goal/round16/README.md``).

With the map's ``branch_turn`` option, a fifth input says how far the rover has pivoted toward
the side since the side was set (:meth:`BranchSide.turned`): the net pivots toward it since the
frame that first gave it, times the map's pivot angle, over 360° and shifted to 0.5 (0.5: no
turn, or no side; 0.75: a half turn toward it; 0.25: a half turn away; clipped to [0, 1]). A
mirrored frame has the same value (the side and the pivots both change side). It is the
side's age in heading, for a learner to weigh when a side is stale: after a corner's turn the
side still names the corner's own side, and only how far the rover has turned since tells a
corner not yet turned from one already turned (``benchmarks/experiments/human_goal/round17/
README.md``). It reads the side :meth:`~BranchSide.see` gives, before :meth:`~BranchSide.
contradicted` (with ``"blank"`` the side is kept while it is not given). On a loop the side
is given on nearly every frame (the strip curving ahead counts as felt off to that side), so a
side once set stays set over several corners and its turn adds them up
(``benchmarks/experiments/human_goal/round17/results/turn_coverage.md``); with
``branch_turn_from = "seen"`` the turn counts instead from the newest frame in the window that saw
felt branch off on the side's side: while the rover drives on along a curve it stays near 0.5,
and it grows while the rover pivots, since a frame seen after a pivot adds nothing
(``"commands"``).

The estimator and its constants are those scored offline on 126 corners over 100° in
``benchmarks/experiments/sharp_corners/vertex/turn_side.md`` (right at 76 of the 81 arrivals
where it gives a side). Everything in it is the robot's own: its commands and its camera.
"""

from __future__ import annotations

import math

import numpy as np

from ..core.commands import Command

#: [m] path length that gives the path's direction; shorter than MIN_PATH_M: no frame value
PATH_M, MIN_PATH_M = 0.5, 0.15
#: [m] the strip's centre from felt between BEHIND_M behind the axle and the axle, within LANE_M
BEHIND_M, LANE_M, MIN_LANE_FELT = 0.5, 0.5, 3.0
#: [m] branching felt: ahead up to AHEAD_M, between NEAR_M and FAR_M off the strip's centre
AHEAD_M, NEAR_M, FAR_M = 1.2, 0.3, 1.0
#: forward commands the side looks back over (1 m of the paper's steps), and the sum it needs
WINDOW_FORWARD, MIN_SUM = 10, 2.0
#: which frames the side sums (``branch_window``; see the module docstring)
WINDOWS = ("forward", "commands", "new_felt", "heading", "behind", "crossed", "blank")
#: [deg] with ``"heading"``: a frame's value is forgotten once the rover has turned more than this
TURNED_DEG = 90.0
#: [deg] with ``"behind"``: fresh felt further off than this, on the other side, ends the side
BEHIND_DEG = 90.0
#: the input's value while no side is known
UNKNOWN = 0.5
#: [deg] ``branch_turn``: the turn toward the side that moves its input from 0.5 to 1
TURN_SCALE_DEG = 180.0
#: where ``branch_turn`` counts the turn from (``branch_turn_from``; see :meth:`BranchSide.turned`)
TURN_FROM = ("set", "seen")


def path_direction(path: np.ndarray) -> np.ndarray | None:
    """u (2,): the unit direction the rover came along its ``path`` (M, 2) of places before the
    current one, oldest first; None while the path is too short."""
    places = np.vstack([path, np.zeros((1, 2))])
    steps = np.hypot(*np.diff(places, axis=0).T)
    back = np.concatenate([[0.0], np.cumsum(steps[::-1])])  # arc length from the axle back
    within = np.flatnonzero(back <= PATH_M)
    p = places[::-1][within[-1]]
    size = float(np.hypot(*p))
    return None if size < MIN_PATH_M else -p / size


def frame_value(points: np.ndarray, felt: np.ndarray, path: np.ndarray) -> float:
    """b: felt branching off to the left (+) or the right (-) of the rover's strip ahead, for the
    map's ``points`` (N, 2), their ``felt`` levels (N,) and the ``path`` (M, 2)."""
    u = path_direction(path)
    if u is None:
        return 0.0
    on = felt >= 0.5
    x, y, w = points[on, 0], points[on, 1], felt[on]
    # element by element (no BLAS product), so the same bits on every processor, as the map's own
    s, lat = x * u[0] + y * u[1], y * u[0] - x * u[1]  # along u, and along n = u turned 90° left
    lane = (s >= -BEHIND_M) & (s <= 0.0) & (np.abs(lat) < LANE_M)
    lane_felt = float(w[lane].sum())
    c = float((w[lane] * lat[lane]).sum()) / lane_felt if lane_felt >= MIN_LANE_FELT else 0.0
    off = lat - c
    branch = (s > 0.0) & (s <= AHEAD_M) & (np.abs(off) > NEAR_M) & (np.abs(off) < FAR_M)
    return float((w[branch] * np.sign(off[branch])).sum())


class BranchSide:
    """The side input's state over an episode: the frames' values b since the last
    :data:`WINDOW_FORWARD` forward commands."""

    def __init__(
        self, window: str = "forward", pivot_deg: float = 22.9, turn_from: str = "set"
    ) -> None:
        if window not in WINDOWS:
            raise ValueError(f"branch window must be one of {WINDOWS}, got {window!r}")
        if turn_from not in TURN_FROM:
            raise ValueError(f"branch turn_from must be one of {TURN_FROM}, got {turn_from!r}")
        self.window = window
        self.turn_from = turn_from
        """:meth:`turned` counts from the frame that set the side (``"set"``) or from the newest
        frame in the window that saw felt branch off on the side's side (``"seen"``)."""
        self.pivot_deg = pivot_deg
        """[deg] the map's turn per pivot (``"heading"``, :meth:`turned`)."""
        self.reset()

    def reset(self) -> None:
        """Start of an episode: no frame seen, no side."""
        # (commands counted before it, net pivots before it, b) per frame
        self._values: list[tuple[int, int, float]] = []
        self._count = 0  # forward commands ("forward") or all commands (the others) so far
        self._turns = 0  # net pivots so far, left positive
        self._after_forward = True  # the last command was a forward one (or none yet)
        self._last: int | None = None  # the last command the map moved by
        self._bearing: float | None = None  # the fresh felt's bearing at the last frame
        self._set_sign = 0  # the side see() last gave: 1 left, -1 right, 0 none
        self._set_turns = 0  # net pivots when that side was first given

    def __copy__(self) -> BranchSide:
        """A snapshot that the original's later frames leave as it is (its own list of values),
        as a shallow copy of the map that holds it must be."""
        twin = object.__new__(BranchSide)
        twin.__dict__.update(self.__dict__)
        twin._values = list(self._values)
        return twin

    def moved(self, command: int) -> None:
        """The map moved by an executed ``command``."""
        forward = command == Command.FORWARD
        if forward or self.window != "forward":
            self._count += 1
        if command == Command.LEFT:
            self._turns += 1
        elif command == Command.RIGHT:
            self._turns -= 1
        self._after_forward = forward
        self._last = command

    def see(self, points: np.ndarray, felt: np.ndarray, path: np.ndarray, new: int) -> float:
        """The input after a frame was added to the map (``points``, ``felt``, ``path`` as in
        :func:`frame_value`; the frame placed the last ``new`` points): 1 left, 0 right,
        :data:`UNKNOWN` none."""
        if self.window == "forward" or self._after_forward:
            if self.window == "new_felt":
                points, felt = points[-new:], felt[-new:]
            self._values.append((self._count, self._turns, frame_value(points, felt, path)))
        turned = TURNED_DEG / self.pivot_deg if self.window == "heading" else math.inf
        self._values = [
            (f, t, b)
            for f, t, b in self._values
            if self._count - f <= WINDOW_FORWARD and abs(self._turns - t) <= turned
        ]
        total = sum(b for _, _, b in self._values)
        sign = 0 if abs(total) <= MIN_SUM else (1 if total > 0 else -1)
        if sign != self._set_sign:  # a new side (or none): its turn counts from here
            self._set_sign, self._set_turns = sign, self._turns
        if sign and self.turn_from == "seen":  # from the newest frame that saw felt that side
            self._set_turns = next(t for _, t, b in reversed(self._values) if b * sign > 0)
        return UNKNOWN if sign == 0 else (1.0 if sign > 0 else 0.0)

    def turned(self) -> float:
        """The ``branch_turn`` input after :meth:`see`: the net turn toward the side since the
        frame that first gave it (``turn_from = "set"``) or since the newest frame in the window
        whose felt branched off on that side (``"seen"``), as 0.5 + turn / (2 *
        :data:`TURN_SCALE_DEG`) clipped to [0, 1]; 0.5 while no side is known."""
        degrees = (self._turns - self._set_turns) * self._set_sign * self.pivot_deg
        return min(1.0, max(0.0, 0.5 + degrees / (2.0 * TURN_SCALE_DEG)))

    def contradicted(self, side: float, bearing: float | None) -> float:
        """The input ``side`` (from :meth:`see`) once the map's fresh felt is at ``bearing``
        [rad, left positive; None: the map is blank]: :data:`UNKNOWN` (and every frame
        forgotten) with ``"behind"`` when that felt lies more than :data:`BEHIND_DEG` off to the
        side opposite ``side``, with ``"crossed"`` when a pivot toward ``side`` carried it across
        from the side's own side to the other; with ``"blank"`` whenever the map has fresh felt
        (its frames kept); else ``side``."""
        before, self._bearing = self._bearing, bearing
        if side == UNKNOWN or bearing is None:
            return side
        if self.window == "blank":
            return UNKNOWN
        sign = 1.0 if side > UNKNOWN else -1.0  # the side's own side of the bearing
        if self.window == "crossed":
            toward = Command.LEFT if side > UNKNOWN else Command.RIGHT
            spent = (
                before is not None and self._last == toward and before * sign >= 0 > bearing * sign
            )
        elif self.window == "behind":
            spent = bearing * sign < -math.radians(BEHIND_DEG)
        else:
            return side
        if spent:
            self._values = []
            return UNKNOWN
        return side


def side_command(value: float) -> Command | None:
    """The pivot toward the side a ``branch_side`` input ``value`` gives (None: no side)."""
    if value > UNKNOWN:
        return Command.LEFT
    if value < UNKNOWN:
        return Command.RIGHT
    return None
