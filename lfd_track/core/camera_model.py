"""The rover's camera as geometry: lens models, :class:`CameraModel`, projections and rays.

The camera sits ``height_m`` above the floor, ``forward_offset_m`` ahead of the rover's pivot
centre, pitched ``pitch_deg`` down, with a vertical field of view of ``vfov_deg``, square pixels
and the principal point at the image centre (or ``principal_shift_px`` above it). Pixel
coordinates are OpenCV's: (u, v) with u to the right and v down, integer values at pixel centres.

Lenses (``lens``): an ideal ``"pinhole"`` (the paper's phone), a pinhole with radial
(Brown–Conrady) ``distortion``, or a ``"fisheye"`` (Kannala–Brandt: the image radius is a
polynomial in the angle off the optical axis, ``r = f·θ·(1 + k1·θ² + k2·θ⁴ + k3·θ⁶ + k4·θ⁸)``; all
k = 0 is the equidistant fisheye). See ``CameraConfig.distortion``.

Only numpy: the road-value memory (:mod:`lfd_track.policy.memory`) asks which floor points the
regions see without loading the renderer (:mod:`lfd_track.render.camera`), which draws frames
through the per-pixel floor table and the homography computed here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from .frame import safe_box_slices

#: Lens projections a camera can have (see ``CameraConfig.lens``).
LENSES = ("pinhole", "fisheye")
#: Largest angle off the optical axis a lens may map into the frame [rad]: a pinhole cannot reach
#: 90°; a fisheye is limited to 175° (real fisheyes stop near 100°; beyond, the model is unphysical).
_LENS_MAX_THETA = {"pinhole": math.radians(89.0), "fisheye": math.radians(175.0)}
#: Points sampled along each image edge for lens footprints and the horizon check.
_EDGE_SAMPLES = 24
#: Smallest angle below the horizon any pixel must look [deg] ("the horizon is never in view").
_HORIZON_MARGIN_DEG = 0.5
#: How the renderer samples the ground texture (see ``CameraConfig.texture_filter``).
TEXTURE_FILTERS = ("bilinear", "mipmap")


@dataclass(frozen=True)
class CameraConfig:
    """Pinhole camera mounted on the rover (TOML table ``[camera]``)."""

    width_px: int = 640
    """Image width [px]."""
    height_px: int = 480
    """Image height [px]."""
    height_m: float = 0.31
    """Height of the optical centre above the floor [m]."""
    pitch_deg: float = 30.0
    """Downward tilt of the optical axis below horizontal [deg] (negative: tilted up, possible
    only with a frame shifted below the axis, ``principal_shift_px``)."""
    vfov_deg: float = 41.0
    """Vertical field of view [deg] of the centred frame (it sets the focal length through the
    lens's mapping); the horizontal one follows from square pixels (``CameraModel.hfov_deg``)."""
    forward_offset_m: float = 0.0
    """Optical centre's distance ahead of the rover's pivot centre [m]."""
    lens: str = "pinhole"
    """Projection: ``"pinhole"`` (rectilinear) or ``"fisheye"`` (Kannala–Brandt)."""
    distortion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """Radial coefficients (k1, k2, k3, k4) [-]. With θ the angle off the optical axis and f the
    focal length [px], a pixel lies r = f·ρ·(1 + k1·ρ² + k2·ρ⁴ + k3·ρ⁶ + k4·ρ⁸) from the
    principal point, where ρ = tan θ for ``"pinhole"`` (Brown–Conrady radial terms; k1 < 0 is
    barrel distortion) and ρ = θ [rad] for ``"fisheye"`` (Kannala–Brandt; all zero = equidistant).
    The mapping must grow with θ over the whole frame."""
    principal_shift_px: float = 0.0
    """Principal point's distance above the image centre [px]: > 0 makes the frame the lower part
    of the lens's picture (an off-centre crop). ``vfov_deg`` is the field of the centred frame."""
    texture_filter: str = "mipmap"
    """How a pixel samples the ground texture. ``"mipmap"`` (the default): bilinear from a
    pre-filtered, halved copy of the texture (a mip level) whose texels are about as large as the
    pixel's floor footprint: the level is round(½·log2(footprint area in texels)), fixed per band
    of image rows (on a flat floor the footprint depends on the row), which is the averaging a
    real lens and sensor pixel do. ``"bilinear"`` (the default until ``results.json`` recorded
    its ``renderer``; every file without that field used it): the 4 texels nearest the point the
    pixel centre sees, however much floor the pixel covers (towards the top of the frame one
    pixel covers about 1.5 × 9 texels of the paper's 2 mm texture, so fine carpet and felt
    texture alias)."""
    scale: float = 1.0
    """Size of the frames relative to ``width_px`` × ``height_px`` [-]: ``0.5`` takes 320 × 240
    frames of the same view (same field of view, mount and lens: the focal length, the principal
    point and ``principal_shift_px``, which stays in ``width_px`` × ``height_px`` pixels, scale
    with the frame), as if the full frame were binned 2 × 2. ``width_px``, ``height_px`` and the
    pixel settings stay those of the full-size sensor; the frame is ``frame_width_px`` ×
    ``frame_height_px``. Both products must be whole numbers of pixels."""

    @property
    def frame_width_px(self) -> int:
        """Width of the frames [px]: ``width_px`` × ``scale``."""
        return self.width_px if self.scale == 1.0 else round(self.width_px * self.scale)

    @property
    def frame_height_px(self) -> int:
        """Height of the frames [px]: ``height_px`` × ``scale``."""
        return self.height_px if self.scale == 1.0 else round(self.height_px * self.scale)

    @property
    def frame_principal_shift_px(self) -> float:
        """``principal_shift_px`` in frame pixels: × ``scale``."""
        return (
            self.principal_shift_px if self.scale == 1.0 else self.principal_shift_px * self.scale
        )

    @property
    def is_ideal_pinhole(self) -> bool:
        """Whether the lens is an undistorted pinhole (the view is one floor homography)."""
        return self.lens == "pinhole" and not any(self.distortion)

    def __post_init__(self) -> None:
        if self.width_px < 2 or self.height_px < 2:
            raise ValueError(
                f"image size must be at least 2 × 2 px, got {self.width_px} × {self.height_px}"
            )
        if not math.isfinite(self.scale) or self.scale <= 0:
            raise ValueError(f"scale must be > 0, got {self.scale}")
        for name, size in (("width_px", self.width_px), ("height_px", self.height_px)):
            scaled = size * self.scale
            if abs(scaled - round(scaled)) > 1e-9 or round(scaled) < 2:
                raise ValueError(
                    f"scale {self.scale} makes {name} {size} {scaled:g} px: frames need a whole"
                    " number of pixels, at least 2"
                )
        if self.height_m <= 0:
            raise ValueError(f"height_m must be > 0, got {self.height_m}")
        if not 0.0 < self.vfov_deg < 170.0:
            raise ValueError(f"vfov_deg must be in (0, 170), got {self.vfov_deg}")
        if self.texture_filter not in TEXTURE_FILTERS:
            raise ValueError(
                f"texture_filter must be one of {', '.join(TEXTURE_FILTERS)},"
                f" got {self.texture_filter!r}"
            )
        if self.lens not in LENSES:
            raise ValueError(f"lens must be one of {', '.join(LENSES)}, got {self.lens!r}")
        if len(self.distortion) != 4 or not all(math.isfinite(k) for k in self.distortion):
            raise ValueError(f"distortion must be 4 finite numbers, got {self.distortion!r}")
        if not math.isfinite(self.principal_shift_px) or not (
            abs(self.principal_shift_px) <= 4.0 * self.height_px
        ):
            raise ValueError(
                f"principal_shift_px must be within ±{4 * self.height_px} px,"
                f" got {self.principal_shift_px}"
            )
        if not (self.is_ideal_pinhole and self.principal_shift_px == 0.0):
            problem = _lens_problem(self)
            if problem is not None:
                raise ValueError(problem)
            return
        if self.pitch_deg - self.vfov_deg / 2.0 <= 0.5:
            raise ValueError(
                f"pitch_deg {self.pitch_deg} with vfov_deg {self.vfov_deg} shows the horizon "
                "(pitch must exceed half the vertical field of view)"
            )
        if self.pitch_deg + self.vfov_deg / 2.0 >= 90.0:
            raise ValueError(
                "pitch_deg + vfov_deg / 2 must stay below 90 (the camera would look backwards)"
            )


def _radial(theta: np.ndarray, lens: str, k: tuple[float, ...]) -> np.ndarray:
    """Image radius / focal length for rays ``theta`` [rad] off the optical axis (same shape)."""
    rho = np.tan(theta) if lens == "pinhole" else np.asarray(theta, dtype=np.float64)
    rho2 = rho * rho
    return rho * (1.0 + rho2 * (k[0] + rho2 * (k[1] + rho2 * (k[2] + rho2 * k[3]))))


def _focal_px(config: CameraConfig) -> float:
    """Focal length [px] that puts the centred frame's top and bottom edges at ±vfov/2."""
    half = math.radians(config.vfov_deg) / 2.0
    scale = float(_radial(np.array(half), config.lens, config.distortion))
    return (config.frame_height_px / 2.0) / scale if scale > 0 else math.nan


def _lens_table(config: CameraConfig, focal_px: float) -> tuple[np.ndarray, np.ndarray] | str:
    """Monotonic table (radius [px], θ [rad]) covering the frame, or why the lens cannot."""
    c = config
    cy = (c.frame_height_px - 1) / 2.0 - c.frame_principal_shift_px
    far_row = max(abs(-0.5 - cy), abs(c.frame_height_px - 0.5 - cy))
    reach_px = math.hypot(c.frame_width_px / 2.0, far_row) + 1.0
    if not math.isfinite(focal_px) or focal_px <= 0:
        return f"lens {c.lens} with distortion {c.distortion} maps vfov_deg {c.vfov_deg} nowhere"
    theta = np.linspace(0.0, _LENS_MAX_THETA[c.lens], 20001)
    radius = focal_px * _radial(theta, c.lens, c.distortion)
    rising = np.diff(radius) > 0
    stop = len(rising) if rising.all() else int(np.argmin(rising))
    if radius[stop] < reach_px:
        return (
            f"lens {c.lens} with distortion {c.distortion} cannot fill the frame: its image radius"
            f" stops growing (or the lens's angle limit is reached) at"
            f" {radius[stop]:.0f} px < {reach_px:.0f} px needed"
        )
    return radius[: stop + 1], theta[: stop + 1]


def _lens_problem(config: CameraConfig) -> str | None:
    """Why a lens camera is unusable (cannot fill the frame, sees the horizon), or None."""
    focal = _focal_px(config)
    table = _lens_table(config, focal)
    if isinstance(table, str):
        return table
    model = CameraModel(config)
    rays = model.rays_rover(model.edge_pixels(_EDGE_SAMPLES))
    elevation = np.degrees(np.arcsin(rays[:, 2] / np.linalg.norm(rays, axis=1)))
    if elevation.max() > -_HORIZON_MARGIN_DEG:
        return (
            f"pitch_deg {config.pitch_deg} with this {config.lens} lens shows the horizon (an image"
            f" edge looks {elevation.max():.1f}° above the floor's horizon; every pixel must look at"
            f" least {_HORIZON_MARGIN_DEG}° below it)"
        )
    return None


class TexturePlacement(Protocol):
    """Where a floor texture lies: what :meth:`CameraModel.homography` needs of a ground."""

    def world_from_texture(self) -> np.ndarray:
        """(3, 3) affine map from texel coordinates (col, row, 1) to floor points (x, y, 1) [m]."""
        ...


class CameraModel:
    """Lens geometry between floor points [m] and image pixels; no rendering.

    An ideal pinhole uses the homography ``K [R | t]``; other lenses go through their radial
    mapping (``_radial``), inverted by a monotonic table.
    """

    def __init__(self, config: CameraConfig | None = None) -> None:
        self.config = config or CameraConfig()
        c = self.config
        self.is_homography = c.is_ideal_pinhole
        if self.is_homography:
            self.focal_px = (c.frame_height_px / 2.0) / math.tan(math.radians(c.vfov_deg) / 2.0)
            self._table: tuple[np.ndarray, np.ndarray] | None = None
        else:
            self.focal_px = _focal_px(c)
            table = _lens_table(c, self.focal_px)
            if isinstance(table, str):
                raise ValueError(table)
            self._table = table
        self.cx = (c.frame_width_px - 1) / 2.0
        self.cy = (c.frame_height_px - 1) / 2.0 - c.frame_principal_shift_px
        self._footprint_rover: np.ndarray | None = None
        self._extrinsics_key: tuple[float, float, float] | None = None
        self._extrinsics_value: tuple[np.ndarray, np.ndarray] | None = None
        self.K = np.array(
            [[self.focal_px, 0.0, self.cx], [0.0, self.focal_px, self.cy], [0.0, 0.0, 1.0]]
        )
        self.K_inv = np.linalg.inv(self.K)
        # Rover frame: x forward, y left, z up. Camera rows: image right, image down, optical axis.
        p = math.radians(c.pitch_deg)
        self._R_rover = np.array(
            [
                [0.0, -1.0, 0.0],
                [-math.sin(p), 0.0, -math.cos(p)],
                [math.cos(p), 0.0, -math.sin(p)],
            ]
        )
        # Camera-axis rays of the pixel sets every step projects: the image corners (pinhole
        # footprint) and the safe box.
        self._corner_rays = self._rays_camera(self._corner_pixels())
        self._safe_box_rays = self._rays_camera(self._safe_box_pixels())

    @property
    def hfov_deg(self) -> float:
        """Horizontal field of view [deg]: the angle between the rays through the left and right
        image edges on the principal point's row."""
        half_px = self.config.frame_width_px / 2.0
        if self._table is None:
            return math.degrees(2.0 * math.atan(half_px / self.focal_px))
        return math.degrees(2.0 * float(np.interp(half_px, *self._table)))

    def _rays_camera(self, pixels: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) → ray directions (N, 3) in camera axes (right, down, optical axis)."""
        px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        if self._table is None:
            return np.column_stack([px, np.ones(len(px))]) @ self.K_inv.T
        x = (px[:, 0] - self.cx) / self.focal_px
        y = (px[:, 1] - self.cy) / self.focal_px
        r_px = np.hypot(x, y) * self.focal_px
        theta = np.interp(r_px, *self._table)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(r_px > 0, np.sin(theta) / (r_px / self.focal_px), 1.0)
        return np.column_stack([x * scale, y * scale, np.cos(theta)])

    def rays_rover(self, pixels: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) → unit ray directions (N, 3) in the rover frame (x ahead, y left, z up)."""
        rays = self._rays_camera(pixels) @ self._R_rover
        return rays / np.linalg.norm(rays, axis=1, keepdims=True)

    def edge_pixels(self, per_edge: int) -> np.ndarray:
        """(4·per_edge, 2) points along the image's outer edge: TL → TR → BR → BL, clockwise."""
        w, h = self.config.frame_width_px, self.config.frame_height_px
        t = np.linspace(0.0, 1.0, per_edge, endpoint=False)
        left, right, top, bottom = -0.5, w - 0.5, -0.5, h - 0.5
        return np.concatenate(
            [
                np.column_stack([left + t * w, np.full(per_edge, top)]),
                np.column_stack([np.full(per_edge, right), top + t * h]),
                np.column_stack([right - t * w, np.full(per_edge, bottom)]),
                np.column_stack([np.full(per_edge, left), bottom - t * h]),
            ]
        )

    def floor_map_rover(self) -> np.ndarray:
        """(H, W, 2) float32 floor point [m] each pixel centre sees, in the rover frame at the
        origin (x ahead, y left). The renderer moves it with the pose; every pixel sees floor."""
        c = self.config
        w, h = c.frame_width_px, c.frame_height_px
        u, v = np.meshgrid(np.arange(w, dtype=np.float64), np.arange(h))
        pts = self.floor_points(np.column_stack([u.ravel(), v.ravel()]), np.zeros(3))
        return pts.reshape(h, w, 2).astype(np.float32)

    def row_footprint_area_m2(self) -> np.ndarray:
        """(H,) floor area [m²] one pixel covers on each image row, at the centre column.

        The quad the pixel's four corners see on the floor (shoelace formula). For an ideal
        pinhole over a flat floor it depends on the row only; a distorted lens is measured on the
        centre column.
        """
        c = self.config
        u = (c.frame_width_px - 1) / 2.0
        rows = np.arange(c.frame_height_px, dtype=np.float64)
        corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        quad = [
            self.floor_points(np.column_stack([np.full_like(rows, u + du), rows + dv]), np.zeros(3))
            for du, dv in corners
        ]
        area = np.zeros(c.frame_height_px)
        for a, b in zip(quad, quad[1:] + quad[:1], strict=True):
            area += a[:, 0] * b[:, 1] - b[:, 0] * a[:, 1]
        return np.abs(area) / 2.0

    def _extrinsics(self, pose: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """World→camera rotation (3, 3) and camera centre (3,) in world coordinates [m].

        A step asks for the same pose several times (the view, its footprint, the safe box), so
        the last pose's answer is kept; the arrays are read-only."""
        x, y, theta = (float(v) for v in pose)
        key = (x, y, theta)
        if key == self._extrinsics_key and self._extrinsics_value is not None:
            return self._extrinsics_value
        ct, st = math.cos(theta), math.sin(theta)
        world_from_rover = np.array([[ct, -st, 0.0], [st, ct, 0.0], [0.0, 0.0, 1.0]])
        R = self._R_rover @ world_from_rover.T
        off = self.config.forward_offset_m
        centre = np.array([x + off * ct, y + off * st, self.config.height_m])
        R.flags.writeable = False
        centre.flags.writeable = False
        self._extrinsics_key, self._extrinsics_value = key, (R, centre)
        return R, centre

    def image_from_world(self, pose: np.ndarray) -> np.ndarray:
        """(3, 3) homography: floor points (x, y, 1) [m] → pixels (u, v, 1) for ``pose`` (3,).

        Exact for an ideal pinhole only (``is_homography``); a distorted lens bends it.
        """
        R, centre = self._extrinsics(pose)
        return self.K @ np.column_stack([R[:, 0], R[:, 1], -R @ centre])

    def project(self, points_world: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Floor points (N, 2) [m] → pixel coordinates (N, 2) float64 (u right, v down).

        Points behind the camera (or beyond a fisheye's angle limit) give NaN. Points outside the
        image still get coordinates.
        """
        pts = np.asarray(points_world, dtype=np.float64).reshape(-1, 2)
        if self._table is not None:
            return self._project_lens(pts, pose)
        hom = np.column_stack([pts, np.ones(len(pts))]) @ self.image_from_world(pose).T
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = hom[:, :2] / hom[:, 2:3]
        uv[hom[:, 2] <= 1e-12] = np.nan
        return uv

    def _project_lens(self, pts: np.ndarray, pose: np.ndarray) -> np.ndarray:
        assert self._table is not None
        R, centre = self._extrinsics(pose)
        cam = (np.column_stack([pts, np.zeros(len(pts))]) - centre) @ R.T  # (N, 3) camera axes
        sideways = np.hypot(cam[:, 0], cam[:, 1])
        theta = np.arctan2(sideways, cam[:, 2])
        radius_table, theta_table = self._table
        r_px = np.interp(theta, theta_table, radius_table)
        with np.errstate(divide="ignore", invalid="ignore"):
            scale = np.where(sideways > 0, r_px / sideways, 0.0)
        uv = np.column_stack([self.cx + cam[:, 0] * scale, self.cy + cam[:, 1] * scale])
        uv[theta > theta_table[-1]] = np.nan
        return uv

    def floor_points(self, pixels: np.ndarray, pose: np.ndarray) -> np.ndarray:
        """Pixels (N, 2) (u, v) → the floor points (N, 2) [m] they see; NaN above the horizon."""
        px = np.asarray(pixels, dtype=np.float64).reshape(-1, 2)
        return self._floor_points_of_rays(self._rays_camera(px), pose)

    def _floor_points_of_rays(self, rays_camera: np.ndarray, pose: np.ndarray) -> np.ndarray:
        R, centre = self._extrinsics(pose)
        rays = rays_camera @ R  # world directions
        with np.errstate(divide="ignore", invalid="ignore"):
            t = -centre[2] / rays[:, 2]
        out = centre[None, :2] + t[:, None] * rays[:, :2]
        out[~(rays[:, 2] < -1e-12)] = np.nan
        return out

    def footprint(self, pose: np.ndarray) -> np.ndarray:
        """(N, 2) floor polygon [m] seen by the image's outer edge, from the top-left corner
        clockwise on screen. An ideal pinhole gives its four corners (TL, TR, BR, BL); a distorted
        lens bends the edges, so they are sampled (N = 4 × 24)."""
        if self._table is not None:
            # The camera is rigid on the rover: move the edge's floor points found once at the
            # origin instead of inverting the lens for ~100 pixels every frame.
            if self._footprint_rover is None:
                self._footprint_rover = self.floor_points(
                    self.edge_pixels(_EDGE_SAMPLES), np.zeros(3)
                )
            x, y, theta = (float(v) for v in pose)
            ct, st = math.cos(theta), math.sin(theta)
            rot = np.array([[ct, -st], [st, ct]])
            return self._footprint_rover @ rot.T + np.array([x, y])
        return self._floor_points_of_rays(self._corner_rays, pose)

    def _corner_pixels(self) -> np.ndarray:
        w, h = self.config.frame_width_px, self.config.frame_height_px
        return np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])

    def safe_box_floor_polygon(self, pose: np.ndarray) -> np.ndarray:
        """(N, 2) floor polygon [m] of the safe box (outer pixel edges), corners TL, TR, BR, BL.

        N = 4 for an ideal pinhole (straight edges); a distorted lens bends the box's edges on
        the floor, so each edge is sampled (N = 16).
        """
        return self._floor_points_of_rays(self._safe_box_rays, pose)

    def _safe_box_pixels(self) -> np.ndarray:
        rows, cols = safe_box_slices(self.config.frame_width_px, self.config.frame_height_px)
        u0, u1 = cols.start - 0.5, cols.stop - 0.5
        v0, v1 = rows.start - 0.5, rows.stop - 0.5
        if self._table is None:
            return np.array([[u0, v0], [u1, v0], [u1, v1], [u0, v1]])
        t = np.linspace(0.0, 1.0, 4, endpoint=False)
        return np.concatenate(
            [
                np.column_stack([u0 + t * (u1 - u0), np.full(4, v0)]),
                np.column_stack([np.full(4, u1), v0 + t * (v1 - v0)]),
                np.column_stack([u1 - t * (u1 - u0), np.full(4, v1)]),
                np.column_stack([np.full(4, u0), v1 - t * (v1 - v0)]),
            ]
        )

    def homography(self, pose: np.ndarray, ground: TexturePlacement) -> np.ndarray:
        """(3, 3) homography from texel coordinates (col, row, 1) of ``ground`` (a
        :class:`~lfd_track.render.texture.GroundTexture`) to image pixels.

        ``cv2.warpPerspective(ground.rgba, H, size)`` renders the view; the renderer passes the
        inverse with ``cv2.WARP_INVERSE_MAP`` instead, which is the same picture.
        """
        return self.image_from_world(pose) @ ground.world_from_texture()


def floor_view_maps(
    model: CameraModel, shape: tuple[int, int], far_m: float, half_m: float, resolution_m: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Where each pixel of a bird's-eye view of the floor lies in the camera's frame: ``(map_u,
    map_v, seen)``, each of ``shape`` (rows, cols), the maps for ``cv2.remap``. View pixel (row
    v, column u) is the floor point ``(far_m - v * resolution_m, half_m - u * resolution_m)`` in
    the rover's frame (the rover at the origin); ``seen`` is True where that point projects at
    least one pixel inside the frame's edge, and the maps hold -10 where it does not. Shared by
    the calibration's floor view and the map's odometry."""
    rows, cols = shape
    v, u = np.mgrid[0:rows, 0:cols].astype(np.float64)
    floor = np.column_stack(
        [(far_m - v * resolution_m).ravel(), (half_m - u * resolution_m).ravel()]
    )
    with np.errstate(invalid="ignore"):
        pixels = model.project(floor, np.zeros(3))
    width, height = model.config.frame_width_px, model.config.frame_height_px
    seen = np.isfinite(pixels).all(axis=1)
    seen &= (pixels[:, 0] >= 1.0) & (pixels[:, 0] <= width - 2.0)
    seen &= (pixels[:, 1] >= 1.0) & (pixels[:, 1] <= height - 2.0)
    pixels[~seen] = -10.0
    map_u = pixels[:, 0].reshape(rows, cols).astype(np.float32)
    map_v = pixels[:, 1].reshape(rows, cols).astype(np.float32)
    return map_u, map_v, seen.reshape(rows, cols)


def safe_box_floor_polygon(pose: np.ndarray, config: CameraConfig | None = None) -> np.ndarray:
    """(N, 2) floor polygon [m] of the safe box for a rover at ``pose`` (x, y, theta); N = 4 for
    an ideal pinhole (see ``CameraModel.safe_box_floor_polygon``)."""
    return CameraModel(config).safe_box_floor_polygon(pose)
