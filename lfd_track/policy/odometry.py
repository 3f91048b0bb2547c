"""Visual odometry on the floor: the rover's motion between two consecutive camera frames.

The ``fresh_felt`` map (:mod:`lfd_track.policy.memory`) moves what it remembers by the rover's
motion per executed command. Its nominal motion (a forward step, a pivot:
:class:`~lfd_track.policy.map_geometry.MapGeometry`) is what a calibration measures on average;
a rover whose treads slip moves differently at every command, which no calibration removes. This
module measures each command's motion from the camera itself, as a real robot would.

How: each frame is warped once to a bird's-eye view of the floor in the rover's frame
(:class:`FloorOdometry`: a remap through the camera model of the map's geometry, 8 mm per view
pixel, from the nearest floor the camera sees to 1 m beyond it), its grey levels high-passed at
4 cm (which removes the camera's own shading: vignetting, exposure, light pools wider than that)
and kept at two scales. Between two frames the floor moves rigidly, so the motion is the rotation
and shift that lays a rectangle of the later view (the *template*: the floor 0.2–0.75 m beyond
the nearest floor seen, as wide as the camera sees it there) onto the earlier view. OpenCV's ECC
registration (``cv2.findTransformECC``, Euclidean motion; it is insensitive to the views'
contrast and brightness) finds it, first on views of 16 mm pixels from the command's nominal
motion and, unless that fits well, from turns 4° and 8° either side of it (a slipping forward
command turns the rover up to some 10°; the best correlation among the motions the rover can
have made wins: a turn traded for a sideways shift can match a strip's straight edges too),
then on the 8 mm views from there (``registration = "full"``; ``"quick"`` tries the nominal motion
alone and stops each fit after 15 iterations, and ``"coarse"`` does so and keeps the 16 mm fit
without the 8 mm one, for a decision that must fit a budget: see :data:`REGISTRATIONS`). The
fit's correlation and its distance from the nominal motion say whether it is trusted
(:attr:`FloorMotion.reliable`).

What the floor offers to match: the felt's edges (sharp, but a straight edge says nothing of a
shift along it), the carpet's pile and patches, and the room's light pools and shadows, which are
fixed to the floor. The simulated carpet's loops (4 mm) are below the view's 8 mm pixels and
average out; what registers is the felt's edges and the carpet's and light's variation over
centimetres. A frame of bare, uniformly lit carpet, motion blur, or a frame the camera lost
gives a low correlation or no fit at all, and the caller keeps the nominal motion.

Costs (the paper camera, one thread): warping a frame some 0.3 ms, a registration 0.7–0.9 ms
median, 3–5 ms at the 90th percentile on the loaded machine
(``benchmarks/experiments/robustness/odometry.py`` measures both, and the accuracy:
``results/odometry.md`` beside it).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import cv2
import numpy as np

from ..core.camera_model import CameraModel, floor_view_maps
from .map_geometry import MapGeometry

__all__ = [
    "COARSE_TURNS_DEG",
    "ECC_ITERATIONS",
    "REGISTRATIONS",
    "FloorMotion",
    "FloorOdometry",
    "FloorView",
    "PlanarMotion",
    "Registration",
    "floor_odometry",
]

#: Least ECC correlation of a fit whose motion is trusted [-] (matched views of felt and carpet
#: mostly give 0.9-0.99, views of little but carpet down to 0.3; a fit that slid off a plausible
#: motion or found none gives below 0.3 or -1; ``odometry.py``'s measurement: plausible fits
#: from 0.3 up were within 3 deg of the true turn).
MIN_CORRELATION = 0.5
#: Least floor texture a view must show [grey levels, RMS of the high-passed view] (the paper
#: world's views show 10-25; a featureless floor shows its sensor's noise, some 2).
MIN_TEXTURE = 4.0
#: Largest difference from the nominal motion a trusted estimate may have: a turn [deg] and a
#: shift [m] (a tread's slip is at most some 30 % of its speed).
MAX_TURN_CHANGE_DEG = 12.0
MAX_SHIFT_CHANGE_M = 0.06

_RESOLUTION_M = 0.008  # [m] a view pixel
_DEPTH_M = 1.0  # [m] floor used beyond the nearest floor seen
_HALF_WIDTH_M = 0.64  # [m] at most this far to either side
_TEMPLATE_FROM_M = 0.2  # [m] the template starts this far beyond the nearest floor seen
_TEMPLATE_TO_M = 0.75  # [m] and ends this far beyond it
_SHADING_SIGMA_M = 0.04  # [m] high-pass scale: keeps felt edges and carpet, drops shading
_COARSE = 2  # the first fit works on blocks of 2 x 2 view pixels
#: Turns tried around the nominal one on the coarse views [deg], in this order (a forward command
#: of a rover slipping 0.10 turns it up to some 10 deg): the ``full`` registration's.
COARSE_TURNS_DEG = (0.0, -4.0, 4.0, -8.0, 8.0)
_GOOD_START = 0.8  # a plausible coarse fit this good needs no further start
#: ECC iterations per fit at most: the ``full`` registration's.
ECC_ITERATIONS = 30


@dataclass(frozen=True)
class Registration:
    """How hard a motion is searched for: the turns tried around the nominal one on the coarse
    views [deg], in order, the ECC iterations per fit at most (coarse and fine alike), and
    whether the best coarse fit is refined on the fine views."""

    turns_deg: tuple[float, ...]
    iterations: int
    fine: bool = True


#: The registrations by name (the ``fresh_felt`` map's ``registration`` setting), read at every
#: fit. ``full`` searches five starts of 30 iterations (the map's motion since it existed);
#: ``quick`` one start of 15, about 1 ms less at the 95th percentile of a decision on the paper
#: camera (``benchmarks/speed/bench_decision_tail.py``: 4.9 against 5.9 ms), for the encapsulated
#: budget; ``coarse`` the same start without the fine fit (on the half-size camera's decision
#: about 0.6 ms less on average, its fine fit's share; the turn it finds up to some three times
#: further off the true one, ``tests/policy/test_odometry.py`` holds it within 1.5 deg; round 30
#: of the human-taught goal measured it costing laps).
REGISTRATIONS: dict[str, Registration] = {
    "full": Registration(COARSE_TURNS_DEG, ECC_ITERATIONS),
    "quick": Registration((0.0,), 15),
    "coarse": Registration((0.0,), 15, fine=False),
}
_EPSILON = 1e-4  # ECC stops when the correlation grows less than this
#: ECC's own Gaussian blur [px] per scale: wider on the coarse views, whose fit must reach
#: further (from a nominal pivot 2 deg off, a 3 px blur there can lose the match).
_ECC_BLUR = {_COARSE: 5, 1: 3}
_MIN_TEMPLATE_PX = 12  # a template narrower or shorter than this (coarse pixels) is refused


@dataclass(frozen=True)
class PlanarMotion:
    """A rigid motion of the rover on the floor, in its frame before the motion."""

    forward_m: float
    """[m] the pivot centre's advance along the first heading."""
    left_m: float
    """[m] its shift to the left of the first heading."""
    turn_deg: float
    """[deg] the turn, counter-clockwise (left) positive."""

    @classmethod
    def from_poses(
        cls, before: Sequence[float] | np.ndarray, after: Sequence[float] | np.ndarray
    ) -> PlanarMotion:
        """The motion from pose ``before`` to pose ``after`` (x, y, heading [m, m, rad]), in the
        rover's frame at ``before`` (the turn taken the short way round)."""
        x0, y0, h0 = (float(v) for v in before[:3])
        x1, y1, h1 = (float(v) for v in after[:3])
        dx, dy = x1 - x0, y1 - y0
        cos, sin = math.cos(h0), math.sin(h0)
        turn = math.remainder(h1 - h0, 2.0 * math.pi)
        return cls(cos * dx + sin * dy, -sin * dx + cos * dy, math.degrees(turn))

    def matrix(self) -> np.ndarray:
        """(3, 3) float64: a point's rover coordinates after the motion -> before it."""
        turn = math.radians(self.turn_deg)
        cos, sin = math.cos(turn), math.sin(turn)
        return np.array([[cos, -sin, self.forward_m], [sin, cos, self.left_m], [0.0, 0.0, 1.0]])

    def move_points(self, points: np.ndarray) -> np.ndarray:
        """Floor points (N, 2) [m] in the rover frame before the motion, in its frame after it."""
        turn = math.radians(self.turn_deg)
        cos, sin = math.cos(turn), math.sin(turn)
        x = points[:, 0] - self.forward_m
        y = points[:, 1] - self.left_m
        return np.column_stack([cos * x + sin * y, -sin * x + cos * y])


@dataclass(frozen=True)
class FloorMotion:
    """What :meth:`FloorOdometry.motion` measured between two frames."""

    motion: PlanarMotion
    """The motion found (the guess itself when no fit was found)."""
    correlation: float
    """ECC correlation of the fit over the template [-] (-1: no fit)."""
    texture: float
    """The weaker view's floor texture [grey levels RMS] (see :data:`MIN_TEXTURE`)."""
    guess: PlanarMotion
    """The nominal motion the fit started from."""

    @property
    def reliable(self) -> bool:
        """Whether the views showed texture, matched well, and the motion is one the rover can
        have made (within :data:`MAX_TURN_CHANGE_DEG` and :data:`MAX_SHIFT_CHANGE_M` of the
        guess)."""
        return (
            self.texture >= MIN_TEXTURE
            and self.correlation >= MIN_CORRELATION
            and _plausible(self.motion, self.guess)
        )


def _plausible(motion: PlanarMotion, guess: PlanarMotion) -> bool:
    """Whether ``motion`` lies within :data:`MAX_TURN_CHANGE_DEG` and :data:`MAX_SHIFT_CHANGE_M`
    of the nominal ``guess``."""
    shift = math.hypot(motion.forward_m - guess.forward_m, motion.left_m - guess.left_m)
    return abs(motion.turn_deg - guess.turn_deg) <= MAX_TURN_CHANGE_DEG and (
        shift <= MAX_SHIFT_CHANGE_M
    )


def _motion_of(matrix: np.ndarray) -> PlanarMotion:
    """The motion of a (3, 3) rigid matrix (:meth:`PlanarMotion.matrix`)."""
    turn = math.degrees(math.atan2(matrix[1, 0], matrix[0, 0]))
    return PlanarMotion(float(matrix[0, 2]), float(matrix[1, 2]), turn)


@dataclass(frozen=True)
class FloorView:
    """One frame warped to the floor (:meth:`FloorOdometry.view`)."""

    fine: np.ndarray
    """(rows, cols) float32 high-passed grey levels of the floor, 0 where unseen."""
    coarse: np.ndarray
    """The same on blocks of 2 x 2 view pixels."""
    texture: float
    """RMS of :attr:`fine` over the floor seen [grey levels]."""


class _Scale:
    """One scale of the views: its mask and the view-pixel <-> floor transforms."""

    def __init__(
        self,
        floor_from_pixel: np.ndarray,
        seen: np.ndarray,
        block: int,
        rect: tuple[int, int, int, int],
    ) -> None:
        offset = (block - 1) / 2.0  # a block's centre, in fine pixels from its corner
        scale = np.array([[block, 0.0, offset], [0.0, block, offset], [0.0, 0.0, 1.0]])
        self.floor_from_view = floor_from_pixel @ scale
        self.view_from_floor = np.linalg.inv(self.floor_from_view)
        r0, r1, c0, c1 = (v // block for v in rect)
        self.rows, self.cols = slice(r0, r1), slice(c0, c1)
        shift = np.array([[1.0, 0.0, c0], [0.0, 1.0, r0], [0.0, 0.0, 1.0]])
        self.floor_from_template = self.floor_from_view @ shift
        self.template_from_floor = np.linalg.inv(self.floor_from_template)
        self.mask = seen
        self.blur = _ECC_BLUR[block]


class FloorOdometry:
    """The rover's motion between two frames of the camera of ``geometry`` (see the module
    docstring). Only the camera of ``geometry`` is read; its motion is the caller's guess.
    ``registration`` names how hard each motion is searched for (:data:`REGISTRATIONS`)."""

    def __init__(self, geometry: MapGeometry, registration: str = "full") -> None:
        if registration not in REGISTRATIONS:
            raise ValueError(
                f"registration must be one of {', '.join(REGISTRATIONS)}, got {registration!r}"
            )
        self.registration = registration
        camera = geometry.camera()
        model = CameraModel(camera)
        footprint = model.footprint(np.zeros(3))
        near = float(np.min(footprint[:, 0]))
        far = near + _DEPTH_M
        half = min(float(np.max(np.abs(footprint[:, 1]))), _HALF_WIDTH_M)
        step = 2 * _COARSE
        rows = int(_DEPTH_M / _RESOLUTION_M) // step * step
        cols = int(2.0 * half / _RESOLUTION_M) // step * step
        #: (u, v, 1) view pixel -> (x, y, 1) floor point [m] in the rover's frame.
        floor_from_pixel = np.array(
            [[0.0, -_RESOLUTION_M, far], [-_RESOLUTION_M, 0.0, half], [0.0, 0.0, 1.0]]
        )
        self._map_u, self._map_v, seen = floor_view_maps(
            model, (rows, cols), far, half, _RESOLUTION_M
        )
        self._seen = seen.astype(np.float32)
        sigma = _SHADING_SIGMA_M / _RESOLUTION_M
        self._seen_weight = np.maximum(cv2.GaussianBlur(self._seen, (0, 0), sigma), 1e-3)
        coarse_size = (cols // _COARSE, rows // _COARSE)
        masks = {
            1: _eroded(self._seen),
            _COARSE: _eroded(cv2.resize(self._seen, coarse_size, interpolation=cv2.INTER_AREA)),
        }
        rect = _template_rect(masks, floor_from_pixel, near, step)
        self._scales = {
            block: _Scale(floor_from_pixel, mask, block, rect) for block, mask in masks.items()
        }
        self._coarse_size = coarse_size
        self._frame_shape = (camera.frame_height_px, camera.frame_width_px)

    @property
    def frame_shape(self) -> tuple[int, int]:
        """(height, width) [px] of the frames :meth:`view` reads: the camera's."""
        return self._frame_shape

    def view(self, frame: np.ndarray) -> FloorView:
        """The floor view of ``frame`` ((H, W, 3) uint8, RGB or BGR alike: the channels are
        averaged) at the camera's frame size."""
        if frame.ndim != 3 or frame.shape[:2] != self._frame_shape:
            height, width = self._frame_shape
            raise ValueError(
                f"frame of shape {frame.shape} does not match the camera's {width} x {height}"
                " frames"
            )
        floor = cv2.remap(frame, self._map_u, self._map_v, cv2.INTER_LINEAR)
        grey = cv2.transform(floor, np.full((1, 3), 1.0 / 3.0, dtype=np.float32)).astype(np.float32)
        sigma = _SHADING_SIGMA_M / _RESOLUTION_M
        local = cv2.GaussianBlur(grey, (0, 0), sigma) / self._seen_weight
        fine = (grey - local) * self._seen
        seen_count = float(self._seen.sum())
        texture = math.sqrt(float(np.square(fine).sum()) / seen_count) if seen_count else 0.0
        coarse = cv2.resize(fine, self._coarse_size, interpolation=cv2.INTER_AREA)
        return FloorView(fine=fine, coarse=coarse, texture=texture)

    def motion(self, before: FloorView, after: FloorView, guess: PlanarMotion) -> FloorMotion:
        """The rover's motion from the frame of ``before`` to that of ``after`` (their
        :meth:`view`), the fit started from ``guess`` (the command's nominal motion)."""
        texture = min(before.texture, after.texture)
        coarse = self._scales[_COARSE]
        template = np.ascontiguousarray(after.coarse[coarse.rows, coarse.cols])
        # The best fit over the starts: a motion the rover can have made before any other (a
        # turn traded for a sideways shift can match a strip's straight edges as well).
        best: tuple[bool, float, np.ndarray] | None = None
        search = REGISTRATIONS[self.registration]
        for extra in search.turns_deg:
            start = PlanarMotion(guess.forward_m, guess.left_m, guess.turn_deg + extra)
            fit = _ecc(template, before.coarse, coarse, start.matrix(), search.iterations)
            if fit is None:
                continue
            ranked = (_plausible(_motion_of(fit[1]), guess), fit[0], fit[1])
            if best is None or ranked[:2] > best[:2]:
                best = ranked
            if best[0] and best[1] >= _GOOD_START:
                break
        if best is None:
            return FloorMotion(guess, -1.0, texture, guess)
        if not search.fine:
            return FloorMotion(_motion_of(best[2]), best[1], texture, guess)
        fine = self._scales[1]
        template = np.ascontiguousarray(after.fine[fine.rows, fine.cols])
        refined = _ecc(template, before.fine, fine, best[2], search.iterations)
        correlation, matrix = refined if refined is not None else best[1:]
        return FloorMotion(_motion_of(matrix), float(correlation), texture, guess)

    def between(self, before: np.ndarray, after: np.ndarray, guess: PlanarMotion) -> FloorMotion:
        """:meth:`motion` of two frames ((H, W, 3) uint8 each)."""
        return self.motion(self.view(before), self.view(after), guess)


@functools.lru_cache(maxsize=8)
def floor_odometry(geometry: MapGeometry, registration: str = "full") -> FloorOdometry:
    """The :class:`FloorOdometry` of ``geometry``'s camera with ``registration`` (built once per
    pair: it holds the view's maps and nothing that changes)."""
    return FloorOdometry(geometry, registration)


def _eroded(seen: np.ndarray) -> np.ndarray:
    """uint8 mask of the view pixels wholly seen, a pixel in from the edge of what is seen."""
    return cv2.erode((seen > 0.999).astype(np.uint8), np.ones((3, 3), np.uint8))


def _template_rect(
    masks: dict[int, np.ndarray], floor_from_pixel: np.ndarray, near: float, step: int
) -> tuple[int, int, int, int]:
    """Fine-pixel rows and columns ``(r0, r1, c0, c1)`` (multiples of ``step``) of the template:
    the floor from ``_TEMPLATE_FROM_M`` to ``_TEMPLATE_TO_M`` beyond ``near``, centred, as wide as
    every scale's mask is seen over all its rows."""
    far, resolution = floor_from_pixel[0, 2], -floor_from_pixel[0, 1]
    r0 = int(math.ceil((far - near - _TEMPLATE_TO_M) / resolution / step)) * step
    r1 = int((far - near - _TEMPLATE_FROM_M) / resolution) // step * step
    cols = masks[1].shape[1]
    centre = cols // 2
    half = centre // step * step
    while half >= _MIN_TEMPLATE_PX * step // 2:
        c0, c1 = centre - half, centre + half
        if all(
            mask[r0 // block : r1 // block, c0 // block : c1 // block].all()
            for block, mask in masks.items()
        ):
            break
        half -= step
    if half < _MIN_TEMPLATE_PX * step // 2 or r1 - r0 < _MIN_TEMPLATE_PX * step:
        raise ValueError("the camera sees too little floor for visual odometry")
    return r0, r1, centre - half, centre + half


def _ecc(
    template: np.ndarray, image: np.ndarray, scale: _Scale, start: np.ndarray, iterations: int
) -> tuple[float, np.ndarray] | None:
    """ECC fit of ``template`` (after) onto ``image`` (before) at ``scale`` from the motion
    matrix ``start`` (:meth:`PlanarMotion.matrix`) in at most ``iterations``; the correlation and
    the fitted motion matrix, or None when the fit fails."""
    warp = (scale.view_from_floor @ start @ scale.floor_from_template)[:2].astype(np.float32)
    criteria = (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_COUNT, iterations, _EPSILON)
    try:
        correlation, warp = cv2.findTransformECC(
            template, image, warp, cv2.MOTION_EUCLIDEAN, criteria, scale.mask, scale.blur
        )
    except cv2.error:  # no convergence: the views do not match there
        return None
    matrix = np.vstack([warp.astype(np.float64), [0.0, 0.0, 1.0]])
    return float(correlation), scale.floor_from_view @ matrix @ scale.template_from_floor
