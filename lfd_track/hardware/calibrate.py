"""Calibration on the robot: its forward step and pivot angle per command, from its own camera.

The ``fresh_felt`` map moves what it remembers by the rover's motion per command
(:mod:`lfd_track.policy.map_geometry`). On a real robot that motion depends on the floor, the
battery and the gearbox; :func:`calibrate` measures it with nothing but the robot's camera.

How: each frame is warped to a bird's-eye view of the floor (:class:`FloorView`) with the
camera's model (its mount is taken as known: the preset's or the robot's profile's; only the
motion is measured). Between two frames the floor moves rigidly, so the rover's motion is the
rotation and shift that lays the later view onto the earlier one, expressed about the rover's
pivot centre (the camera sits ``forward_offset_m`` ahead of it; the view's coordinates are
the rover's). :func:`floor_motion` finds it from the carpet's texture and the felt's edges:
both views are high-passed (which removes the camera's own shading: vignetting, exposure) and
contrast-normalised (every 5 cm of floor weighs alike, so the felt's long straight edges, which
say nothing about a shift along them, do not drown the carpet's texture); a search tries turns
5° apart, each with the shift that best lays the turned view on the other (a cross-correlation
of the whole views, on a 2x coarser view), and a Gauss–Newton fit refines the best few,
maximising the views' correlation over the floor both see (the correlation is also the
match's quality). A pivot is fitted as a turn about the pivot centre alone, as the map models
it (on bare carpet a turn and a shift can otherwise trade for one another).

The guided routine (:func:`calibrate`): with the robot on a straight felt strip, it drives
``runs`` runs of ``commands_per_run`` forward commands, then of left pivots, then of right
pivots, again and again (so the heading ends where it began; the robot advances
``runs x commands_per_run`` forward steps along the strip). Every run starts from rest
(``reset``; on the real robot that stops the motors, in the simulator it puts the rover back
on ``reset_options``' pose) and counts its motion over all its commands: a run of 3 from rest
is how the simulator defines its forward speed and pivot rate
(:attr:`~lfd_track.world.rover.RoverConfig.calibration_commands`), so the measurement and a
preset's nominal motion mean the same. Each run gives one sample; the step and pivot are the
samples' medians (left and right pivots together) and their spread is reported.

It does not converge, and raises :class:`CalibrationFailed` with one line saying why, when the
frames cannot be matched (a floor with too little texture, :data:`MIN_TEXTURE`; a correlation
below :data:`MIN_CORRELATION`, or too little floor seen twice, in more than half the runs), the samples scatter (relative spread above :data:`MAX_SPREAD`), the
robot does not move or moves the wrong way, or its episode ends (a lost link, a stalled camera).

The robot is anything with Gymnasium's ``reset``/``step`` (actions 0 forward, 1 left, 2 right)
returning camera frames: the simulator's ``LfDTrack-v0`` or the real robot's
:class:`~lfd_track.hardware.env.HardwareEnv`. Nothing but its frames is read.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

import cv2
import numpy as np

from ..core.camera_model import CameraConfig, CameraModel, floor_view_maps
from ..core.commands import Command
from ..errors import CalibrationFailed
from .profile import Calibration

__all__ = [
    "CalibrationFailed",
    "FloorView",
    "Motion",
    "Robot",
    "calibrate",
    "floor_motion",
    "strip_start",
]

#: Lowest correlation of two matched floor views a sample is kept with [-].
MIN_CORRELATION = 0.5
#: Least share of the first view's floor the second must see for a match [-].
MIN_OVERLAP = 0.2
#: Least floor texture a view must show [grey levels, RMS of the high-passed bird's-eye view]:
#: the simulated worlds show 7-22 (bare carpet to felt), a featureless floor its sensor's noise (1.5).
MIN_TEXTURE = 4.0
#: Largest relative spread (standard deviation / median) of the runs' steps or pivots [-].
MAX_SPREAD = 0.10
#: Smallest forward step [m] and pivot [deg] that count as the robot moving.
MIN_STEP_M = 0.005
MIN_PIVOT_DEG = 1.0
#: Runs of each command and commands per run of the guided routine (9 of each command).
DEFAULT_RUNS = 3
DEFAULT_COMMANDS_PER_RUN = 3

_RESOLUTION_M = 0.005  # [m] bird's-eye pixel
_DEPTH_M = 1.2  # [m] floor used ahead of the nearest floor seen
_HALF_WIDTH_M = 0.8  # [m] at most this far to either side
_CONTRAST_SIGMA_M = 0.05  # [m] contrast normalisation's reach: each 5 cm of floor weighs alike
_SHADING_SIGMA_M = 0.05  # [m] high-pass scale: keeps felt edges and carpet, drops shading
_SEARCH_SCALE = 2  # the search works on blocks of 2 x 2 bird's-eye pixels
_SEARCH_ANGLES_DEG = tuple(float(a) for a in range(-50, 51, 5))  # turns tried by the search
_REFINED = 3  # the search's best matches refined by the fit
_ITERATIONS = {2: 10, 1: 10}  # Gauss-Newton iterations per level
_MIN_POINTS = 200  # floor points both views must share for a fit


class Robot(Protocol):
    """What :func:`calibrate` drives: Gymnasium's ``reset`` and ``step`` with camera frames."""

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]: ...

    def step(self, action: int) -> tuple[np.ndarray, float, bool, bool, dict[str, Any]]: ...


@dataclass(frozen=True)
class Motion:
    """The rover's motion between two frames, in the rover's frame at the first."""

    forward_m: float
    """[m] the pivot centre's advance along the first heading."""
    left_m: float
    """[m] its shift to the left of the first heading."""
    turn_deg: float
    """[deg] the turn, counter-clockwise positive."""
    correlation: float
    """The views' correlation over the floor both see, after the fit [-]."""
    overlap: float
    """The share of the second view's floor the first one sees too [-]."""
    texture: float
    """The weaker view's floor texture [grey levels RMS] (see :data:`MIN_TEXTURE`)."""

    @property
    def matched(self) -> bool:
        """Whether both views show texture and matched well enough to trust the motion."""
        return (
            self.texture >= MIN_TEXTURE
            and self.correlation >= MIN_CORRELATION
            and self.overlap >= MIN_OVERLAP
        )


class FloorView:
    """A camera frame warped to a bird's-eye view of the floor in the rover's frame.

    Pixel (u, v) of the view sees floor point x = ``far_m`` - v·res ahead of the pivot centre and
    y = ``half_width_m`` - u·res to its left (res = 5 mm); the view spans the floor from the
    nearest point the camera sees to 1.2 m beyond it, at most 0.8 m to either side, and
    :attr:`mask` marks where the camera sees it.
    """

    def __init__(self, camera: CameraConfig) -> None:
        model = CameraModel(camera)
        footprint = model.footprint(np.zeros(3))
        near = float(np.min(footprint[:, 0]))
        far = min(float(np.max(footprint[:, 0])), near + _DEPTH_M)
        half = min(float(np.max(np.abs(footprint[:, 1]))), _HALF_WIDTH_M)
        rows = int((far - near) / _RESOLUTION_M) // _SEARCH_SCALE * _SEARCH_SCALE
        cols = int(2.0 * half / _RESOLUTION_M) // _SEARCH_SCALE * _SEARCH_SCALE
        self.camera = camera
        self.shape = (rows, cols)
        self.far_m, self.half_width_m = far, half
        #: (u, v, 1) view pixel -> (x, y, 1) floor point [m] in the rover's frame.
        self.pixel_to_floor = np.array(
            [[0.0, -_RESOLUTION_M, far], [-_RESOLUTION_M, 0.0, half], [0.0, 0.0, 1.0]]
        )
        self._map_u, self._map_v, seen = floor_view_maps(
            model, (rows, cols), far, half, _RESOLUTION_M
        )
        # A few pixels in from the edge of what the camera sees: no border pixel is matched.
        seen_view = seen.astype(np.uint8)
        self.mask = cv2.erode(seen_view, np.ones((5, 5), np.uint8)).astype(np.float32)
        if self.mask.sum() < _MIN_POINTS * _SEARCH_SCALE * _SEARCH_SCALE:
            raise ValueError("the camera sees too little floor to calibrate on")

    def warp(self, frame: np.ndarray) -> tuple[np.ndarray, float]:
        """(rows, cols) float32 floor view of ``frame`` ((H, W, 3) uint8 RGB): its grey levels
        high-passed at 5 cm and scaled to about unit RMS in every 5 cm of floor, zero where the
        camera does not see; and the high-passed view's RMS over the floor it sees [grey
        levels]: how much texture the floor shows."""
        expected = (self.camera.frame_height_px, self.camera.frame_width_px, 3)
        if frame.shape != expected:
            raise CalibrationFailed(
                f"frames are {frame.shape[1]} x {frame.shape[0]} px; the camera model expects"
                f" {expected[1]} x {expected[0]}"
            )
        grey = frame.astype(np.float32).mean(axis=2)
        floor = cv2.remap(grey, self._map_u, self._map_v, cv2.INTER_LINEAR)
        mask = self.mask
        sigma = _SHADING_SIGMA_M / _RESOLUTION_M
        weight = cv2.GaussianBlur(mask, (0, 0), sigma)
        local = cv2.GaussianBlur(floor * mask, (0, 0), sigma) / np.maximum(weight, 1e-3)
        detail = (floor - local) * mask
        rms = math.sqrt(float(np.sum(detail * detail)) / float(mask.sum()))
        # Every patch of floor counts alike: the felt's long straight edges, which say nothing
        # about a shift along them, do not drown the carpet's texture. (A tenth of the whole
        # view's RMS keeps a patch of bare noise from being blown up.)
        spread = _CONTRAST_SIGMA_M / _RESOLUTION_M
        energy = cv2.GaussianBlur(detail * detail, (0, 0), spread) / np.maximum(
            cv2.GaussianBlur(mask, (0, 0), spread), 1e-3
        )
        return detail * mask / np.sqrt(energy + (0.1 * rms) ** 2 + 1e-12), rms


def floor_motion(
    view: FloorView,
    before: np.ndarray,
    after: np.ndarray,
    guess: Motion | None = None,
    *,
    turn_only: bool = False,
) -> Motion:
    """The rover's motion from frame ``before`` to frame ``after`` ((H, W, 3) uint8 RGB each),
    from their floor views (see the module docstring); :attr:`Motion.matched` says whether the
    views matched. ``guess`` (e.g. the previous command's motion) is tried first.
    ``turn_only``: fit a turn about the pivot centre alone (a pivot, as the map models it; on
    bare carpet a turn and a shift can otherwise trade for one another)."""
    (first, texture_first), (second, texture_second) = view.warp(before), view.warp(after)
    texture = min(texture_first, texture_second)
    levels = [_Level(view, first, second, scale, turn_only) for scale in (_SEARCH_SCALE, 1)]
    # Every turn the search tries, with the shift that best lays the views on one another
    # (a cross-correlation: the whole view's reach); the best few, and the guess, are refined.
    candidates = levels[0].search(_SEARCH_ANGLES_DEG)[:_REFINED]
    if guess is not None:
        candidates.insert(
            0, np.array([math.radians(guess.turn_deg), guess.forward_m, guess.left_m])
        )
    best: Motion | None = None
    for params in candidates:
        if turn_only:
            params = np.array([params[0], 0.0, 0.0])
        fit = None
        for level in levels:
            fit = level.fit(params)
            if fit is None:
                break
            params = fit[0]
        if fit is None:
            continue
        turn, forward, left = (float(p) for p in fit[0])
        turn = math.remainder(turn, 2.0 * math.pi)  # a fit may wander a whole turn round
        motion = Motion(forward, left, math.degrees(turn), fit[1], fit[2], texture)
        # A match that sees enough of the floor twice beats any that does not.
        rank = (motion.overlap >= MIN_OVERLAP, motion.correlation)
        if best is None or rank > (best.overlap >= MIN_OVERLAP, best.correlation):
            best = motion
    if best is None:
        return Motion(0.0, 0.0, 0.0, correlation=-1.0, overlap=0.0, texture=texture)
    return best


class _Level:
    """One scale of the two floor views and the Gauss–Newton fit of the motion on it."""

    def __init__(
        self, view: FloorView, first: np.ndarray, second: np.ndarray, scale: int, turn_only: bool
    ) -> None:
        mask: np.ndarray = view.mask
        # The parameters fitted: (turn, forward, left), or the turn alone.
        self.free = np.array([True, not turn_only, not turn_only])
        if scale > 1:
            size = (first.shape[1] // scale, first.shape[0] // scale)
            first = cv2.resize(first, size, interpolation=cv2.INTER_AREA)
            second = cv2.resize(second, size, interpolation=cv2.INTER_AREA)
            mask = cv2.resize(mask, size, interpolation=cv2.INTER_AREA)
        self.scale = scale
        # A pixel's blur: the fit's linearisation then holds over about a pixel of fine texture.
        first = cv2.GaussianBlur(first, (0, 0), 1.0)
        second = cv2.GaussianBlur(second, (0, 0), 1.0)
        self.first, self.first_mask, self.second = first, mask, second
        self.grad_u = cv2.Sobel(first, cv2.CV_32F, 1, 0, ksize=3) / 8.0
        self.grad_v = cv2.Sobel(first, cv2.CV_32F, 0, 1, ksize=3) / 8.0
        # A coarse pixel is the block of scale x scale fine ones: its centre is (scale - 1) / 2
        # fine pixels in from the block's corner.
        offset = (scale - 1) / 2.0
        block = np.array([[scale, 0.0, offset], [0.0, scale, offset], [0.0, 0.0, 1.0]])
        self.to_floor = view.pixel_to_floor @ block
        self.to_pixel = np.linalg.inv(self.to_floor)
        rows, cols = np.nonzero(mask > 0.999)
        self.template = second[rows, cols].astype(np.float64)
        homogeneous = np.stack([cols, rows, np.ones(len(rows))]).astype(np.float64)
        self.points = (self.to_floor @ homogeneous)[:2]  # (2, N) the second view's floor [m]

    def search(self, angles_deg: tuple[float, ...]) -> list[np.ndarray]:
        """For each turn in ``angles_deg``, the shift that best lays the second view, turned
        about the pivot centre, onto the first (phase correlation over the whole view); the
        (turn [rad], forward [m], left [m]) of each, the best match first."""
        rows, cols = self.first.shape
        v, u = np.mgrid[0:rows, 0:cols].astype(np.float64)
        x, y = (self.to_floor[:2, :2] @ np.stack([u.ravel(), v.ravel()])) + self.to_floor[:2, 2:3]
        first = self.first * (self.first_mask > 0.999)
        # Zero-padded to twice the size: the correlation of every shift, none wrapped round.
        shape = (2 * rows, 2 * cols)
        first_spectrum = np.fft.rfft2(first, shape)
        first_energy = float((first * first).sum())
        found = []
        for angle in angles_deg:
            turn = math.radians(angle)
            cos, sin = math.cos(turn), math.sin(turn)
            # The first view's floor points seen from the second pose, if it had only turned.
            x_second, y_second = cos * x + sin * y, -sin * x + cos * y
            (a, b), (c, d) = self.to_pixel[:2, :2]
            u0, v0 = self.to_pixel[:2, 2]
            map_u = (a * x_second + b * y_second + u0).reshape(rows, cols).astype(np.float32)
            map_v = (c * x_second + d * y_second + v0).reshape(rows, cols).astype(np.float32)
            turned = cv2.remap(self.second, map_u, map_v, cv2.INTER_LINEAR, borderValue=0.0)
            seen = cv2.remap(self.first_mask, map_u, map_v, cv2.INTER_LINEAR, borderValue=0.0)
            turned = turned * (seen > 0.999)
            # Plain cross-correlation, not phase correlation: whitening would give the sensor's
            # noise, which differs in every frame, the weight of the floor's texture.
            product = first_spectrum * np.conj(np.fft.rfft2(turned, shape))
            correlation = np.fft.irfft2(product, shape)
            peak = int(np.argmax(correlation))
            dv, du = divmod(peak, shape[1])
            dv = dv - shape[0] if dv >= rows else dv  # wrapped: a negative shift
            du = du - shape[1] if du >= cols else du
            norm = math.sqrt(first_energy * float((turned * turned).sum()))
            score = float(correlation.flat[peak]) / norm if norm > 0 else 0.0
            (e, f), (g, h) = self.to_floor[:2, :2]
            found.append((score, turn, e * du + f * dv, g * du + h * dv))
        found.sort(key=lambda item: -item[0])
        return [np.array(item[1:]) for item in found]

    def fit(self, params: np.ndarray) -> tuple[np.ndarray, float, float] | None:
        """Refine (turn [rad], forward [m], left [m]) from ``params``: Gauss–Newton steps, each
        kept only if it raises the correlation (else halved, from the best so far). Returns
        the best parameters with their correlation and overlap, or None when the views do not
        overlap there."""
        best = self._linearise(np.asarray(params, dtype=np.float64))
        if best is None:
            return None
        shrink = 1.0
        small = 0.01 * _RESOLUTION_M * self.scale  # [m] a hundredth of a pixel
        for _ in range(_ITERATIONS[self.scale]):
            delta = shrink * best.delta
            if abs(delta[0]) < 1e-5 and math.hypot(delta[1], delta[2]) < small:
                break
            trial = self._linearise(best.params + delta)
            if trial is not None and trial.correlation > best.correlation:
                best, shrink = trial, 1.0
            else:
                shrink *= 0.5
        return best.params, best.correlation, best.overlap

    def _linearise(self, params: np.ndarray) -> _Linearisation | None:
        """The correlation at ``params`` and the Gauss–Newton step from there (None when too
        little floor is seen by both views). Element-wise sums, no BLAS: the same numbers on
        every machine, and no thread pool to wait for."""
        turn, forward, left = params
        cos, sin = math.cos(turn), math.sin(turn)
        (a, b), (c, d) = self.to_pixel[:2, :2]
        u0, v0 = self.to_pixel[:2, 2]
        x, y = self.points
        x_first = cos * x - sin * y + forward
        y_first = sin * x + cos * y + left
        map_u = _as_map(a * x_first + b * y_first + u0)
        map_v = _as_map(c * x_first + d * y_first + v0)
        count = len(x)
        inside = _sample(self.first_mask, map_u, map_v, count) > 0.999
        if inside.sum() < _MIN_POINTS:
            return None
        sample = _sample(self.first, map_u, map_v, count)[inside]
        grad_u = _sample(self.grad_u, map_u, map_v, count)[inside]
        grad_v = _sample(self.grad_v, map_u, map_v, count)[inside]
        sample = sample - sample.mean()
        template = self.template[inside]
        template = template - template.mean()
        energy = float((sample * sample).sum())
        cross = float((sample * template).sum())
        norm = math.sqrt(energy * float((template * template).sum()))
        if norm <= 0.0:
            return None
        # The first view, scaled to the template's contrast, against the template.
        gain = cross / energy
        residual = gain * sample - template
        x, y = x[inside], y[inside]
        dx_dturn, dy_dturn = -sin * x - cos * y, cos * x - sin * y
        # Change of the sampled value per unit of (turn, forward, left).
        columns = [
            gain
            * (grad_u * (a * dx_dturn + b * dy_dturn) + grad_v * (c * dx_dturn + d * dy_dturn)),
            gain * (grad_u * a + grad_v * c),
            gain * (grad_u * b + grad_v * d),
        ]
        free = [i for i in range(3) if self.free[i]]
        normal = np.array([[(columns[i] * columns[j]).sum() for j in free] for i in free])
        rhs = np.array([-(columns[i] * residual).sum() for i in free])
        delta = np.zeros(3)
        try:
            delta[free] = np.linalg.solve(normal, rhs)
        except np.linalg.LinAlgError:
            pass
        return _Linearisation(params, cross / norm, float(inside.mean()), delta)


@dataclass(frozen=True)
class _Linearisation:
    params: np.ndarray  # (turn [rad], forward [m], left [m])
    correlation: float
    overlap: float
    delta: np.ndarray  # the Gauss-Newton step from params


_MAP_COLUMNS = 256  # cv2.remap takes maps of fewer than 32767 rows and columns


def _as_map(coordinates: np.ndarray) -> np.ndarray:
    """(N,) pixel coordinates as a float32 remap map of _MAP_COLUMNS columns (padded)."""
    rows = -(-len(coordinates) // _MAP_COLUMNS)
    out = np.full(rows * _MAP_COLUMNS, -10.0, dtype=np.float32)
    out[: len(coordinates)] = coordinates
    return out.reshape(rows, _MAP_COLUMNS)


def _sample(image: np.ndarray, map_u: np.ndarray, map_v: np.ndarray, count: int) -> np.ndarray:
    """(count,) float64 values of ``image`` at the maps' points (bilinear; 0 outside)."""
    values = cv2.remap(image, map_u, map_v, cv2.INTER_LINEAR, borderValue=0.0)
    return values.ravel()[:count].astype(np.float64)


class _Strips(Protocol):
    """What :func:`strip_start` reads of a track: its driven segments."""

    @property
    def segment_starts(self) -> np.ndarray: ...

    @property
    def segment_ends(self) -> np.ndarray: ...


def strip_start(track: _Strips, inset_m: float = 0.15) -> tuple[float, float, float]:
    """(x [m], y [m], heading [rad]): ``inset_m`` into the track's longest straight strip, facing
    along it; where the simulator's robot is placed to calibrate (the training track's 1.83 m
    straight)."""
    starts, ends = np.asarray(track.segment_starts), np.asarray(track.segment_ends)
    lengths = np.linalg.norm(ends - starts, axis=1)
    longest = int(np.argmax(lengths))
    direction = (ends[longest] - starts[longest]) / lengths[longest]
    x, y = starts[longest] + inset_m * direction
    return float(x), float(y), math.atan2(float(direction[1]), float(direction[0]))


@dataclass(frozen=True)
class _Run:
    command: Command
    motion: tuple[float, float, float]  # (forward [m], left [m], turn [deg]) per command
    matched: bool
    correlation: float  # the lowest of its commands' matches
    texture: float  # [grey levels] the least textured view of the run


def calibrate(
    robot: Robot,
    camera: CameraConfig,
    *,
    runs: int = DEFAULT_RUNS,
    commands_per_run: int = DEFAULT_COMMANDS_PER_RUN,
    reset_options: Mapping[str, Any] | None = None,
    seed: int | None = None,
    on_run: Callable[[str], None] | None = None,
) -> Calibration:
    """Measure ``robot``'s forward step and pivot per command from its frames (see the module
    docstring). ``camera`` is the robot's camera (its mount is not measured);
    ``reset_options`` go to every ``reset`` (the simulator's start pose on the strip), ``seed``
    to the first (the simulator's world and noise; the same seed measures the same numbers);
    ``on_run`` receives one line per run. Raises :class:`CalibrationFailed`."""
    if isinstance(runs, bool) or not isinstance(runs, int) or runs < 1:
        raise ValueError(f"runs must be a positive integer, got {runs!r}")
    if (
        isinstance(commands_per_run, bool)
        or not isinstance(commands_per_run, int)
        or not 1 <= commands_per_run <= 100
    ):
        raise ValueError(f"commands_per_run must be an integer in 1..100, got {commands_per_run!r}")
    view = FloorView(camera)
    done: list[_Run] = []
    for index in range(runs):
        for command in (Command.FORWARD, Command.LEFT, Command.RIGHT):
            run = _drive_run(robot, view, command, commands_per_run, reset_options, seed)
            seed = None  # the first reset only
            done.append(run)
            if on_run is not None:
                forward, _, turn = run.motion
                shown = f"{forward:.4f} m" if command == Command.FORWARD else f"{turn:+.2f} deg"
                quality = (
                    ""
                    if run.matched
                    else f" (not matched: correlation {run.correlation:.2f},"
                    f" texture {run.texture:.1f} grey levels)"
                )
                on_run(
                    f"run {index + 1}/{runs} {command.name.lower()}: {shown} per command{quality}"
                )
    return _summarise(done, commands_per_run)


def _drive_run(
    robot: Robot,
    view: FloorView,
    command: Command,
    commands: int,
    reset_options: Mapping[str, Any] | None,
    seed: int | None,
) -> _Run:
    """Drive one run of ``commands`` identical commands from rest; its motion per command."""
    options = None if reset_options is None else dict(reset_options)
    frame, _ = robot.reset(seed=seed, options=options)
    pose = np.zeros(3)  # (x [m], y [m], heading [rad]) in the run's first frame
    worst, texture = 1.0, math.inf
    matched = True
    guess: Motion | None = None
    for count in range(1, commands + 1):
        after, _, terminated, truncated, info = robot.step(int(command))
        if terminated or truncated:
            reason = info.get("error") or info.get("failure") or "the episode ended"
            raise CalibrationFailed(
                f"the robot stopped during a {command.name.lower()} run (command {count}): {reason}"
            )
        motion = floor_motion(view, frame, after, guess, turn_only=command != Command.FORWARD)
        guess = motion
        matched &= motion.matched
        worst = min(worst, motion.correlation)
        texture = min(texture, motion.texture)
        cos, sin = math.cos(pose[2]), math.sin(pose[2])
        pose = pose + np.array(
            [
                cos * motion.forward_m - sin * motion.left_m,
                sin * motion.forward_m + cos * motion.left_m,
                math.radians(motion.turn_deg),
            ]
        )
        frame = after
    per_command = (pose[0] / commands, pose[1] / commands, math.degrees(pose[2]) / commands)
    return _Run(command, per_command, matched, worst, texture)


def _summarise(done: list[_Run], commands_per_run: int) -> Calibration:
    """The calibration of the runs, or :class:`CalibrationFailed` saying why there is none."""
    unmatched = [run for run in done if not run.matched]
    if len(unmatched) * 2 > len(done):
        texture = min(run.texture for run in done)
        if texture < MIN_TEXTURE:
            raise CalibrationFailed(
                f"the floor is too uniform to see the robot move (texture {texture:.1f} grey"
                f" levels, at least {MIN_TEXTURE:g} needed): place it on a felt strip on"
                " textured carpet, in good light"
            )
        worst = min(run.correlation for run in done)
        raise CalibrationFailed(
            f"the floor views of {len(unmatched)} of {len(done)} runs do not match (correlation"
            f" down to {worst:.2f}, {MIN_CORRELATION:g} needed): keep people and shadows out of"
            " the camera's view and the light steady"
        )
    kept = [run for run in done if run.matched]
    forward = [run.motion[0] for run in kept if run.command == Command.FORWARD]
    left = [run.motion[2] for run in kept if run.command == Command.LEFT]
    right = [-run.motion[2] for run in kept if run.command == Command.RIGHT]
    for what, values in (("forward", forward), ("left", left), ("right", right)):
        if not values:
            raise CalibrationFailed(f"no {what} run's floor views match: the floor is too uniform")
    step, pivot_left, pivot_right = (float(np.median(v)) for v in (forward, left, right))
    if abs(step) < MIN_STEP_M or max(abs(pivot_left), abs(pivot_right)) < MIN_PIVOT_DEG:
        raise CalibrationFailed(
            f"the robot did not move (forward step {step:.4f} m, pivots {pivot_left:+.2f} and"
            f" {-pivot_right:+.2f} deg): are the motors powered and the e-stop clear?"
        )
    if step < 0:
        raise CalibrationFailed(
            f"forward commands drive the robot backwards ({step:.4f} m each): swap both motors' wires"
        )
    if pivot_left < MIN_PIVOT_DEG or pivot_right < MIN_PIVOT_DEG:
        raise CalibrationFailed(
            f"left pivots turn {pivot_left:+.2f} deg and right pivots {-pivot_right:+.2f} deg"
            " (counter-clockwise positive): the motors' wires or sides are swapped"
        )
    if min(forward) <= 0 or min(left) <= 0 or min(right) <= 0:
        raise CalibrationFailed("a run moved against its command: the estimates are too scattered")
    calibration = Calibration(
        commands_per_run=commands_per_run,
        forward_step_m=tuple(forward),
        left_pivot_deg=tuple(left),
        right_pivot_deg=tuple(right),
    )
    for what, spread in (
        ("forward step", calibration.step_spread),
        ("pivot", calibration.pivot_spread),
    ):
        if spread > MAX_SPREAD:
            raise CalibrationFailed(
                f"the {what} estimates are too scattered (relative spread {100 * spread:.1f} %,"
                f" at most {100 * MAX_SPREAD:.0f} %): check the floor's grip and run again"
            )
    return calibration
