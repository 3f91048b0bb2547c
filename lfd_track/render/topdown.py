"""Human-facing top-down pictures of a track: felt, corners, trajectories, rover, camera view.

This is a debug and report view, separate from the rover's camera: flat colours, drawn with
OpenCV in RGB. World x is to the right and y up, as in the world frame.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import cv2
import numpy as np

from ..world.track import Track

RGB = tuple[int, int, int]

CARPET_RGB: RGB = (92, 66, 48)
FELT_RGB: RGB = (140, 190, 225)
CENTRELINE_RGB: RGB = (95, 140, 175)
LABEL_RGB: RGB = (255, 255, 255)
TRAJECTORY_RGB: RGB = (255, 200, 40)
ROVER_RGB: RGB = (235, 70, 60)
FOOTPRINT_RGB: RGB = (250, 250, 120)
#: Rover body length × width [m] (paper §4.1: Rover 5 chassis), for drawing only.
ROVER_SIZE_M = (0.245, 0.225)
_SHIFT = 4  # sub-pixel bits for OpenCV drawing


class TopDownView:
    """World [m] ↔ picture pixel mapping for a track's top-down picture."""

    def __init__(
        self, track: Track, size_px: int | tuple[int, int] = 800, margin_m: float = 0.35
    ) -> None:
        xmin, ymin, xmax, ymax = track.bounds(margin_m)
        span_x, span_y = xmax - xmin, ymax - ymin
        if isinstance(size_px, int):
            width = size_px
            height = max(int(round(width * span_y / span_x)), 1)
        else:
            width, height = int(size_px[0]), int(size_px[1])
        if width < 16 or height < 16:
            raise ValueError(f"picture size must be at least 16 × 16 px, got {width} × {height}")
        self.size_px = (width, height)
        self.px_per_m = min(width / span_x, height / span_y)
        # Centre the track's box in the picture when the aspect ratios differ.
        self._x0 = (xmin + xmax) / 2.0 - width / (2.0 * self.px_per_m)
        self._y1 = (ymin + ymax) / 2.0 + height / (2.0 * self.px_per_m)

    def to_px(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 2) [m] → picture coordinates (..., 2) float64 (x right, y down)."""
        pts = np.asarray(points, dtype=np.float64)
        col = (pts[..., 0] - self._x0) * self.px_per_m
        row = (self._y1 - pts[..., 1]) * self.px_per_m
        return np.stack([col, row], axis=-1)

    def to_fixed(self, points: np.ndarray) -> np.ndarray:
        """World points (N, 2) [m] → int32 (N, 2) fixed-point coordinates for OpenCV drawing."""
        return np.rint(self.to_px(points) * (1 << _SHIFT)).astype(np.int32).reshape(-1, 2)

    def blank(self, track: Track, labels: bool = True) -> np.ndarray:
        """(H, W, 3) uint8 RGB picture of the carpet, felt strips, centreline and corner labels."""
        width, height = self.size_px
        img = np.empty((height, width, 3), dtype=np.uint8)
        img[:] = CARPET_RGB
        for poly in track.strip_polygons():
            cv2.fillPoly(img, [self.to_fixed(poly)], FELT_RGB, cv2.LINE_AA, _SHIFT)
        loop = np.vstack([track.vertices, track.vertices[:1]]) if track.closed else track.vertices
        cv2.polylines(img, [self.to_fixed(loop)], False, CENTRELINE_RGB, 1, cv2.LINE_AA, _SHIFT)
        if labels:
            self._draw_labels(img, track)
        return img

    def _draw_labels(self, img: np.ndarray, track: Track) -> None:
        centre = track.vertices.mean(axis=0)
        scale = max(0.4, self.size_px[0] / 1600.0)
        thick = max(1, int(round(scale * 2)))
        for corner in track.corners:
            v = track.vertices[corner.vertex]
            out = v - centre
            norm = float(np.hypot(*out))
            out = out / norm if norm > 1e-9 else np.array([0.0, 1.0])
            where = self.to_px(v + out * (track.width_m * 0.5 + 0.18))
            text = str(corner.label)
            (tw, th), _ = cv2.getTextSize(text, cv2.FONT_HERSHEY_SIMPLEX, scale, thick)
            org = (int(where[0] - tw / 2), int(where[1] + th / 2))
            cv2.putText(
                img, text, org, cv2.FONT_HERSHEY_SIMPLEX, scale, LABEL_RGB, thick, cv2.LINE_AA
            )
        # Start point and driving direction.
        start, heading = track.point_at(0.0)
        tip = start + 0.35 * np.array([math.cos(heading), math.sin(heading)])
        a, b = self.to_px(start), self.to_px(tip)
        cv2.arrowedLine(
            img,
            (int(a[0]), int(a[1])),
            (int(b[0]), int(b[1])),
            LABEL_RGB,
            max(1, thick - 1),
            cv2.LINE_AA,
            tipLength=0.3,
        )

    def draw_path(
        self, img: np.ndarray, points: np.ndarray, colour: RGB, thickness: int = 2
    ) -> None:
        """Draw a polyline through world points (N, 2) [m] onto ``img`` in place."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if len(pts) >= 2:
            cv2.polylines(img, [self.to_fixed(pts)], False, colour, thickness, cv2.LINE_AA, _SHIFT)
        elif len(pts) == 1:
            c = self.to_px(pts[0])
            cv2.circle(img, (int(c[0]), int(c[1])), thickness + 1, colour, -1, cv2.LINE_AA)

    def draw_rover(
        self, img: np.ndarray, pose: np.ndarray, size_m: tuple[float, float] = ROVER_SIZE_M
    ) -> None:
        """Draw the rover at ``pose`` (x, y, theta) as an oriented rectangle with a nose mark."""
        x, y, theta = (float(v) for v in pose)
        fwd = np.array([math.cos(theta), math.sin(theta)])
        left = np.array([-fwd[1], fwd[0]])
        hl, hw = size_m[0] / 2.0, size_m[1] / 2.0
        c = np.array([x, y])
        body = np.array(
            [
                c + fwd * hl + left * hw,
                c - fwd * hl + left * hw,
                c - fwd * hl - left * hw,
                c + fwd * hl - left * hw,
            ]
        )
        cv2.fillPoly(img, [self.to_fixed(body)], ROVER_RGB, cv2.LINE_AA, _SHIFT)
        nose = np.array(
            [
                c + fwd * hl,
                c + fwd * (hl * 0.3) + left * hw * 0.6,
                c + fwd * (hl * 0.3) - left * hw * 0.6,
            ]
        )
        cv2.fillPoly(img, [self.to_fixed(nose)], LABEL_RGB, cv2.LINE_AA, _SHIFT)

    def draw_polygon(
        self, img: np.ndarray, polygon: np.ndarray, colour: RGB, thickness: int = 1
    ) -> None:
        """Draw a closed polygon (K, 2) [m] outline onto ``img`` in place (skips NaN corners)."""
        poly = np.asarray(polygon, dtype=np.float64).reshape(-1, 2)
        if len(poly) >= 2 and np.all(np.isfinite(poly)):
            cv2.polylines(img, [self.to_fixed(poly)], True, colour, thickness, cv2.LINE_AA, _SHIFT)


def draw_topdown(
    track: Track,
    *,
    pose: np.ndarray | None = None,
    trajectory: np.ndarray | None = None,
    footprint: np.ndarray | None = None,
    size_px: int | tuple[int, int] = 800,
    labels: bool = True,
    margin_m: float = 0.35,
) -> np.ndarray:
    """Top-down picture of ``track`` (H, W, 3) uint8 RGB.

    ``pose`` (3,) draws the rover; ``trajectory`` (N, 2) [m] its path; ``footprint`` (N, 2) [m]
    the camera's floor polygon (``CameraModel.footprint``). ``size_px`` is a width (height from
    the track's aspect) or a (width, height) pair.
    """
    view = TopDownView(track, size_px, margin_m)
    img = view.blank(track, labels)
    if trajectory is not None:
        view.draw_path(img, trajectory, TRAJECTORY_RGB)
    if footprint is not None:
        view.draw_polygon(img, footprint, FOOTPRINT_RGB, 2)
    if pose is not None:
        view.draw_rover(img, pose)
    return img


def draw_trajectories(
    track: Track,
    trajectories: Sequence[np.ndarray],
    colours: Sequence[RGB],
    *,
    size_px: int | tuple[int, int] = 800,
    labels: bool = True,
    margin_m: float = 0.35,
    thickness: int = 2,
    mark_ends: bool = True,
) -> np.ndarray:
    """Several paths (each (N, 2) [m]) over one track picture, each in its RGB colour.

    Meant for benchmark plots, e.g. trajectories coloured by outcome. ``mark_ends`` puts a dot
    where each path ends. Returns (H, W, 3) uint8 RGB.
    """
    if len(trajectories) != len(colours):
        raise ValueError(f"got {len(trajectories)} trajectories but {len(colours)} colours")
    view = TopDownView(track, size_px, margin_m)
    img = view.blank(track, labels)
    for path, colour in zip(trajectories, colours, strict=True):
        red, green, blue = (int(c) for c in colour)
        col = (red, green, blue)
        view.draw_path(img, path, col, thickness)
        pts = np.asarray(path, dtype=np.float64).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        if mark_ends and len(pts):
            end = view.to_px(pts[-1])
            cv2.circle(img, (int(end[0]), int(end[1])), thickness + 2, col, -1, cv2.LINE_AA)
    return img
