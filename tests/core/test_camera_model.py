"""The camera's geometry: lens models, projections and rays, apart from the renderer."""

from __future__ import annotations

import math
import subprocess
import sys

import numpy as np
import pytest

from lfd_track.core.camera_model import CameraConfig, CameraModel


def grid_pixels(step: int = 24) -> np.ndarray:
    us, vs = np.meshgrid(np.arange(4, 640, step), np.arange(4, 480, step))
    return np.column_stack([us.ravel(), vs.ravel()]).astype(float)


def test_equidistant_fisheye_maps_angle_linearly_to_radius():
    cam = CameraModel(CameraConfig(lens="fisheye", vfov_deg=60.0, pitch_deg=60.0))
    assert not cam.is_homography
    f = 240.0 / math.radians(30.0)  # r = f·θ with the top/bottom edges at ±30°
    assert cam.focal_px == pytest.approx(f)
    axis = np.array([math.cos(math.radians(60.0)), 0.0, -math.sin(math.radians(60.0))])  # rover
    for u, v in [(319.5 + 200.0, 239.5), (319.5, 239.5 - 150.0), (319.5 - 120.0, 239.5 + 160.0)]:
        ray = cam.rays_rover(np.array([[u, v]]))[0]
        theta = math.acos(float(ray @ axis))
        assert theta == pytest.approx(math.hypot(u - 319.5, v - 239.5) / f, abs=1e-6)
    # Equidistant: the horizontal field is 4/3 of the vertical one.
    assert cam.hfov_deg == pytest.approx(80.0, abs=0.01)


@pytest.mark.parametrize(
    "config",
    [
        CameraConfig(lens="fisheye", distortion=(0.2, 0.0, 0.0, 0.0), vfov_deg=79.8,
                     principal_shift_px=329.0, pitch_deg=-7.0),
        CameraConfig(lens="pinhole", distortion=(-0.15, 0.02, 0.0, 0.0), vfov_deg=50.0,
                     pitch_deg=35.0),
        CameraConfig(pitch_deg=20.0, principal_shift_px=120.0),  # shifted ideal pinhole
    ],
)  # fmt: skip
def test_project_inverts_floor_points(config):
    cam = CameraModel(config)
    pose = np.array([1.2, -0.4, 0.7])
    pixels = grid_pixels(40)
    floor = cam.floor_points(pixels, pose)
    assert np.isfinite(floor).all()
    np.testing.assert_allclose(cam.project(floor, pose), pixels, atol=1e-3)


def test_distortion_bends_straight_floor_lines():
    """A fisheye shows a straight strip edge as a curve; the ideal pinhole keeps it straight."""
    pose = np.zeros(3)
    line = np.column_stack([np.full(9, 0.6), np.linspace(-0.4, 0.4, 9)])  # across, 0.6 m ahead
    for config, straight in [
        (CameraConfig(), True),
        (CameraConfig(lens="fisheye", vfov_deg=60.0, pitch_deg=45.0), False),
    ]:
        uv = CameraModel(config).project(line, pose)
        bow = np.abs(uv[:, 1] - uv[0, 1]).max()
        assert (bow < 1e-6) == straight


def test_lens_problems_are_rejected_with_a_reason():
    with pytest.raises(ValueError, match="lens must be one of"):
        CameraConfig(lens="anamorphic")
    with pytest.raises(ValueError, match="horizon"):
        CameraConfig(lens="fisheye", vfov_deg=76.0, pitch_deg=30.0)  # top corners see the sky
    with pytest.raises(ValueError, match="cannot fill the frame"):
        CameraConfig(lens="fisheye", distortion=(-0.5, 0.0, 0.0, 0.0), vfov_deg=80.0,
                     pitch_deg=60.0)  # fmt: skip
    with pytest.raises(ValueError, match="4 finite numbers"):
        CameraConfig(lens="fisheye", distortion=(0.1, math.nan, 0.0, 0.0))
    # The same horizon rule holds for a shifted frame: looking up without the crop shows the sky.
    with pytest.raises(ValueError, match="horizon"):
        CameraConfig(lens="fisheye", distortion=(0.2, 0.0, 0.0, 0.0), vfov_deg=79.8,
                     pitch_deg=-7.0)  # fmt: skip


def test_the_geometry_loads_without_the_renderer():
    """The road-value memory asks what the regions see; that must not load OpenCV or render/."""
    code = (
        "import sys\n"
        "from lfd_track.policy.memory import region_floor_points\n"
        "region_floor_points()\n"
        "print(sorted(m for m in sys.modules if m == 'cv2' or m.startswith('lfd_track.render')))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
