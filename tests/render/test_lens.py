"""Lens models as rendered: the remap renderer, a lens in a preset file, the wide preset.

The lens geometry alone is tested in tests/core/test_camera_model.py.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.core.camera_model import CameraConfig, CameraModel
from lfd_track.envs.presets import load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.errors import FileFormatError
from lfd_track.render.camera import CameraRenderer, SensorConfig
from lfd_track.render.texture import AppearanceConfig, LightingConfig, build_ground
from lfd_track.world.track import load_track

QUIET = SensorConfig(noise_std=0.0, white_balance_cast=0.0, white_balance_jitter=0.0)


@pytest.fixture(scope="module")
def wide():
    return load_preset("wide").camera


def grid_pixels(step: int = 24) -> np.ndarray:
    us, vs = np.meshgrid(np.arange(4, 640, step), np.arange(4, 480, step))
    return np.column_stack([us.ravel(), vs.ravel()]).astype(float)


def test_bad_lens_in_a_preset_is_one_line_naming_the_file(tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text('[camera]\nlens = "fisheye"\nvfov_deg = 76.0\npitch_deg = 30.0\n')
    with pytest.raises(FileFormatError) as err:
        load_preset(path)
    message = str(err.value)
    assert "bad.toml" in message and "horizon" in message and "\n" not in message


# ---- the wide preset -------------------------------------------------------------------------
def test_wide_preset_is_a_wide_lens_on_the_paper_mount(wide):
    paper = load_preset("paper").camera
    cam = CameraModel(wide)
    assert wide.lens == "fisheye" and any(wide.distortion)
    assert cam.hfov_deg >= 100.0
    assert (wide.height_m, wide.forward_offset_m) == (paper.height_m, paper.forward_offset_m)
    assert (wide.width_px, wide.height_px) == (640, 480)
    # The horizon stays out of view: every pixel looks below it and meets the floor.
    rays = cam.rays_rover(cam.edge_pixels(64))
    assert rays[:, 2].max() < -math.sin(math.radians(0.5))
    floor = cam.floor_map_rover()
    assert np.isfinite(floor).all()
    # The top row sees about as far as the paper's (1.84 m); the safe box lies ahead of the
    # rover's pivot centre near its front edge, not under the phone.
    top = cam.floor_points(np.array([[319.5, -0.5]]), np.zeros(3))[0, 0]
    assert 1.5 < top < 2.5
    box = cam.safe_box_floor_polygon(np.zeros(3))
    assert box.shape == (16, 2)
    assert 0.10 < box[:, 0].min() and box[:, 0].max() < 0.2
    assert np.abs(box[:, 1]).max() < 0.03


def test_paper_preset_keeps_the_homography_path():
    cam = CameraModel(load_preset("paper").camera)
    assert cam.is_homography
    assert cam.footprint(np.zeros(3)).shape == (4, 2)
    assert cam.safe_box_floor_polygon(np.zeros(3)).shape == (4, 2)
    assert CameraRenderer(load_preset("paper").camera)._floor_map is None


def test_remap_renderer_matches_the_homography_for_an_ideal_pinhole(ground):
    """The lens path (floor map + cv2.remap) reproduces the warpPerspective view of a pinhole."""
    pose = np.array([1.3, 0.04, 0.25])
    frames = []
    for force_remap in (False, True):
        renderer = CameraRenderer(CameraConfig(), QUIET)
        if force_remap:
            renderer._floor_map = renderer.model.floor_map_rover()
        rng = np.random.default_rng(3)
        renderer.reset(rng)
        frames.append(renderer.render(ground, pose, rng).astype(int))
    diff = np.abs(frames[0] - frames[1])
    assert diff.mean() < 0.5 and np.percentile(diff, 99) <= 3


def test_wide_frame_felt_coverage_matches_the_lens_geometry(track, ground, wide):
    renderer = CameraRenderer(wide, QUIET)
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    pose = np.array([2.6, 0.05, 0.3])
    frame = renderer.render(ground, pose, rng)
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    cover = renderer.last_felt_coverage
    pixels = grid_pixels()
    on = track.on_felt(CameraModel(wide).floor_points(pixels, pose))
    seen = cover[pixels[:, 1].astype(int), pixels[:, 0].astype(int)] >= 128
    assert 0.1 < on.mean() < 0.9
    assert (seen == on).mean() > 0.97


def test_wide_render_is_deterministic_and_never_mirrors_felt(track, ground, wide):
    def frame(pose, seed):
        renderer = CameraRenderer(wide)
        rng = np.random.default_rng(seed)
        renderer.reset(rng)
        return renderer, renderer.render(ground, pose, rng)

    pose = np.array([1.5, 0.0, 0.4])
    assert np.array_equal(frame(pose, 5)[1], frame(pose, 5)[1])
    # Looking away from the track from its outer edge: the view reaches past the texture.
    away = np.array([1.5, -0.12, -math.pi / 2])
    cam = CameraModel(wide)
    assert not track.on_felt(cam.floor_points(grid_pixels(20), away)).any()
    renderer, _ = frame(away, 0)
    assert renderer.last_felt_coverage.max() == 0


# ---- the env follows the lens ------------------------------------------------------------------
def test_safe_box_on_felt_follows_the_lens():
    """Turned 60° off a straight, the paper's box (0.26–0.29 m ahead) leaves the 0.30 m strip;
    the wide lens's box (0.12–0.15 m ahead) is still on it — the env must use the lens's box."""
    pose = (1.5, 0.0, math.radians(60.0))
    answers = {}
    for name in ("paper", "wide"):
        env = LfDTrackEnv(track="testing", preset=name)
        _, info = env.reset(seed=0, options={"pose": pose})
        box = CameraModel(load_preset(name).camera).safe_box_floor_polygon(env.rover_pose)
        assert info["safe_box_on_felt"] == bool(env.track.on_felt(box).all())
        answers[name] = info["safe_box_on_felt"]
        assert env.camera_footprint(env.rover_pose).shape[0] == (4 if name == "paper" else 96)
        with pytest.warns(UserWarning, match="no render_mode"):
            assert env.render() is None  # no render mode: nothing drawn, and the user is told
    assert answers == {"paper": False, "wide": True}


def test_wide_side_regions_see_the_strip_a_sharp_corner_leads_into(track):
    """0.8 m before corner 4 (135° left), coming down the diagonal, the strip after the corner lies
    30–60° to the left: the paper's 53° view catches a corner of it, the wide view's left regions
    show much more of it."""
    d = 0.8 / math.sqrt(2.0)
    pose = np.array([d, d, math.radians(225.0)])
    diagonal = load_track("testing")  # strips: 4→1 (y = 0), ..., 3→4 (the diagonal)
    outgoing = diagonal.strip_polygons()[0]
    x_lo, x_hi = outgoing[:, 0].min(), outgoing[:, 0].max()
    pixels = grid_pixels(8)
    seen = {}
    for name in ("paper", "wide"):
        floor = CameraModel(load_preset(name).camera).floor_points(pixels, pose)
        on_outgoing = (
            (np.abs(floor[:, 1]) <= diagonal.width_m / 2)
            & (floor[:, 0] >= x_lo)
            & (floor[:, 0] <= x_hi)
            & (floor[:, 0] > 0.45)  # past where the two strips overlap
        )
        seen[name] = pixels[on_outgoing]
    assert len(seen["paper"]) < 30
    assert len(seen["wide"]) > 5 * max(len(seen["paper"]), 1) and len(seen["wide"]) > 100
    left_regions = seen["wide"][:, 0] < 160  # the two leftmost region columns
    assert left_regions.all()
    # ...and the rendered wide frame shows felt there.
    renderer = CameraRenderer(load_preset("wide").camera, QUIET)
    ground = build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(1))
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    renderer.render(ground, pose, rng)
    cover = renderer.last_felt_coverage
    px = seen["wide"].astype(int)
    assert (cover[px[:, 1], px[:, 0]] >= 128).mean() > 0.95


def test_lens_footprint_moves_rigidly_with_the_pose(wide):
    cam = CameraModel(wide)
    for pose in (np.array([0.3, -1.2, 2.5]), np.array([-2.0, 0.7, -0.4])):
        direct = cam.floor_points(cam.edge_pixels(24), pose)
        np.testing.assert_allclose(cam.footprint(pose), direct, atol=1e-9)
