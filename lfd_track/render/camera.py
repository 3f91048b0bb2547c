"""The rover's phone camera: lens geometry over the floor plane and a fast frame renderer.

Geometry: the camera sits ``height_m`` above the floor, ``forward_offset_m`` ahead of the rover's
pivot centre, pitched ``pitch_deg`` down, with a vertical field of view of ``vfov_deg``, square
pixels and the principal point at the image centre (or ``principal_shift_px`` above it). Pixel
coordinates are OpenCV's: (u, v) with u to the right and v down, integer values at pixel centres.

Lenses (``lens``): an ideal ``"pinhole"`` (the paper's phone), a pinhole with radial
(Brown–Conrady) ``distortion``, or a ``"fisheye"`` (Kannala–Brandt: the image radius is a
polynomial in the angle off the optical axis, ``r = f·θ·(1 + k1·θ² + k2·θ⁴ + k3·θ⁶ + k4·θ⁸)``; all
k = 0 is the equidistant fisheye). See ``CameraConfig.distortion``.

Rendering an ideal pinhole is one ground-plane homography (``cv2.warpPerspective``, linear
interpolation) from the ground texture. A distorted lens is rendered by ``cv2.remap`` through a
per-pixel map of the floor points each pixel sees, computed once in the rover's frame (the camera
is rigid on the rover) and moved with the pose by one affine transform per frame. With
``texture_filter = "mipmap"`` each band of image rows is sampled the same way from the texture's
pre-filtered mip level that matches the pixel's floor footprint (``mip_bands``). Then comes the
phone's image pipeline: auto-exposure that adapts with a lag, white-balance jitter, vignetting,
sensor noise, and optionally motion blur and JPEG compression.

Why one module of about 670 lines: the lens model (:class:`CameraModel`: projection, the
per-pixel floor table, the safe box's footprint) and the renderer that warps through that same
table are one piece of geometry, checked together by the lens tests; split, each half would
import the other's private tables.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..core.frame import safe_box_slices
from .texture import GroundTexture

#: Rec. 601 luma weights of R, G, B, used to meter brightness.
_LUMA = np.array([0.299, 0.587, 0.114])
#: Samples (columns, rows) the auto-exposure meter reads per frame.
_METER_GRID = (80, 60)
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
#: Coarsest mip level the ``"mipmap"`` filter uses (2^6 = 64 texels per level-6 texel).
MAX_MIP_LEVEL = 6


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

    @property
    def is_ideal_pinhole(self) -> bool:
        """Whether the lens is an undistorted pinhole (the view is one floor homography)."""
        return self.lens == "pinhole" and not any(self.distortion)

    def __post_init__(self) -> None:
        if self.width_px < 2 or self.height_px < 2:
            raise ValueError(
                f"image size must be at least 2 × 2 px, got {self.width_px} × {self.height_px}"
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


@dataclass(frozen=True)
class SensorConfig:
    """The phone's image pipeline (TOML table ``[sensor]``)."""

    exposure_target: float = 118.0
    """Mean luma (0–255) the auto-exposure steers towards."""
    exposure_lag_frames: float = 1.5
    """Time constant of the auto-exposure [frames]; 0 adapts instantly."""
    exposure_min_gain: float = 0.4
    """Smallest exposure gain the camera can reach (relative to the texture)."""
    exposure_max_gain: float = 3.0
    """Largest exposure gain the camera can reach."""
    white_balance_cast: float = 0.03
    """Std of the per-episode colour cast (per-channel gain), relative."""
    white_balance_jitter: float = 0.015
    """Std of the per-frame white-balance jitter (per-channel gain), relative."""
    white_balance_pool: int = 8
    """Jittered white balances drawn at reset; each frame picks one of them at random."""
    highlight_knee: float = 0.7
    """Fraction of full scale where the tone curve starts to roll off (1 = hard clipping)."""
    noise_std: float = 3.0
    """Std of the additive sensor noise [8-bit levels]."""
    noise_pool_frames: int = 4
    """Noise frames drawn at reset; each frame uses one at a random offset."""
    vignetting: float = 0.25
    """Brightness lost in the image corners, relative (0 = none)."""
    motion_blur: bool = False
    """Blur along the image motion of the last pose change (needs ``motion`` in ``render``)."""
    motion_blur_fraction: float = 0.08
    """Blur length / image displacement of the last pose change (≈ exposure time / step time)."""
    jpeg_quality: int = 0
    """JPEG round trip at this quality (1–100); 0 turns compression off."""

    def __post_init__(self) -> None:
        if not 0.0 < self.exposure_target < 255.0:
            raise ValueError(f"exposure_target must be in (0, 255), got {self.exposure_target}")
        if self.exposure_lag_frames < 0:
            raise ValueError(f"exposure_lag_frames must be >= 0, got {self.exposure_lag_frames}")
        if not 0.0 < self.exposure_min_gain <= self.exposure_max_gain:
            raise ValueError("need 0 < exposure_min_gain <= exposure_max_gain")
        for name in (
            "white_balance_cast",
            "white_balance_jitter",
            "noise_std",
            "motion_blur_fraction",
        ):
            if getattr(self, name) < 0:
                raise ValueError(f"{name} must be >= 0, got {getattr(self, name)}")
        if not 0.0 < self.highlight_knee <= 1.0:
            raise ValueError(f"highlight_knee must be in (0, 1], got {self.highlight_knee}")
        if not 0.0 <= self.vignetting < 1.0:
            raise ValueError(f"vignetting must be in [0, 1), got {self.vignetting}")
        if self.white_balance_pool < 1:
            raise ValueError(f"white_balance_pool must be >= 1, got {self.white_balance_pool}")
        if self.noise_pool_frames < 1:
            raise ValueError(f"noise_pool_frames must be >= 1, got {self.noise_pool_frames}")
        if not 0 <= self.jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be in 0..100 (0 = off), got {self.jpeg_quality}")


def _radial(theta: np.ndarray, lens: str, k: tuple[float, ...]) -> np.ndarray:
    """Image radius / focal length for rays ``theta`` [rad] off the optical axis (same shape)."""
    rho = np.tan(theta) if lens == "pinhole" else np.asarray(theta, dtype=np.float64)
    rho2 = rho * rho
    return rho * (1.0 + rho2 * (k[0] + rho2 * (k[1] + rho2 * (k[2] + rho2 * k[3]))))


def _focal_px(config: CameraConfig) -> float:
    """Focal length [px] that puts the centred frame's top and bottom edges at ±vfov/2."""
    half = math.radians(config.vfov_deg) / 2.0
    scale = float(_radial(np.array(half), config.lens, config.distortion))
    return (config.height_px / 2.0) / scale if scale > 0 else math.nan


def _lens_table(config: CameraConfig, focal_px: float) -> tuple[np.ndarray, np.ndarray] | str:
    """Monotonic table (radius [px], θ [rad]) covering the frame, or why the lens cannot."""
    c = config
    cy = (c.height_px - 1) / 2.0 - c.principal_shift_px
    far_row = max(abs(-0.5 - cy), abs(c.height_px - 0.5 - cy))
    reach_px = math.hypot(c.width_px / 2.0, far_row) + 1.0
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
            self.focal_px = (c.height_px / 2.0) / math.tan(math.radians(c.vfov_deg) / 2.0)
            self._table: tuple[np.ndarray, np.ndarray] | None = None
        else:
            self.focal_px = _focal_px(c)
            table = _lens_table(c, self.focal_px)
            if isinstance(table, str):
                raise ValueError(table)
            self._table = table
        self.cx = (c.width_px - 1) / 2.0
        self.cy = (c.height_px - 1) / 2.0 - c.principal_shift_px
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
        half_px = self.config.width_px / 2.0
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
        w, h = self.config.width_px, self.config.height_px
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
        u, v = np.meshgrid(np.arange(c.width_px, dtype=np.float64), np.arange(c.height_px))
        pts = self.floor_points(np.column_stack([u.ravel(), v.ravel()]), np.zeros(3))
        return pts.reshape(c.height_px, c.width_px, 2).astype(np.float32)

    def row_footprint_area_m2(self) -> np.ndarray:
        """(H,) floor area [m²] one pixel covers on each image row, at the centre column.

        The quad the pixel's four corners see on the floor (shoelace formula). For an ideal
        pinhole over a flat floor it depends on the row only; a distorted lens is measured on the
        centre column.
        """
        c = self.config
        u = (c.width_px - 1) / 2.0
        rows = np.arange(c.height_px, dtype=np.float64)
        corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]
        quad = [
            self.floor_points(np.column_stack([np.full_like(rows, u + du), rows + dv]), np.zeros(3))
            for du, dv in corners
        ]
        area = np.zeros(c.height_px)
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
        w, h = self.config.width_px, self.config.height_px
        return np.array([[-0.5, -0.5], [w - 0.5, -0.5], [w - 0.5, h - 0.5], [-0.5, h - 0.5]])

    def safe_box_floor_polygon(self, pose: np.ndarray) -> np.ndarray:
        """(N, 2) floor polygon [m] of the safe box (outer pixel edges), corners TL, TR, BR, BL.

        N = 4 for an ideal pinhole (straight edges); a distorted lens bends the box's edges on
        the floor, so each edge is sampled (N = 16).
        """
        return self._floor_points_of_rays(self._safe_box_rays, pose)

    def _safe_box_pixels(self) -> np.ndarray:
        rows, cols = safe_box_slices()
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

    def homography(self, pose: np.ndarray, ground: GroundTexture) -> np.ndarray:
        """(3, 3) homography from texel coordinates (col, row, 1) of ``ground`` to image pixels.

        ``cv2.warpPerspective(ground.rgba, H, size)`` renders the view; the renderer passes the
        inverse with ``cv2.WARP_INVERSE_MAP`` instead, which is the same picture.
        """
        return self.image_from_world(pose) @ ground.world_from_texture()


def safe_box_floor_polygon(pose: np.ndarray, config: CameraConfig | None = None) -> np.ndarray:
    """(N, 2) floor polygon [m] of the safe box for a rover at ``pose`` (x, y, theta); N = 4 for
    an ideal pinhole (see ``CameraModel.safe_box_floor_polygon``)."""
    return CameraModel(config).safe_box_floor_polygon(pose)


def _vignette(config: CameraConfig, strength: float) -> np.ndarray:
    """(H, W) float64 brightness factor, 1 at the centre; a smooth cos⁴-like radial falloff."""
    w, h = config.width_px, config.height_px
    u = (np.arange(w) - (w - 1) / 2.0) / ((w - 1) / 2.0)
    v = (np.arange(h) - (h - 1) / 2.0) / ((w - 1) / 2.0)
    r2 = (u[None, :] ** 2 + v[:, None] ** 2) / (1.0 + ((h - 1) / (w - 1)) ** 2)  # 1 at the corners
    return 1.0 - strength * r2 * (0.6 + 0.4 * r2)


def mip_bands(area_m2: np.ndarray, metres_per_px: float) -> tuple[tuple[int, int, int], ...]:
    """Bands of image rows (first row, stop row, mip level) for per-row footprints ``area_m2``.

    A row's level is round(½·log2(area / texel area)), clamped to 0 .. ``MAX_MIP_LEVEL``: the
    level whose texels cover about as much floor as the pixel does. Consecutive rows with the same
    level form one band.
    """
    texels = np.maximum(np.asarray(area_m2, dtype=np.float64) / metres_per_px**2, 1e-12)
    levels = np.clip(np.rint(0.5 * np.log2(texels)), 0, MAX_MIP_LEVEL).astype(int)
    bands = []
    start = 0
    for v in range(1, len(levels) + 1):
        if v == len(levels) or levels[v] != levels[start]:
            bands.append((start, v, int(levels[start])))
            start = v
    return tuple(bands)


#: The 256 input levels of the tone curve's table.
_LEVELS = np.arange(256.0)
_LEVELS.flags.writeable = False

#: Texel coordinates of mip level L are level 0's times 2^-L: the scaling per level.
_LEVEL_SCALES = tuple(np.diag([0.5**level, 0.5**level, 1.0]) for level in range(MAX_MIP_LEVEL + 1))

#: Fixed-point unit of the gain maps: a map value of 200 is a gain of 1 (so gains up to 1.27 fit).
_GAIN_ONE = 200.0


class CameraRenderer:
    """Renders camera frames from a ground texture, with the phone's image pipeline.

    Holds the auto-exposure state across frames; ``reset`` starts a new episode. All randomness
    comes from the generators passed to ``reset`` and ``render``.
    """

    def __init__(
        self, camera: CameraConfig | None = None, sensor: SensorConfig | None = None
    ) -> None:
        self.camera = camera or CameraConfig()
        self.sensor = sensor or SensorConfig()
        self.model = CameraModel(self.camera)
        self._vignette = _vignette(self.camera, self.sensor.vignetting)
        self._mean_vignette = float(self._vignette.mean())
        self._gain_maps: np.ndarray | None = None
        self._episode_started = False
        self._pad = 16
        self._noise_up: np.ndarray | None = None
        self._noise_down: np.ndarray | None = None
        self._cast = np.ones(3)
        self._gain: float | None = None
        self._last_raw: np.ndarray | None = None
        self._frame_gain: float | None = None  # the exposure gain the last frame was taken with
        # A distorted lens is rendered through a per-pixel floor map (rover frame), built once.
        self._floor_map = None if self.model.is_homography else self.model.floor_map_rover()
        self._mipmap = self.camera.texture_filter == "mipmap"
        self._row_area_m2 = self.model.row_footprint_area_m2() if self._mipmap else None
        self._bands: dict[float, tuple[tuple[int, int, int], ...]] = {}
        # How far from the rover's pose the view's footprint reaches (it is rigid on the rover).
        corners = self.model.footprint(np.zeros(3))
        self._footprint_reach_m = float(np.max(np.hypot(corners[:, 0], corners[:, 1])))

    def mip_bands(self, metres_per_px: float) -> tuple[tuple[int, int, int], ...]:
        """Row bands (first row, stop row, mip level) the ``"mipmap"`` filter renders for a
        texture of ``metres_per_px``; one band at level 0 for ``"bilinear"``."""
        if self._row_area_m2 is None:
            return ((0, self.camera.height_px, 0),)
        bands = self._bands.get(metres_per_px)
        if bands is None:
            bands = self._bands[metres_per_px] = mip_bands(self._row_area_m2, metres_per_px)
        return bands

    @property
    def exposure_gain(self) -> float | None:
        """Current auto-exposure gain (None before the first frame of an episode)."""
        return self._gain

    @property
    def last_felt_coverage(self) -> np.ndarray | None:
        """(H, W) uint8 felt coverage (255 = felt) in the last frame: ground truth for tests."""
        return None if self._last_raw is None else self._last_raw[..., 3]

    def reset(self, rng: np.random.Generator, *, new_pools: bool = True) -> None:
        """Start an episode: draw the colour cast, white balances and noise, forget the exposure.

        With ``new_pools=False`` (and pools drawn before) the colour cast, white-balance maps and
        noise pool are kept and only the exposure is forgotten: drawing the pools costs ~0.1 s,
        which would dominate short episodes in the same world.
        """
        s = self.sensor
        already = self._episode_started
        self._episode_started = True
        if not new_pools and already:
            self._gain = None
            return
        self._cast = 1.0 + s.white_balance_cast * rng.standard_normal(3)
        # Vignetting × white balance as a pool of per-pixel, per-channel gain maps, one per
        # jittered white balance: a frame then costs one uint8 multiply for both effects.
        jitter = 1.0 + s.white_balance_jitter * rng.standard_normal((s.white_balance_pool, 3))
        balances = self._cast[None, :] * jitter
        if s.vignetting == 0 and np.all(balances == 1.0):
            self._gain_maps = None
        else:
            maps = self._vignette[None, :, :, None] * balances[:, None, None, :] * _GAIN_ONE
            self._gain_maps = np.clip(np.rint(maps), 0, 255).astype(np.uint8)
        self._gain = None  # settles on the first frame, as a camera does before recording
        if s.noise_std > 0:
            h, w = self.camera.height_px + self._pad, self.camera.width_px + self._pad
            noise = rng.standard_normal((s.noise_pool_frames, h, w, 3), dtype=np.float32)
            noise = np.rint(noise * np.float32(s.noise_std))
            # Split into two saturating uint8 adds, much faster than signed arithmetic per frame.
            self._noise_up = np.clip(noise, 0, 255).astype(np.uint8)
            self._noise_down = np.clip(-noise, 0, 255).astype(np.uint8)
        else:
            self._noise_up = self._noise_down = None

    def _tone_table(self, gain: float) -> np.ndarray:
        """(256,) uint8 table: level × exposure gain, with a soft highlight shoulder."""
        levels = _LEVELS * gain
        knee = 255.0 * self.sensor.highlight_knee
        span = 255.0 - knee
        if span > 0:
            # Above the knee the curve bends smoothly (slope 1 at the knee) towards 255, as phone
            # tone curves do, so bright felt keeps some gradation instead of clipping flat. The
            # levels rise with the input (the gain is positive): those above the knee are a tail.
            over = levels[int(np.searchsorted(levels, knee, side="right")) :]
            over[...] = knee + span * -np.expm1(-(over - knee) / span)
        np.rint(levels, out=levels)
        np.maximum(levels, 0.0, out=levels)
        np.minimum(levels, 255.0, out=levels)
        return levels.astype(np.uint8)

    def _sees_past_margin(self, ground: GroundTexture, pose: np.ndarray) -> bool:
        """Whether the view reaches further past a texture edge than the carpet margin is wide."""
        # No corner is further from the pose than the footprint's reach: while the whole circle
        # of that reach stays short of the limit past every edge, the answer is no (the usual
        # case, decided without projecting the corners; two texels of slack dwarf any rounding).
        h, w = ground.shape
        mpp = ground.metres_per_px
        reach = self._footprint_reach_m / mpp
        slack = 0.9 * ground.margin_m / mpp - 2.0
        col = (float(pose[0]) - ground.origin_xy[0]) / mpp
        row = (ground.origin_xy[1] - float(pose[1])) / mpp
        if (
            min(col, row) - reach >= -slack
            and col + reach <= w - 1 + slack
            and row + reach <= h - 1 + slack
        ):
            return False
        corners = ground.to_texture(self.model.footprint(pose))
        beyond_px = max(
            float(-corners.min()),
            float(corners[:, 0].max()) - (w - 1),
            float(corners[:, 1].max()) - (h - 1),
        )
        return beyond_px * ground.metres_per_px > 0.9 * ground.margin_m

    def _motion_kernel(self, pose: np.ndarray, motion: np.ndarray) -> np.ndarray | None:
        """Line kernel along the image displacement of the floor under the image centre."""
        centre_px = np.array([[self.model.cx, self.model.cy]])
        floor = self.model.floor_points(centre_px, pose)
        before = self.model.project(floor, np.asarray(pose, dtype=np.float64) - np.asarray(motion))
        disp = (centre_px - before)[0]
        if not np.all(np.isfinite(disp)):
            return None
        length = float(np.hypot(*disp)) * self.sensor.motion_blur_fraction
        if length < 1.0:
            return None
        size = int(math.ceil(length)) | 1
        kernel = np.zeros((size, size), dtype=np.float32)
        c = size // 2
        direction = disp / np.hypot(*disp)
        a = np.rint(np.array([c, c]) - direction * length / 2.0).astype(int)
        b = np.rint(np.array([c, c]) + direction * length / 2.0).astype(int)
        cv2.line(kernel, (int(a[0]), int(a[1])), (int(b[0]), int(b[1])), 1.0, 1, cv2.LINE_AA)
        return kernel / kernel.sum()

    def _warp_pinhole(self, ground: GroundTexture, pose: np.ndarray) -> np.ndarray:
        """(H, W, 4) uint8 RGBA view through an ideal pinhole: one floor homography."""
        c = self.camera
        tex_from_img = np.linalg.inv(self.model.homography(pose, ground))
        size = (c.width_px, c.height_px)
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        if self._mipmap:
            return self._warp_bands(ground, pose, tex_from_img)
        if self._sees_past_margin(ground, pose):
            # Mirroring the whole texture would bring felt back into view: fill the picture with
            # mirrored carpet first, then draw the texture over it where it reaches.
            raw = cv2.warpPerspective(
                ground.carpet_band, tex_from_img, size, flags=flags, borderMode=cv2.BORDER_REFLECT
            )
            cv2.warpPerspective(
                ground.rgba,
                tex_from_img,
                size,
                dst=raw,
                flags=flags,
                borderMode=cv2.BORDER_TRANSPARENT,
            )
        else:
            raw = cv2.warpPerspective(
                ground.rgba, tex_from_img, size, flags=flags, borderMode=cv2.BORDER_REFLECT
            )
        return raw

    def _warp_bands(
        self, ground: GroundTexture, pose: np.ndarray, tex_from_img: np.ndarray
    ) -> np.ndarray:
        """(H, W, 4) uint8 view through an ideal pinhole, each band of rows warped from its mip
        level: level L's texel coordinates are level 0's divided by 2^L."""
        c = self.camera
        raw = np.empty((c.height_px, c.width_px, 4), dtype=np.uint8)
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        past = self._sees_past_margin(ground, pose)
        for v0, v1, level in self.mip_bands(ground.metres_per_px):
            m = _LEVEL_SCALES[level] @ tex_from_img
            m[:, 2] += m[:, 1] * v0  # band row 0 is image row v0
            size = (c.width_px, v1 - v0)
            dst = raw[v0:v1]
            if past:
                cv2.warpPerspective(
                    ground.carpet_band_at(level),
                    m,
                    size,
                    dst=dst,
                    flags=flags,
                    borderMode=cv2.BORDER_REFLECT,
                )
                border = cv2.BORDER_TRANSPARENT
            else:
                border = cv2.BORDER_REFLECT
            out = cv2.warpPerspective(
                ground.mip_level(level), m, size, dst=dst, flags=flags, borderMode=border
            )
            if out is not dst and not np.shares_memory(out, dst):
                dst[...] = out
        return raw

    def _remap_bands(self, ground: GroundTexture, maps: np.ndarray, past: bool) -> np.ndarray:
        """(H, W, 4) uint8 view through a distorted lens, each band of rows remapped from its mip
        level (level-0 texel coordinates ``maps`` divided by 2^L)."""
        c = self.camera
        raw = np.empty((c.height_px, c.width_px, 4), dtype=np.uint8)
        for v0, v1, level in self.mip_bands(ground.metres_per_px):
            band = maps[v0:v1] * np.float32(0.5**level) if level else maps[v0:v1]
            dst = raw[v0:v1]
            if past:
                cv2.remap(
                    ground.carpet_band_at(level),
                    band,
                    None,
                    cv2.INTER_LINEAR,
                    dst=dst,
                    borderMode=cv2.BORDER_REFLECT,
                )
            border = cv2.BORDER_TRANSPARENT if past else cv2.BORDER_REFLECT
            out = cv2.remap(
                ground.mip_level(level), band, None, cv2.INTER_LINEAR, dst=dst, borderMode=border
            )
            if out is not dst and not np.shares_memory(out, dst):
                dst[...] = out
        return raw

    def _remap_lens(self, ground: GroundTexture, pose: np.ndarray) -> np.ndarray:
        """(H, W, 4) uint8 RGBA view through a distorted lens: the rover-frame floor map, moved
        to ``pose`` and into texel coordinates by one affine transform, then ``cv2.remap``."""
        assert self._floor_map is not None
        x, y, theta = (float(v) for v in pose)
        ct, st = math.cos(theta), math.sin(theta)
        world_from_rover = np.array([[ct, -st, x], [st, ct, y], [0.0, 0.0, 1.0]])
        tex_from_rover = (ground.texture_from_world() @ world_from_rover)[:2]
        maps = cv2.transform(self._floor_map, tex_from_rover)  # (H, W, 2) float32 texel coords
        if self._mipmap:
            return self._remap_bands(ground, maps, self._sees_past_margin(ground, pose))
        if self._sees_past_margin(ground, pose):
            raw = cv2.remap(
                ground.carpet_band, maps, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT
            )
            cv2.remap(
                ground.rgba,
                maps,
                None,
                cv2.INTER_LINEAR,
                dst=raw,
                borderMode=cv2.BORDER_TRANSPARENT,
            )
            return raw
        return cv2.remap(ground.rgba, maps, None, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REFLECT)

    def view(self, ground: GroundTexture, pose: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A still frame from another ``pose`` taken as the last frame was (its exposure, the
        colour cast and noise pools), leaving the camera as it was: the exposure it settles
        towards and the last raw frame stay those of the frames :meth:`render` drew. Draws the
        frame's white balance and noise from ``rng``."""
        gain, last_raw, frame_gain = self._gain, self._last_raw, self._frame_gain
        if frame_gain is not None:
            self._gain = frame_gain  # the exposure of the last frame, not the next one's
        try:
            return self.render(ground, pose, rng)
        finally:
            self._gain, self._last_raw, self._frame_gain = gain, last_raw, frame_gain

    def render(
        self,
        ground: GroundTexture,
        pose: np.ndarray,
        rng: np.random.Generator,
        motion: np.ndarray | None = None,
    ) -> np.ndarray:
        """Render the camera frame for a rover at ``pose`` (x [m], y [m], theta [rad]).

        ``motion`` (3,) is the pose change over the last step (dx, dy, dtheta), used only for
        motion blur. Returns (H, W, 3) uint8 RGB, a new array each call. Draws from ``rng``:
        the frame's white balance (one of the pool drawn at reset), the noise frame and offset.
        """
        s, c = self.sensor, self.camera
        if not self._episode_started:
            self.reset(rng)
        if self._floor_map is not None:
            raw = self._remap_lens(ground, pose)
        else:
            raw = self._warp_pinhole(ground, pose)
        self._last_raw = raw
        if s.motion_blur and motion is not None:
            kernel = self._motion_kernel(pose, motion)
            if kernel is not None:
                raw = cv2.filter2D(raw, -1, kernel, borderType=cv2.BORDER_REFLECT)

        # Auto-exposure: this frame uses the gain set from earlier frames; the meter then moves
        # the gain towards the target with the configured lag (in log space, like EV steps).
        # The meter reads a coarse 80 × 60 grid of samples, like a phone's AE statistics.
        means = cv2.mean(cv2.resize(raw, _METER_GRID, interpolation=cv2.INTER_NEAREST))
        luma = max(float(_LUMA @ np.array(means[:3])) * self._mean_vignette, 1e-3)
        wanted = float(min(max(s.exposure_target / luma, s.exposure_min_gain), s.exposure_max_gain))
        if self._gain is None:
            self._gain = wanted
        gain = self._frame_gain = self._gain
        rate = 1.0 if s.exposure_lag_frames == 0 else 1.0 - math.exp(-1.0 / s.exposure_lag_frames)
        self._gain = math.exp(math.log(gain) + rate * (math.log(wanted) - math.log(gain)))

        # Exposure and tone curve: one lookup table shared by the three channels (OpenCV's
        # single-table LUT over the interleaved rows is twice as fast as a per-channel one).
        rgb = cv2.cvtColor(raw, cv2.COLOR_RGBA2RGB)
        table = self._tone_table(gain)
        frame = cv2.LUT(rgb.reshape(c.height_px, -1), table).reshape(rgb.shape)
        # Vignetting × this frame's white balance (applied after the tone curve: an approximation
        # that only matters in the highlights, where the balance is within a few per cent).
        if self._gain_maps is not None:
            k = int(rng.integers(len(self._gain_maps)))
            frame = cv2.multiply(frame, self._gain_maps[k], scale=1.0 / _GAIN_ONE)
        if self._noise_up is not None and self._noise_down is not None:
            k = int(rng.integers(s.noise_pool_frames))
            dy, dx = (int(v) for v in rng.integers(self._pad + 1, size=2))
            view = (k, slice(dy, dy + c.height_px), slice(dx, dx + c.width_px))
            cv2.add(frame, self._noise_up[view], dst=frame)
            cv2.subtract(frame, self._noise_down[view], dst=frame)
        if s.jpeg_quality > 0:
            ok, buf = cv2.imencode(
                ".jpg",
                np.ascontiguousarray(frame[..., ::-1]),
                [cv2.IMWRITE_JPEG_QUALITY, s.jpeg_quality],
            )
            if ok:
                frame = np.ascontiguousarray(cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1])
        return frame
