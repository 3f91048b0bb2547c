"""The procedural floor: felt and carpet, lighting, determinism, size."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.core.config import dataclass_from_table
from lfd_track.errors import FileFormatError
from lfd_track.render.texture import (
    MAX_TEXTURE_BYTES,
    AppearanceConfig,
    LightingConfig,
    build_ground,
)
from lfd_track.world.track import load_track


@pytest.fixture(scope="module")
def ground(track):
    return build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(11))


def test_same_seed_same_bytes_other_seed_other_texture():
    track = load_track("training")
    a = build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(1))
    b = build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(1))
    c = build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(2))
    assert np.array_equal(a.rgba, b.rgba)
    assert a.shadows == b.shadows
    assert a.rgba.shape == c.rgba.shape
    assert np.mean(a.rgba != c.rgba) > 0.5
    assert a.shadows != c.shadows


def test_texture_fits_the_budget_and_resolution(track, ground):
    assert ground.metres_per_px <= 0.002
    assert ground.nbytes <= MAX_TEXTURE_BYTES
    assert ground.rgba.dtype == np.uint8 and ground.rgba.shape[2] == 4
    assert ground.image.shape == (*ground.shape, 3)
    # The margin: at least 1.5 m of carpet around the felt.
    xmin, ymin, xmax, ymax = track.bounds()
    h, w = ground.shape
    corners = ground.to_texture(np.array([[xmin - 1.5, ymax + 1.5], [xmax + 1.5, ymin - 1.5]]))
    assert corners.min() >= -0.5 and corners[1, 0] <= w - 0.5 and corners[1, 1] <= h - 0.5


def test_config_rejects_coarse_textures_and_bad_colours():
    with pytest.raises(ValueError, match="metres_per_px"):
        AppearanceConfig(metres_per_px=0.003)
    with pytest.raises(ValueError, match="felt_rgb"):
        AppearanceConfig(felt_rgb=(300, 0, 0))
    with pytest.raises(ValueError, match="shadow_count"):
        LightingConfig(shadow_count=0)


def test_configs_load_from_toml_tables():
    app = dataclass_from_table(
        AppearanceConfig, {"felt_rgb": [100, 160, 220], "margin_m": 2}, "appearance", "x.toml"
    )
    assert app.felt_rgb == (100, 160, 220) and app.margin_m == 2.0
    light = dataclass_from_table(LightingConfig, {"shadow_count": 2}, "lighting", "x.toml")
    assert light.shadow_count == 2
    with pytest.raises(FileFormatError, match="x.toml: \\[appearance\\] metres_per_px"):
        dataclass_from_table(AppearanceConfig, {"metres_per_px": 0.01}, "appearance", "x.toml")


def test_felt_mask_matches_the_track_geometry(track, ground):
    rng = np.random.default_rng(0)
    xmin, ymin, xmax, ymax = track.bounds(0.3)
    pts = rng.uniform([xmin, ymin], [xmax, ymax], size=(4000, 2))
    on = track.on_felt(pts)
    # Ignore points within 1 cm of an edge, where the felt frays.
    near_edge = np.zeros(len(pts), bool)
    for dx, dy in ((0.01, 0), (-0.01, 0), (0, 0.01), (0, -0.01)):
        near_edge |= track.on_felt(pts + [dx, dy]) != on
    col, row = np.rint(ground.to_texture(pts)).astype(int).T
    mask = ground.felt_mask[row, col]
    keep = ~near_edge
    assert on[keep].sum() > 300
    assert np.array_equal(mask[keep], on[keep])


def test_felt_is_light_blue_and_carpet_dark_brown(ground):
    img = ground.image[::3, ::3].reshape(-1, 3).astype(float)
    felt = ground.felt_mask[::3, ::3].ravel()
    felt_rgb, carpet_rgb = img[felt].mean(axis=0), img[~felt].mean(axis=0)
    assert felt_rgb[2] > felt_rgb[1] > felt_rgb[0] and felt_rgb.mean() > 100
    assert carpet_rgb[0] > carpet_rgb[1] > carpet_rgb[2] and carpet_rgb.mean() < 80
    # Textured, not flat: fibres and loops vary from texel to texel.
    assert img[felt].std(axis=0).min() > 4 and img[~felt].std(axis=0).min() > 4


def test_shadow_band_gives_lit_and_shaded_road(track, ground):
    band = ground.shadows[0]
    assert track.on_felt(np.array(band.point))  # the band crosses the track
    mask = ground.felt_mask
    h, w = ground.shape
    rows, cols = np.nonzero(mask[::4, ::4])
    pts = np.column_stack([cols * 4, rows * 4]).astype(float)
    world = np.column_stack(
        [
            ground.origin_xy[0] + pts[:, 0] * ground.metres_per_px,
            ground.origin_xy[1] - pts[:, 1] * ground.metres_per_px,
        ]
    )
    nx, ny = -math.sin(band.angle_rad), math.cos(band.angle_rad)
    dist = np.abs((world[:, 0] - band.point[0]) * nx + (world[:, 1] - band.point[1]) * ny)
    light = LightingConfig()
    in_core = dist < light.shadow_width_m / 2 - 0.02
    far = dist > light.shadow_width_m / 2 + light.shadow_softness_m + 0.3
    assert in_core.sum() > 100 and far.sum() > 100
    luma = ground.image[rows * 4, cols * 4].astype(float) @ [0.299, 0.587, 0.114]
    shaded, lit = luma[in_core].mean(), luma[far].mean()
    assert shaded < 0.75 * lit
    # Both felt lit and felt shaded are still clearly felt (bluish).
    rgb = ground.image[rows * 4, cols * 4].astype(float)
    assert (rgb[in_core, 2] > rgb[in_core, 0] + 20).mean() > 0.95


def test_illumination_is_smooth_and_bounded(ground):
    light = ground.illumination
    assert light.min() > 0.2 and light.max() <= LightingConfig().max_illumination + 1e-6
    # Smooth: neighbouring 2 cm cells differ little even at the penumbra.
    assert np.abs(np.diff(light, axis=0)).max() < 0.15
    assert np.abs(np.diff(light, axis=1)).max() < 0.15


def test_carpet_has_no_stray_felt_away_from_the_strips(track, ground):
    # Texels 2 cm or more from any strip are pure carpet (no frayed-edge speckles).
    h, w = ground.shape
    rows, cols = np.mgrid[0:h:3, 0:w:3]
    world = np.column_stack(
        [
            ground.origin_xy[0] + cols.ravel() * ground.metres_per_px,
            ground.origin_xy[1] - rows.ravel() * ground.metres_per_px,
        ]
    )
    near = np.zeros(len(world), bool)
    for dx, dy in ((0.02, 0), (-0.02, 0), (0, 0.02), (0, -0.02), (0, 0)):
        near |= track.on_felt(world + [dx, dy])
    cover = ground.rgba[rows.ravel(), cols.ravel(), 3]
    assert cover[~near].max() == 0
    assert (ground.carpet_band[..., 3] == 0).all()
