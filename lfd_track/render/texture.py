"""Procedural top-down ground texture: light-blue felt strips on dark-brown loop-pile carpet.

The whole floor around a track is painted once per episode into one RGBA image:
felt and carpet textures are drawn from the episode's random generator and the room lighting
(ceiling light pools and soft shadow bands) is baked in, since it is fixed relative to the floor.
The camera renders views from this image with a ground-plane homography.

Beyond the texture the carpet continues: the camera samples with ``cv2.BORDER_REFLECT``, so a
point past the edge shows the carpet mirrored at the edge. The margin band between the felt and
the texture edge holds only carpet, so as long as the camera sees no further past the edge than
the margin is wide (true for the paper's camera anywhere near the felt) the mirror shows carpet,
never felt. For views reaching further (a flatter camera), the renderer fills the outside from
the top margin band alone, mirrored, which is carpet however far it repeats
(``GroundTexture.carpet_band``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import cv2
import numpy as np

from ..world.track import Track
from .felt_windows import (
    _BAND_ROWS,
    _CHUNK_ROWS,
    _FELT_CELL,
    _felt_window,
    _felt_windows,
    _FeltWindow,
    _gauss_reach,
    _rgb,
)

#: Largest allowed texture size [bytes] (≤ 100 MB per env instance).
MAX_TEXTURE_BYTES = 100 * 1024 * 1024


@dataclass(frozen=True)
class AppearanceConfig:
    """Colours and procedural texture of felt and carpet (TOML table ``[appearance]``)."""

    felt_rgb: tuple[int, int, int] = (118, 176, 214)
    """Mean felt colour under full light, 8-bit RGB (light blue)."""
    carpet_rgb: tuple[int, int, int] = (78, 54, 38)
    """Mean carpet colour under full light, 8-bit RGB (dark brown)."""
    metres_per_px: float = 0.002
    """Texture resolution [m/px]; at most 0.002 (2 mm)."""
    margin_m: float = 1.5
    """Carpet border painted around the felt [m]; see the module docstring on what lies beyond."""
    carpet_pile_strength: float = 0.16
    """Relative brightness contrast of the carpet's loops (std of the brightness factor)."""
    carpet_pile_scale_m: float = 0.004
    """Size of one carpet loop [m]."""
    carpet_fleck_strength: float = 0.10
    """Per-channel colour variation of the carpet fibres (heathered yarn), relative."""
    carpet_patchiness: float = 0.04
    """Slow brightness variation of the carpet over tens of centimetres (wear, pile direction)."""
    felt_fibre_strength: float = 0.07
    """Relative brightness contrast of the felt's fibres."""
    felt_fibre_length_m: float = 0.012
    """Typical length of a visible felt fibre streak [m]."""
    felt_nonuniformity: float = 0.04
    """Slow relative brightness variation of the felt (dye and thickness), std."""
    felt_tint_variation: float = 0.025
    """Slow per-channel colour variation of the felt (dye lots), std, relative."""
    felt_nonuniformity_scale_m: float = 0.08
    """Spatial scale of the felt's slow variations [m]."""
    edge_fuzz_m: float = 0.003
    """Width of the frayed, fuzzy felt edge [m]."""

    def __post_init__(self) -> None:
        for name in ("felt_rgb", "carpet_rgb"):
            rgb = getattr(self, name)
            if len(rgb) != 3 or not all(0 <= int(c) <= 255 for c in rgb):
                raise ValueError(f"{name} must be three integers in 0..255, got {rgb!r}")
        if not 0.0 < self.metres_per_px <= 0.002:
            raise ValueError(f"metres_per_px must be in (0, 0.002], got {self.metres_per_px}")
        if self.margin_m < 0.5:
            raise ValueError(f"margin_m must be at least 0.5 m, got {self.margin_m}")
        for name in ("carpet_pile_scale_m", "felt_fibre_length_m", "felt_nonuniformity_scale_m"):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        for name in (
            "carpet_pile_strength",
            "carpet_fleck_strength",
            "carpet_patchiness",
            "felt_fibre_strength",
            "felt_nonuniformity",
            "felt_tint_variation",
            "edge_fuzz_m",
        ):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ValueError(f"{name} must be in [0, 1], got {getattr(self, name)}")


@dataclass(frozen=True)
class LightingConfig:
    """Room lighting baked into the floor texture (TOML table ``[lighting]``)."""

    ambient: float = 0.72
    """Illumination far from any light pool, relative to the texture colours (1 = full light)."""
    pool_count: int = 3
    """Number of ceiling light pools, centred at random over the track area."""
    pool_radius_m: float = 1.3
    """Radius (Gaussian sigma) of a light pool on the floor [m]."""
    pool_strength: float = 0.30
    """Extra illumination at a pool's centre, relative."""
    max_illumination: float = 1.05
    """Illumination is clipped here so pools overlapping do not wash the floor out."""
    shadow_count: int = 1
    """Number of soft shadow bands; each crosses the track at a random place (at least one)."""
    shadow_width_m: float = 0.40
    """Width of the fully shaded core of a shadow band [m]."""
    shadow_darkness: float = 0.45
    """Fraction of the light removed in a shadow band's core."""
    shadow_softness_m: float = 0.12
    """Width of the penumbra on each side of a shadow band [m]."""
    shadow_min_crossing_deg: float = 35.0
    """Smallest angle between a shadow band and the strip it crosses [deg]."""
    grid_m: float = 0.02
    """Resolution at which the smooth illumination field is computed, then upsampled [m]."""

    def __post_init__(self) -> None:
        if not 0.0 < self.ambient <= 2.0:
            raise ValueError(f"ambient must be in (0, 2], got {self.ambient}")
        if self.pool_count < 0:
            raise ValueError(f"pool_count must be >= 0, got {self.pool_count}")
        if self.shadow_count < 1:
            raise ValueError(
                f"shadow_count must be >= 1 (a band must cross the track), got {self.shadow_count}"
            )
        if not 0.0 <= self.shadow_darkness < 1.0:
            raise ValueError(f"shadow_darkness must be in [0, 1), got {self.shadow_darkness}")
        for name in (
            "pool_radius_m",
            "shadow_width_m",
            "shadow_softness_m",
            "grid_m",
            "max_illumination",
        ):
            if getattr(self, name) <= 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if not 0.0 <= self.shadow_min_crossing_deg <= 90.0:
            raise ValueError(
                f"shadow_min_crossing_deg must be in [0, 90], got {self.shadow_min_crossing_deg}"
            )


@dataclass(frozen=True)
class ShadowBand:
    """One straight soft shadow band on the floor."""

    point: tuple[float, float]  # a point on the band's centre line [m]
    angle_rad: float  # direction of the band's centre line, from +x, counter-clockwise [rad]


@dataclass(frozen=True, eq=False)
class GroundTexture:
    """A top-down picture of the floor, with its mapping to world coordinates.

    ``rgba`` is (H, W, 4) uint8: RGB colour with the lighting baked in, and in the fourth channel
    the felt coverage (255 = felt, 0 = carpet, between at the fuzzy edge). Four channels are kept
    because OpenCV warps them much faster than three. Texel (col, row) has its centre at world
    ``(origin_xy[0] + col * metres_per_px, origin_xy[1] - row * metres_per_px)``: rows grow
    downwards in the image while y grows upwards in the world.
    """

    rgba: np.ndarray
    origin_xy: tuple[float, float]  # world position of texel (0, 0)'s centre [m]
    metres_per_px: float
    illumination: np.ndarray  # (h, w) float32 illumination on the coarse lighting grid
    illumination_m_per_px: float  # coarse grid resolution [m/px], same origin as the texture
    shadows: tuple[ShadowBand, ...]
    margin_m: float  # carpet-only border between the felt's bounding box and the texture edge [m]

    def mip_level(self, level: int) -> np.ndarray:
        """(H_L, W_L, 4) uint8 texture pre-filtered and halved ``level`` times (0 = ``rgba``).

        Each level is ``cv2.pyrDown`` of the one before (a 5 × 5 binomial low-pass, then every
        second texel): level L's texel (c, r) sits at level 0's texel (2^L·c, 2^L·r) and averages
        about 2^L × 2^L of its texels, as the camera's pixel does where it covers that many.
        Built on first use and kept (a third more memory than ``rgba``); deterministic.
        """
        if level < 0:
            raise ValueError(f"mip level must be >= 0, got {level}")
        levels = self._mips()
        while len(levels) <= level:
            levels.append(cv2.pyrDown(levels[-1], borderType=cv2.BORDER_REFLECT_101))
        return levels[level]

    def _mips(self) -> list[np.ndarray]:
        levels = self.__dict__.get("_mip_cache")
        if levels is None:
            levels = [self.rgba]
            object.__setattr__(self, "_mip_cache", levels)  # frozen dataclass: a private cache
        return levels

    def carpet_band_at(self, level: int) -> np.ndarray:
        """``carpet_band`` of mip level ``level`` (its top rows, which hold carpet only)."""
        return self.mip_level(level)[: max(self.carpet_band.shape[0] >> level, 1)]

    @property
    def carpet_band(self) -> np.ndarray:
        """(M, W, 4) view of the texture's top rows, which hold carpet only (M spans the margin).

        Mirror-tiled (``cv2.BORDER_REFLECT``) it gives carpet everywhere, in the texture's texel
        coordinates: the renderer's fill for views reaching far beyond the texture.
        """
        rows = max(int(self.margin_m / self.metres_per_px) - 2, 1)
        return self.rgba[:rows]

    @property
    def image(self) -> np.ndarray:
        """(H, W, 3) uint8 RGB view of the texture (not contiguous; copy before cv2 calls)."""
        return self.rgba[..., :3]

    @property
    def felt_mask(self) -> np.ndarray:
        """(H, W) bool: texels mostly covered by felt."""
        return self.rgba[..., 3] >= 128

    @property
    def shape(self) -> tuple[int, int]:
        """(H, W) in texels."""
        return self.rgba.shape[0], self.rgba.shape[1]

    @property
    def nbytes(self) -> int:
        """Memory held by the texture arrays [bytes]."""
        return int(self.rgba.nbytes + self.illumination.nbytes)

    def world_from_texture(self) -> np.ndarray:
        """(3, 3) float64 affine map from texel coordinates (col, row, 1) to world (x, y, 1) [m]."""
        s = self.metres_per_px
        x0, y0 = self.origin_xy
        return np.array([[s, 0.0, x0], [0.0, -s, y0], [0.0, 0.0, 1.0]])

    def texture_from_world(self) -> np.ndarray:
        """(3, 3) float64 affine map from world (x, y, 1) [m] to texel coordinates (col, row, 1)."""
        s = self.metres_per_px
        x0, y0 = self.origin_xy
        return np.array([[1.0 / s, 0.0, -x0 / s], [0.0, -1.0 / s, y0 / s], [0.0, 0.0, 1.0]])

    def to_texture(self, points: np.ndarray) -> np.ndarray:
        """World points (..., 2) [m] → texel coordinates (..., 2) float64 (col, row)."""
        pts = np.asarray(points, dtype=np.float64)
        col = (pts[..., 0] - self.origin_xy[0]) / self.metres_per_px
        row = (self.origin_xy[1] - pts[..., 1]) / self.metres_per_px
        return np.stack([col, row], axis=-1)

    def illumination_at(self, points: np.ndarray) -> np.ndarray:
        """Baked illumination factor (...) at world points (..., 2) [m] (nearest coarse cell)."""
        pts = np.asarray(points, dtype=np.float64)
        s = self.illumination_m_per_px
        col = np.rint((pts[..., 0] - self.origin_xy[0]) / s).astype(np.int64)
        row = np.rint((self.origin_xy[1] - pts[..., 1]) / s).astype(np.int64)
        h, w = self.illumination.shape
        return self.illumination[np.clip(row, 0, h - 1), np.clip(col, 0, w - 1)]


def _value_noise(rng: np.random.Generator, shape: tuple[int, int], cell_px: float) -> np.ndarray:
    """Smooth noise (H, W) float32, std ≈ 1, with features about ``cell_px`` texels wide.

    White noise on a coarse grid, upsampled with bicubic interpolation (cheap and seamless).
    """
    out, scale = _value_noise_unscaled(rng, shape, cell_px)
    out *= scale
    return out


def _value_noise_unscaled(
    rng: np.random.Generator,
    shape: tuple[int, int],
    cell_px: float,
    out: np.ndarray | None = None,
) -> tuple[np.ndarray, np.float32]:
    """``_value_noise`` before its last step: the upsampled field and the factor that brings its
    std to ≈ 1, so a caller using only part of the field scales only that part (same values).
    The field is written into ``out`` if given ((H, W) float32 no longer needed)."""
    h, w = shape
    cell = max(cell_px, 1.0)
    gh, gw = max(int(round(h / cell)), 2), max(int(round(w / cell)), 2)
    coarse = rng.standard_normal((gh, gw), dtype=np.float32)
    out = cv2.resize(coarse, (w, h), dst=out, interpolation=cv2.INTER_CUBIC)
    # Interpolation lowers the std of white noise (to about 0.6 for large cells); restore ≈ 1.
    return out, np.float32(1.0 / max(float(out[::7, ::7].std()), 1e-6))


def _smoothstep(x: np.ndarray) -> np.ndarray:
    x = np.clip(x, 0.0, 1.0)
    return x * x * (3.0 - 2.0 * x)


def _shadow_bands(
    track: Track, lighting: LightingConfig, rng: np.random.Generator
) -> tuple[ShadowBand, ...]:
    """Draw shadow bands, each crossing a random point of the centreline at an angle to it."""
    bands = []
    min_cross = math.radians(lighting.shadow_min_crossing_deg)
    for _ in range(lighting.shadow_count):
        s = float(rng.uniform(0.0, track.length_m))
        point, heading = track.point_at(s)
        cross = float(rng.uniform(min_cross, math.pi - min_cross))
        bands.append(ShadowBand((float(point[0]), float(point[1])), heading + cross))
    return tuple(bands)


def _illumination(
    track: Track,
    lighting: LightingConfig,
    bands: tuple[ShadowBand, ...],
    origin_xy: tuple[float, float],
    shape_m: tuple[float, float],
    rng: np.random.Generator,
) -> tuple[np.ndarray, float]:
    """Coarse illumination grid (h, w) float32 and its resolution [m/px]."""
    step = lighting.grid_m
    width_m, height_m = shape_m
    w = int(math.ceil(width_m / step)) + 1
    h = int(math.ceil(height_m / step)) + 1
    xs = origin_xy[0] + np.arange(w, dtype=np.float32) * step
    ys = origin_xy[1] - np.arange(h, dtype=np.float32) * step
    gx, gy = np.meshgrid(xs, ys)
    light = np.full((h, w), lighting.ambient, dtype=np.float32)
    xmin, ymin, xmax, ymax = track.bounds(0.5)
    for _ in range(lighting.pool_count):
        cx, cy = rng.uniform(xmin, xmax), rng.uniform(ymin, ymax)
        r2 = (gx - cx) ** 2 + (gy - cy) ** 2
        light += lighting.pool_strength * np.exp(-r2 / (2.0 * lighting.pool_radius_m**2))
    np.minimum(light, lighting.max_illumination, out=light)
    half = lighting.shadow_width_m / 2.0
    soft = lighting.shadow_softness_m
    for band in bands:
        nx, ny = -math.sin(band.angle_rad), math.cos(band.angle_rad)
        dist = np.abs((gx - band.point[0]) * nx + (gy - band.point[1]) * ny)
        # 1 in the core, 0 outside, a smooth penumbra of width ``soft`` between.
        core = _smoothstep((half + soft - dist) / soft)
        light *= 1.0 - lighting.shadow_darkness * core
    return light, step


def build_ground(
    track: Track, appearance: AppearanceConfig, lighting: LightingConfig, rng: np.random.Generator
) -> GroundTexture:
    """Paint the floor around ``track``: felt strips, carpet, light pools and shadow bands.

    Everything random is drawn from ``rng``, so the same seed gives the same bytes.

    The felt's fields (coverage, fibres, dye) are computed only in windows around the strips, the
    carpet's everywhere, and every texel gets the bytes it would get if each field were computed
    over the whole floor (``tests/render/test_ground_reference.py`` compares the two): OpenCV's
    filters give a texel the same value wherever it sits in the image they are given, as long as
    that image holds every texel the kernel reaches (each window is cut with such a halo; the
    box filters' running sums of these float32 values are exact in their float64 sums); outside
    the windows the felt's coverage is exactly 0 (no strip within the blur's reach), so the
    felt's terms of the colour are exact zeros there and are left out.
    """
    mpp = appearance.metres_per_px
    xmin, ymin, xmax, ymax = track.bounds(appearance.margin_m)
    w = int(math.ceil((xmax - xmin) / mpp)) + 1
    h = int(math.ceil((ymax - ymin) / mpp)) + 1
    if h * w * 4 > MAX_TEXTURE_BYTES:
        raise ValueError(
            f"ground texture for track '{track.name}' would take {h * w * 4 / 2**20:.0f} MB "
            f"(> {MAX_TEXTURE_BYTES / 2**20:.0f} MB): raise metres_per_px or lower margin_m"
        )
    origin = (xmin, ymax)
    shape = (h, w)

    # One full-resolution white-noise field feeds every fine texture below; the regions where
    # each use is visible (felt, carpet, the felt's edge) barely overlap, so reuse is invisible
    # and saves most of the build time.
    fine = rng.standard_normal(shape, dtype=np.float32)

    # Felt coverage: strips rasterised with sub-texel precision (into an image padded to whole
    # window cells; the strips lie inside the margin, so the floor's part is the same), then a
    # frayed edge.
    shift = 4
    cell = _FELT_CELL
    padded = np.zeros((-(-h // cell) * cell, -(-w // cell) * cell), dtype=np.uint8)
    for poly in track.strip_polygons():
        col = (poly[:, 0] - origin[0]) / mpp
        row = (origin[1] - poly[:, 1]) / mpp
        pts = np.rint(np.stack([col, row], axis=1) * (1 << shift)).astype(np.int32)
        cv2.fillPoly(padded, [pts], 255, lineType=cv2.LINE_8, shift=shift)
    mask = padded[:h, :w]
    fuzz_px = appearance.edge_fuzz_m / mpp
    fuzzy = fuzz_px > 0.25
    runs_per_band = _felt_windows(padded, _gauss_reach(fuzz_px) if fuzzy else 0)
    del padded

    # Felt: short fibre streaks in two directions over a soft pilled surface, slow dye variation.
    # The vertical streaks are blurred in the field flipped upside down (rows counted from the
    # bottom), so a window's rows are cut from the flipped field.
    fibre_px = max(int(round(appearance.felt_fibre_length_m / mpp)), 1)
    k_fibre = appearance.felt_fibre_strength
    flipped = fine[::-1]
    felt: list[_FeltWindow] = []
    for b, runs in enumerate(runs_per_band):
        rows = (b * _BAND_ROWS, min((b + 1) * _BAND_ROWS, h))
        for cols in runs:
            cols = (cols[0], min(cols[1], w))
            felt.append(
                _felt_window(mask, fine, flipped, rows, cols, fuzz_px, fuzzy, fibre_px, k_fibre)
            )
    del flipped

    # Carpet: loops (blobs about one loop wide) with fine fibre grain, slow wear patches.
    pile_px = appearance.carpet_pile_scale_m / mpp
    k_pile = appearance.carpet_pile_strength
    carpet_shade = _value_noise(rng, shape, pile_px)
    cv2.addWeighted(carpet_shade, 0.75 * k_pile, fine, 0.45 * k_pile, 1.0, dst=carpet_shade)
    patches, patch_scale = _value_noise_unscaled(rng, shape, 0.25 / mpp, out=fine)
    del fine  # its memory now holds the patches (fresh full-size arrays cost page faults)
    patches *= patch_scale
    cv2.addWeighted(carpet_shade, 1.0, patches, appearance.carpet_patchiness, 0.0, dst=carpet_shade)

    slow_px = appearance.felt_nonuniformity_scale_m / mpp
    slow, slow_scale = _value_noise_unscaled(rng, shape, slow_px, out=patches)
    del patches
    for win in felt:
        win.shade = cv2.addWeighted(
            win.shade,
            1.0,
            slow[win.rows, win.cols] * slow_scale,
            appearance.felt_nonuniformity,
            0.0,
        )

    shadows = _shadow_bands(track, lighting, rng)
    light, light_step = _illumination(
        track, lighting, shadows, origin, ((w - 1) * mpp, (h - 1) * mpp), rng
    )
    # Texel (c, r) sits at coarse position (c, r) * mpp / step: an exact affine upsampling.
    inv_scale = mpp / light_step
    light_full: np.ndarray = cv2.warpAffine(
        light,
        np.array([[inv_scale, 0.0, 0.0], [0.0, inv_scale, 0.0]]),
        (w, h),
        dst=slow,
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REPLICATE,
    )
    del slow
    carpet_lit = carpet_shade
    carpet_lit *= light_full  # in place (before its coverage weighting)
    for win in felt:
        win.shade *= light_full[win.rows, win.cols]
        win.shade *= win.coverage
    flecks, fleck_scale = _value_noise_unscaled(rng, shape, pile_px * 0.7, out=light_full)
    del light_full
    tint, tint_scale = _value_noise_unscaled(rng, shape, 2.0 * slow_px)

    # Colour: carpet_rgb·(1 + flecks·w) on the carpet, felt_rgb·(1 + tint·u) on the felt, that is
    # a 3×4 colour matrix applied to four planes (carpet, carpet·flecks, felt, felt·tint), see
    # ``_rgb``. Outside the felt windows the felt's planes are 0 and are left out.
    carpet_rgb = np.array(appearance.carpet_rgb, dtype=np.float64)
    felt_rgb = np.array(appearance.felt_rgb, dtype=np.float64)
    # Heathered yarn: fibres vary from redder to duller; felt dye varies in saturation.
    fleck_dir = np.array([1.0, 0.55, 0.2])
    tint_dir = (felt_rgb - felt_rgb.mean()) / max(
        float(np.abs(felt_rgb - felt_rgb.mean()).max()), 1.0
    )
    colour = np.column_stack(
        [
            carpet_rgb,
            carpet_rgb * appearance.carpet_fleck_strength * fleck_dir,
            felt_rgb,
            felt_rgb * appearance.felt_tint_variation * (0.5 + tint_dir),
        ]
    ).astype(np.float32)
    rgba = np.empty((h, w, 4), dtype=np.uint8)
    # The carpet's colour everywhere (the felt's planes left out: they are 0 outside the felt
    # windows), in bands of rows so the temporaries stay in cache; then each felt window's.
    no_felt = np.zeros((_CHUNK_ROWS, w), dtype=np.uint8)
    for r0 in range(0, h, _CHUNK_ROWS):
        r1 = min(r0 + _CHUNK_ROWS, h)
        cl = carpet_lit[r0:r1]
        rgb = _rgb([cl, cl * (flecks[r0:r1] * fleck_scale)], colour)
        rgba[r0:r1] = cv2.merge([*rgb, no_felt[: r1 - r0]])
    for win in felt:
        cl = carpet_lit[win.rows, win.cols]
        cl = cl - cl * win.coverage
        fl = win.shade
        planes = [
            cl,
            cl * (flecks[win.rows, win.cols] * fleck_scale),
            fl,
            fl * (tint[win.rows, win.cols] * tint_scale),
        ]
        alpha = cv2.convertScaleAbs(win.coverage, alpha=255.0)
        rgba[win.rows, win.cols] = cv2.merge([*_rgb(planes, colour), alpha])
    return GroundTexture(
        rgba=rgba,
        origin_xy=(float(origin[0]), float(origin[1])),
        metres_per_px=float(mpp),
        illumination=light,
        illumination_m_per_px=float(light_step),
        shadows=shadows,
        margin_m=float(appearance.margin_m),
    )
