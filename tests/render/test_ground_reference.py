"""The floor painted in felt windows is byte for byte the floor painted over the whole texture.

``build_ground`` computes the felt's fields only in windows around the strips and the colours with
per-plane multiply-adds; ``_reference_ground`` below is the straightforward whole-floor version
(every field over the whole texture, the colours with one ``cv2.transform``) that defined the
floor's bytes. Both run here on the same machine, so the comparison is exact whatever the CPU.
"""

from __future__ import annotations

import dataclasses
import math

import cv2
import numpy as np
import pytest

from lfd_track.render.texture import (
    AppearanceConfig,
    LightingConfig,
    _illumination,
    _shadow_bands,
    _value_noise,
    build_ground,
)
from lfd_track.world.track import Track, load_track


def _reference_ground(
    track: Track, appearance: AppearanceConfig, lighting: LightingConfig, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """(rgba, coarse illumination) of the floor, every field computed over the whole texture."""
    mpp = appearance.metres_per_px
    xmin, ymin, xmax, ymax = track.bounds(appearance.margin_m)
    w = int(math.ceil((xmax - xmin) / mpp)) + 1
    h = int(math.ceil((ymax - ymin) / mpp)) + 1
    origin = (xmin, ymax)
    shape = (h, w)
    fine = rng.standard_normal(shape, dtype=np.float32)
    mask = np.zeros(shape, dtype=np.uint8)
    for poly in track.strip_polygons():
        col = (poly[:, 0] - origin[0]) / mpp
        row = (origin[1] - poly[:, 1]) / mpp
        pts = np.rint(np.stack([col, row], axis=1) * 16).astype(np.int32)
        cv2.fillPoly(mask, [pts], 255, lineType=cv2.LINE_8, shift=4)
    coverage = mask.astype(np.float32)
    coverage *= np.float32(1.0 / 255.0)
    fuzz_px = appearance.edge_fuzz_m / mpp
    if fuzz_px > 0.25:
        coverage = cv2.GaussianBlur(coverage, (0, 0), sigmaX=fuzz_px)
        fray = cv2.GaussianBlur(fine, (0, 0), sigmaX=1.0)
        fray *= 4.0 * coverage * (1.0 - coverage)
        coverage = cv2.addWeighted(coverage, 2.5, fray, 1.1, -0.75)
        np.clip(coverage, 0.0, 1.0, out=coverage)
    pile_px = appearance.carpet_pile_scale_m / mpp
    k_pile = appearance.carpet_pile_strength
    carpet = cv2.addWeighted(
        _value_noise(rng, shape, pile_px), 0.75 * k_pile, fine, 0.45 * k_pile, 1.0
    )
    carpet = cv2.addWeighted(
        carpet, 1.0, _value_noise(rng, shape, 0.25 / mpp), appearance.carpet_patchiness, 0.0
    )
    fibre_px = max(int(round(appearance.felt_fibre_length_m / mpp)), 1)
    streaks = np.maximum(
        cv2.blur(fine, (fibre_px, 1)), cv2.blur(np.ascontiguousarray(fine[::-1]), (1, fibre_px))
    )
    k_fibre = appearance.felt_fibre_strength
    felt = cv2.addWeighted(
        streaks,
        0.6 * k_fibre * math.sqrt(fibre_px),
        cv2.GaussianBlur(fine, (0, 0), 0.7),
        0.5 * k_fibre,
        1.0,
    )
    slow_px = appearance.felt_nonuniformity_scale_m / mpp
    felt = cv2.addWeighted(
        felt, 1.0, _value_noise(rng, shape, slow_px), appearance.felt_nonuniformity, 0.0
    )
    bands = _shadow_bands(track, lighting, rng)
    light, step = _illumination(track, lighting, bands, origin, ((w - 1) * mpp, (h - 1) * mpp), rng)
    scale = mpp / step
    light_full = cv2.warpAffine(
        light,
        np.array([[scale, 0.0, 0.0], [0.0, scale, 0.0]]),
        (w, h),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REPLICATE,
    )
    carpet *= light_full
    felt *= light_full
    felt *= coverage
    carpet -= carpet * coverage
    flecks = _value_noise(rng, shape, pile_px * 0.7)
    tint = _value_noise(rng, shape, 2.0 * slow_px)
    carpet_rgb = np.array(appearance.carpet_rgb, dtype=np.float64)
    felt_rgb = np.array(appearance.felt_rgb, dtype=np.float64)
    tint_dir = (felt_rgb - felt_rgb.mean()) / max(
        float(np.abs(felt_rgb - felt_rgb.mean()).max()), 1.0
    )
    colour = np.column_stack(
        [
            carpet_rgb,
            carpet_rgb * appearance.carpet_fleck_strength * np.array([1.0, 0.55, 0.2]),
            felt_rgb,
            felt_rgb * appearance.felt_tint_variation * (0.5 + tint_dir),
        ]
    ).astype(np.float32)
    planes = cv2.merge([carpet, carpet * flecks, felt, felt * tint])
    rgba = np.empty((h, w, 4), dtype=np.uint8)
    rgba[..., :3] = cv2.convertScaleAbs(cv2.transform(planes, colour))
    rgba[..., 3] = cv2.convertScaleAbs(coverage, alpha=255.0)
    return rgba, light


# Small floors (the least margin) keep the test fast; each case exercises another path: straight
# strips, a procedural loop's slanted ones, no fuzzy edge, a wide fuzz with other fibre lengths.
CASES = {
    "training": ("training", {}),
    "loop": ("random:test:3", {}),
    "sharp edge": ("testing", {"edge_fuzz_m": 0.0, "felt_fibre_length_m": 0.005}),
    "wide fuzz": ("random:train:1", {"edge_fuzz_m": 0.012, "carpet_pile_scale_m": 0.007}),
}


@pytest.mark.parametrize("case", list(CASES))
def test_windowed_floor_matches_whole_floor_reference(case):
    name, changes = CASES[case]
    track = load_track(name)
    appearance = dataclasses.replace(AppearanceConfig(margin_m=0.5), **changes)
    lighting = LightingConfig(shadow_count=2)
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    ground = build_ground(track, appearance, lighting, rng_a)
    rgba, light = _reference_ground(track, appearance, lighting, rng_b)
    assert ground.rgba.shape == rgba.shape
    # Byte-equal on the machines measured; the colour pass is a different OpenCV kernel from the
    # reference's (scaleAdd, not transform), so on another CPU a texel may round the other way:
    # allowed at most one level, on at most 1 texel in 10,000.
    diff = np.abs(ground.rgba.astype(np.int16) - rgba.astype(np.int16))
    assert int(diff.max()) <= 1, f"a texel differs by {int(diff.max())} levels"
    mismatched = int(np.count_nonzero(diff))
    assert mismatched <= rgba.size // 10_000, f"{mismatched} bytes differ from the reference"
    assert np.array_equal(ground.illumination, light)
    assert rng_a.integers(1 << 30) == rng_b.integers(1 << 30)  # the same draws, in order
