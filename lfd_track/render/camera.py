"""The rover's phone camera as a sensor: a fast frame renderer and the phone's image pipeline.

The lens geometry (which floor point each pixel sees) is :mod:`lfd_track.core.camera_model`;
this module draws frames through it. Rendering an ideal pinhole is one ground-plane homography
(``cv2.warpPerspective``, linear interpolation) from the ground texture. A distorted lens is
rendered by ``cv2.remap`` through a per-pixel map of the floor points each pixel sees
(``CameraModel.floor_map_rover``), computed once in the rover's frame (the camera is rigid on the
rover) and moved with the pose by one affine transform per frame. With
``texture_filter = "mipmap"`` each band of image rows is sampled the same way from the texture's
pre-filtered mip level that matches the pixel's floor footprint (``mip_bands``). Then comes the
phone's image pipeline: auto-exposure that adapts with a lag, white-balance jitter, vignetting,
sensor noise, and optionally motion blur and JPEG compression.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..core.camera_model import CameraConfig, CameraModel
from .texture import GroundTexture

#: Rec. 601 luma weights of R, G, B, used to meter brightness.
_LUMA = np.array([0.299, 0.587, 0.114])
#: Samples (columns, rows) the auto-exposure meter reads per frame.
_METER_GRID = (80, 60)
#: Coarsest mip level the ``"mipmap"`` filter uses (2^6 = 64 texels per level-6 texel).
MAX_MIP_LEVEL = 6


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


def _vignette(config: CameraConfig, strength: float) -> np.ndarray:
    """(H, W) float64 brightness factor, 1 at the centre; a smooth cos⁴-like radial falloff."""
    w, h = config.frame_width_px, config.frame_height_px
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


def _remap(
    src: np.ndarray, texel_xy: np.ndarray, border: int, dst: np.ndarray | None = None
) -> np.ndarray:
    """``cv2.remap`` of ``src`` with bilinear sampling at the (H, W, 2) float32 texel coordinates
    (col, row) ``texel_xy``, into ``dst`` when given."""
    # OpenCV takes one two-channel map with map2=None; its stubs mark map2 as required.
    return cv2.remap(src, texel_xy, None, cv2.INTER_LINEAR, dst=dst, borderMode=border)  # type: ignore[call-overload]


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
        # A smaller camera (``scale``) is the full one binned: averaging 1/scale² pixels divides
        # the sensor noise's std by 1/scale (the same noise per unit of the picture).
        self._noise_std = self.sensor.noise_std * min(self.camera.scale, 1.0)
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
            return ((0, self.camera.frame_height_px, 0),)
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
        if self._noise_std > 0:
            h = self.camera.frame_height_px + self._pad
            w = self.camera.frame_width_px + self._pad
            noise = rng.standard_normal((s.noise_pool_frames, h, w, 3), dtype=np.float32)
            noise = np.rint(noise * np.float32(self._noise_std))
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
        size = (c.frame_width_px, c.frame_height_px)
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
        raw = np.empty((c.frame_height_px, c.frame_width_px, 4), dtype=np.uint8)
        flags = cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP
        past = self._sees_past_margin(ground, pose)
        for v0, v1, level in self.mip_bands(ground.metres_per_px):
            m = _LEVEL_SCALES[level] @ tex_from_img
            m[:, 2] += m[:, 1] * v0  # band row 0 is image row v0
            size = (c.frame_width_px, v1 - v0)
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
        raw = np.empty((c.frame_height_px, c.frame_width_px, 4), dtype=np.uint8)
        for v0, v1, level in self.mip_bands(ground.metres_per_px):
            band = maps[v0:v1] * np.float32(0.5**level) if level else maps[v0:v1]
            dst = raw[v0:v1]
            if past:
                _remap(ground.carpet_band_at(level), band, cv2.BORDER_REFLECT, dst=dst)
            border = cv2.BORDER_TRANSPARENT if past else cv2.BORDER_REFLECT
            out = _remap(ground.mip_level(level), band, border, dst=dst)
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
            raw = _remap(ground.carpet_band, maps, cv2.BORDER_REFLECT)
            _remap(ground.rgba, maps, cv2.BORDER_TRANSPARENT, dst=raw)
            return raw
        return _remap(ground.rgba, maps, cv2.BORDER_REFLECT)

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
        frame = cv2.LUT(rgb.reshape(c.frame_height_px, -1), table).reshape(rgb.shape)
        # Vignetting × this frame's white balance (applied after the tone curve: an approximation
        # that only matters in the highlights, where the balance is within a few per cent).
        if self._gain_maps is not None:
            k = int(rng.integers(len(self._gain_maps)))
            frame = cv2.multiply(frame, self._gain_maps[k], scale=1.0 / _GAIN_ONE)
        if self._noise_up is not None and self._noise_down is not None:
            k = int(rng.integers(s.noise_pool_frames))
            dy, dx = (int(v) for v in rng.integers(self._pad + 1, size=2))
            view = (k, slice(dy, dy + c.frame_height_px), slice(dx, dx + c.frame_width_px))
            cv2.add(frame, self._noise_up[view], dst=frame)
            cv2.subtract(frame, self._noise_down[view], dst=frame)
        if s.jpeg_quality > 0:
            ok, buf = cv2.imencode(
                ".jpg",
                np.ascontiguousarray(frame[..., ::-1]),
                [cv2.IMWRITE_JPEG_QUALITY, s.jpeg_quality],
            )
            decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR) if ok else None
            if decoded is not None:
                frame = np.ascontiguousarray(decoded[..., ::-1])
        return frame
