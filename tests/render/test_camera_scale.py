"""A camera with ``scale``: smaller frames of the same view (preset ``paper_fast``)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lfd_track.core.camera_model import CameraConfig, CameraModel
from lfd_track.core.frame import region_bounds, safe_box, safe_box_slices
from lfd_track.envs.presets import load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.errors import FileFormatError
from lfd_track.render.camera import CameraRenderer, SensorConfig

HALF = CameraConfig(scale=0.5)
POSE = np.array([1.0, 2.0, 0.3])


def test_half_camera_takes_320_by_240_frames_from_the_paper_fast_preset():
    preset = load_preset("paper_fast")
    paper = load_preset("paper")
    assert (preset.camera.frame_width_px, preset.camera.frame_height_px) == (320, 240)
    # Every other value is the paper's.
    assert dataclasses.replace(preset.camera, scale=1.0) == paper.camera
    for section in ("rover", "sensor", "appearance", "lighting", "episode"):
        assert getattr(preset, section) == getattr(paper, section), section
    env = LfDTrackEnv(track="testing", preset="paper_fast")
    obs, info = env.reset(seed=0)
    assert obs.shape == (240, 320, 3) and env.observation_space.shape == (240, 320, 3)
    obs, *_ = env.step(0)
    assert obs.shape == (240, 320, 3) and obs.dtype == np.uint8


def test_round_29s_quarter_camera_is_the_paper_world_at_160_by_120():
    # benchmarks/experiments/human_goal/round29/presets/paper_quarter.toml: paper_fast's scaling
    # one step further, every other value the paper's.
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    quarter = load_preset(
        str(root / "benchmarks/experiments/human_goal/round29/presets/paper_quarter.toml")
    )
    paper = load_preset("paper")
    assert (quarter.camera.frame_width_px, quarter.camera.frame_height_px) == (160, 120)
    assert dataclasses.replace(quarter.camera, scale=1.0) == paper.camera
    for section in ("rover", "sensor", "appearance", "lighting", "episode"):
        assert getattr(quarter, section) == getattr(paper, section), section


def test_same_view_image_centre_and_corners_see_the_same_floor_points():
    full, half = CameraModel(), CameraModel(HALF)
    assert half.focal_px == pytest.approx(full.focal_px / 2)
    assert half.hfov_deg == pytest.approx(full.hfov_deg)
    # Pixel edges and the centre: full-frame u maps to (u + 0.5) / 2 - 0.5 at half size.
    full_px = np.array([[319.5, 239.5], [-0.5, -0.5], [639.5, -0.5], [639.5, 479.5], [-0.5, 479.5]])
    half_px = (full_px + 0.5) / 2 - 0.5
    a = full.floor_points(full_px, POSE)
    b = half.floor_points(half_px, POSE)
    np.testing.assert_allclose(a, b, atol=1e-9)  # the same rays: exact up to rounding
    np.testing.assert_allclose(full.footprint(POSE), half.footprint(POSE), atol=1e-9)


def test_same_view_through_the_wide_lens_too():
    wide = load_preset("wide").camera
    full, half = CameraModel(wide), CameraModel(dataclasses.replace(wide, scale=0.5))
    full_px = np.array([[319.5, 239.5], [-0.5, -0.5], [639.5, 479.5], [100.0, 400.0]])
    half_px = (full_px + 0.5) / 2 - 0.5
    # A lens is inverted through a table: within a millimetre.
    np.testing.assert_allclose(
        full.floor_points(full_px, POSE), half.floor_points(half_px, POSE), atol=1e-3
    )


def test_grid_keeps_8_by_5_regions_and_the_safe_box_its_place_on_the_floor():
    assert region_bounds(0, 320, 240) == (0, 0, 40, 48)
    assert region_bounds(39, 320, 240) == (280, 192, 320, 240)
    assert safe_box() == (295, 430, 50, 50)
    assert safe_box(320, 240) == (147, 215, 25, 25)
    assert safe_box_slices(320, 240) == (slice(215, 240), slice(147, 172))
    full = CameraModel().safe_box_floor_polygon(POSE)
    half = CameraModel(HALF).safe_box_floor_polygon(POSE)
    # The box is one full-size pixel to the left (the half frame's centre falls between two
    # pixels): under 2 mm on the floor at the bottom of the frame.
    assert np.abs(full - half).max() < 0.002


def test_texture_is_sampled_one_mip_level_coarser_for_four_times_the_footprint():
    full, half = CameraRenderer(), CameraRenderer(HALF)
    mpp = load_preset("paper").appearance.metres_per_px
    np.testing.assert_allclose(
        CameraModel(HALF).row_footprint_area_m2()[-1],
        4 * CameraModel().row_footprint_area_m2()[-1],
        rtol=0.02,
    )
    # Level = round(½·log2(footprint in texels)), clamped at 0: the top rows one level coarser.
    bands_full, bands_half = full.mip_bands(mpp), half.mip_bands(mpp)
    assert bands_half[0][2] == bands_full[0][2] + 1
    assert [level for *_, level in bands_half] == sorted(
        {level for *_, level in bands_half}, reverse=True
    )
    assert bands_half[-1][2] == 0


def test_sensor_noise_is_binned_vignetting_keeps_its_shape():
    sensor = SensorConfig(vignetting=0.25)
    full, half = CameraRenderer(sensor=sensor), CameraRenderer(HALF, sensor)
    assert half._noise_std == pytest.approx(sensor.noise_std / 2)
    # The corner darkening is the same at the same place in the picture.
    assert half._vignette[0, 0] == pytest.approx(full._vignette[0, 0])
    assert half._vignette[120, 160] == pytest.approx(full._vignette[240, 320], abs=1e-3)


@pytest.mark.parametrize("scale", [0.33, 0.0, -1.0, float("nan")])
def test_bad_scales_are_refused(scale):
    with pytest.raises(ValueError, match="scale"):
        CameraConfig(scale=scale)


def test_preset_refuses_a_scale_the_grid_does_not_divide_and_randomizing_it(tmp_path):
    odd = tmp_path / "odd.toml"
    odd.write_text("[camera]\nscale = 0.125\n")  # 80 x 60: 10 x 12 regions, fine
    assert load_preset(odd).camera.frame_width_px == 80
    odd.write_text("[camera]\nscale = 0.15\n")  # 96 x 72: 72 is no multiple of 5
    with pytest.raises(FileFormatError, match="does not divide"):
        load_preset(odd)
    odd.write_text('[randomization]\n"camera.scale" = [0.5, 1.0]\n')
    with pytest.raises(FileFormatError, match="cannot draw camera.scale"):
        load_preset(odd)
