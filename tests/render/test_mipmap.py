"""The ``"mipmap"`` texture filter: pre-filtered ground levels picked per band of image rows."""

from __future__ import annotations

import dataclasses

import cv2
import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.core.camera_model import CameraConfig, CameraModel
from lfd_track.envs.presets import load_preset
from lfd_track.render.camera import CameraRenderer, mip_bands
from lfd_track.render.texture import GroundTexture

MPP = 0.002
MIPMAP = CameraConfig(texture_filter="mipmap")
BILINEAR = CameraConfig(texture_filter="bilinear")


def synthetic_ground(rgba: np.ndarray, x0: float = -0.5, y0: float = 1.5) -> GroundTexture:
    """A ground texture whose texel (0, 0) lies at world (x0, y0)."""
    return GroundTexture(
        rgba=rgba,
        origin_xy=(x0, y0),
        metres_per_px=MPP,
        illumination=np.ones((2, 2), np.float32),
        illumination_m_per_px=1.0,
        shadows=(),
        margin_m=1.5,
    )


def floor_x_of_rows(model: CameraModel) -> np.ndarray:
    rows = np.arange(model.config.height_px, dtype=float)
    px = np.column_stack([np.full_like(rows, model.cx), rows])
    return model.floor_points(px, np.zeros(3))[:, 0]


def test_config_refuses_an_unknown_filter():
    with pytest.raises(ValueError, match="texture_filter must be one of bilinear, mipmap"):
        CameraConfig(texture_filter="trilinear")


def test_bands_cover_the_frame_and_coarsen_towards_the_top():
    renderer = CameraRenderer(MIPMAP)
    bands = renderer.mip_bands(MPP)
    assert bands[0][0] == 0 and bands[-1][1] == 480
    assert all(a[1] == b[0] for a, b in zip(bands, bands[1:], strict=False))
    levels = [lv for _, _, lv in bands]
    assert levels == sorted(levels, reverse=True)  # the footprint grows towards the top
    assert levels[-1] == 0 and levels[0] == 2  # paper camera on the 2 mm texture
    # The top row's pixel covers about 10.5 texels (level 2: 16), the bottom row's about 0.1.
    area = CameraModel(MIPMAP).row_footprint_area_m2() / MPP**2
    assert area[0] == pytest.approx(10.5, rel=0.05) and area[-1] == pytest.approx(0.105, rel=0.05)
    assert CameraRenderer(BILINEAR).mip_bands(MPP) == ((0, 480, 0),)


def test_mip_bands_rounds_half_log2_of_the_area():
    area = np.array([64.0, 20.0, 7.9, 2.1, 1.9, 0.1]) * MPP**2
    assert mip_bands(area, MPP) == ((0, 1, 3), (1, 2, 2), (2, 4, 1), (4, 6, 0))


@pytest.mark.parametrize("distance_m", [0.26, 0.5, 1.0, 1.5, 1.83])
def test_mipmap_keeps_the_camera_geometry(distance_m):
    """A step from dark to bright floor at ``distance_m`` ahead lands on the same image row in
    both filters (within one row), and on the row the lens geometry puts it: the levels' texel
    coordinates are level 0's halved L times, exactly. The frame still spans 0.256–1.85 m."""
    h, w = int(3.0 / MPP), int(3.0 / MPP)
    rgba = np.zeros((h, w, 4), np.uint8)
    col = int(round((distance_m + 0.5) / MPP))
    rgba[:, col:] = 255
    ground = synthetic_ground(rgba)
    model = CameraModel(MIPMAP)
    xs = floor_x_of_rows(model)
    expected = int(np.argmin(np.abs(xs - (-0.5 + (col - 0.5) * MPP))))
    for config in (BILINEAR, MIPMAP):
        raw = CameraRenderer(config)._warp_pinhole(ground, np.zeros(3))
        profile = raw[:, 320, 0].astype(float)
        row = int(np.argmin(np.abs(profile - 127.5)))
        assert abs(row - expected) <= 1, (config.texture_filter, row, expected)
    corners = model.footprint(np.zeros(3))
    assert corners[0, 0] == pytest.approx(1.85, abs=0.03)  # top row
    assert corners[3, 0] == pytest.approx(0.256, abs=0.01)  # bottom row


def test_mipmap_is_closer_than_bilinear_to_what_a_pixel_averages():
    """On fine texture (texel-sized noise) a pixel's value is the average over its floor
    footprint; the reference is a 4 × 4 supersampled render averaged down. Near the top of the
    frame, where a pixel covers ~10 texels, bilinear lookup aliases (the pixel shows a single
    texel's noise) and the mip levels follow the reference far more closely; near the bottom,
    where a pixel covers less than a texel, both agree with it."""
    rng = np.random.default_rng(3)
    h, w = int(3.0 / MPP), int(3.0 / MPP)
    rgba = np.full((h, w, 4), 255, np.uint8)
    rgba[..., :3] = rng.integers(40, 216, size=(h, w, 1), dtype=np.uint8)
    ground = synthetic_ground(rgba)
    pose = np.array([0.0, 0.0, 0.3])
    big = dataclasses.replace(BILINEAR, width_px=2560, height_px=1920)
    reference = cv2.resize(
        CameraRenderer(big)._warp_pinhole(ground, pose)[..., 0].astype(np.float32),
        (640, 480),
        interpolation=cv2.INTER_AREA,
    )
    errors = {}
    for config in (BILINEAR, MIPMAP):
        frame = CameraRenderer(config)._warp_pinhole(ground, pose)[..., 0].astype(np.float32)
        diff = frame - reference
        errors[config.texture_filter] = (diff[:60].std(), diff[-60:].std())
    top_bilinear, bottom_bilinear = errors["bilinear"]
    top_mipmap, bottom_mipmap = errors["mipmap"]
    assert top_mipmap < 0.5 * top_bilinear
    assert bottom_mipmap == pytest.approx(bottom_bilinear, rel=0.05)


def test_mip_levels_are_pyramids_of_the_texture():
    rgba = np.random.default_rng(0).integers(0, 256, size=(101, 67, 4), dtype=np.uint8)
    ground = synthetic_ground(rgba)
    assert ground.mip_level(0) is ground.rgba
    one = ground.mip_level(1)
    assert one.shape == (51, 34, 4)
    np.testing.assert_array_equal(one, cv2.pyrDown(rgba, borderType=cv2.BORDER_REFLECT_101))
    assert ground.mip_level(2).shape == (26, 17, 4) and ground.mip_level(1) is one


def test_two_mipmap_envs_with_one_seed_render_the_same_bytes():
    paper = load_preset("paper")
    preset = dataclasses.replace(
        paper, camera=dataclasses.replace(paper.camera, texture_filter="mipmap")
    )
    envs = [gym.make("LfDTrack-v0", preset=preset) for _ in range(2)]
    frames = [[env.reset(seed=11)[0].tobytes()] for env in envs]
    actions = np.random.default_rng(0).integers(3, size=25)
    for env, seen in zip(envs, frames, strict=True):
        for a in actions:
            obs, _, terminated, truncated, _ = env.step(int(a))
            seen.append(obs.tobytes())
            if terminated or truncated:
                seen.append(env.reset()[0].tobytes())
        env.close()
    assert frames[0] == frames[1]
    bilinear = gym.make("LfDTrack-v0", preset="paper_bilinear")
    assert bilinear.reset(seed=11)[0].tobytes() != frames[0][0]  # the filter does change frames
    bilinear.close()


def test_a_distorted_lens_is_banded_too_and_its_level_0_rows_are_unchanged():
    wide = load_preset("wide").camera
    rng = np.random.default_rng(5)
    rgba = rng.integers(0, 256, size=(int(3.0 / MPP), int(3.0 / MPP), 4), dtype=np.uint8)
    ground = synthetic_ground(rgba)
    pose = np.array([0.0, 0.0, 0.2])
    mip = CameraRenderer(wide)  # the default filter, "mipmap"
    assert wide.texture_filter == "mipmap"
    bands = mip.mip_bands(MPP)
    assert len(bands) > 1 and bands[-1][2] == 0 and bands[0][2] > 0
    plain = CameraRenderer(dataclasses.replace(wide, texture_filter="bilinear"))._remap_lens(
        ground, pose
    )
    banded = mip._remap_lens(ground, pose)
    first_level_0 = bands[-1][0]
    np.testing.assert_array_equal(banded[first_level_0:], plain[first_level_0:])
    # Coarser rows show the same floor, low-passed: their mean level barely moves.
    top = slice(0, bands[0][1])
    assert abs(float(banded[top].mean()) - float(plain[top].mean())) < 2.0
    assert banded[top].std() < plain[top].std()
