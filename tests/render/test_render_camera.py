"""Camera geometry (paper §4.1) and the rendered frames."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lfd_track.core.camera_model import CameraConfig, CameraModel, safe_box_floor_polygon
from lfd_track.core.frame import safe_box_slices
from lfd_track.render.camera import CameraRenderer, SensorConfig
from lfd_track.render.texture import AppearanceConfig, LightingConfig, build_ground
from lfd_track.world.track import load_track

STRAIGHT = np.array([1.5, 0.0, 0.0])  # centred on the testing track's bottom straight


def render_sequence(ground, poses, seed, sensor=None):
    renderer = CameraRenderer(CameraConfig(), sensor or SensorConfig())
    rng = np.random.default_rng(seed)
    renderer.reset(rng)
    return [renderer.render(ground, np.asarray(p, dtype=float), rng) for p in poses]


# ---- geometry ------------------------------------------------------------------------------
def test_paper_distances_land_on_bottom_and_top_rows():
    cam = CameraModel()
    # The paper: the safe box (bottom edge) 10 in ahead, the view reaching about 6 ft.
    uv = cam.project(np.array([[0.254, 0.0], [1.84, 0.0]]), np.zeros(3))
    assert uv[0, 1] == pytest.approx(479, abs=5)
    assert uv[1, 1] == pytest.approx(0, abs=5)
    assert uv[:, 0] == pytest.approx(319.5)
    bottom, top = cam.floor_points(np.array([[319.5, 479.0], [319.5, 0.0]]), np.zeros(3))
    assert bottom[0] == pytest.approx(0.25, abs=0.01)
    assert top[0] == pytest.approx(1.84, abs=0.03)


def test_horizontal_field_of_view_is_about_53_degrees():
    assert CameraModel().hfov_deg == pytest.approx(53.0, abs=0.5)


def test_left_of_the_rover_is_left_in_the_image_for_any_heading():
    cam = CameraModel()
    for theta in np.linspace(-math.pi, math.pi, 9):
        pose = np.array([0.3, -0.2, theta])
        fwd = np.array([math.cos(theta), math.sin(theta)])
        left = np.array([-fwd[1], fwd[0]])
        ahead = pose[:2] + 1.0 * fwd
        uv = cam.project(np.stack([ahead, ahead + 0.2 * left, ahead + 0.2 * fwd]), pose)
        assert uv[0, 0] == pytest.approx(319.5, abs=1e-6)
        assert uv[1, 0] < uv[0, 0] - 50  # left of the centre column
        assert uv[2, 1] < uv[0, 1] - 20  # further away is higher up


def test_project_and_floor_points_round_trip():
    cam = CameraModel(CameraConfig(forward_offset_m=0.05))
    rng = np.random.default_rng(0)
    pixels = rng.uniform([0, 0], [639, 479], size=(200, 2))
    for pose in ([0.0, 0.0, 0.0], [2.0, -1.0, 2.5], [-0.7, 3.0, -1.2]):
        floor = cam.floor_points(pixels, np.array(pose))
        assert np.isfinite(floor).all()  # the horizon is never in view
        np.testing.assert_allclose(cam.project(floor, np.array(pose)), pixels, atol=1e-6)


def test_points_behind_the_camera_do_not_project():
    uv = CameraModel().project(np.array([[-1.0, 0.0]]), np.zeros(3))
    assert np.isnan(uv).all()


def test_footprint_is_the_trapezoid_ahead():
    fp = CameraModel().footprint(np.array([1.0, 2.0, math.pi / 2]))
    # Heading +y: "ahead" is +y and the image's left is -x... top-left corner is far and left.
    top_left, top_right, bottom_right, bottom_left = fp
    assert top_left[1] - 2.0 == pytest.approx(1.85, abs=0.03)
    assert bottom_left[1] - 2.0 == pytest.approx(0.256, abs=0.01)
    assert top_left[0] < 1.0 < top_right[0]
    assert bottom_left[0] < 1.0 < bottom_right[0]
    assert top_right[0] - top_left[0] > 3 * (bottom_right[0] - bottom_left[0])


def test_homography_agrees_with_project(ground):
    cam = CameraModel()
    pose = np.array([1.2, 0.3, 0.4])
    world = cam.floor_points(np.array([[10.0, 20.0], [600.0, 450.0], [320.0, 100.0]]), pose)
    tex = ground.to_texture(world)
    hom = np.column_stack([tex, np.ones(3)]) @ cam.homography(pose, ground).T
    np.testing.assert_allclose(hom[:, :2] / hom[:, 2:], cam.project(world, pose), atol=1e-6)


def test_config_rejects_a_horizon_in_view():
    with pytest.raises(ValueError, match="horizon"):
        CameraConfig(pitch_deg=15.0)


def test_safe_box_constant_matches_the_design():
    rows, cols = safe_box_slices()
    assert (rows.start, rows.stop, cols.start, cols.stop) == (430, 480, 295, 345)


def test_safe_box_floor_polygon_is_on_the_felt_on_a_straight(track):
    poly = safe_box_floor_polygon(STRAIGHT)
    assert poly.shape == (4, 2)
    assert track.on_felt(poly).all()
    assert poly[:, 0].min() == pytest.approx(1.5 + 0.256, abs=0.01)
    # Turned 90° on the 0.30 m strip, the box (0.26–0.29 m ahead) lies on the carpet beside it.
    assert not track.on_felt(safe_box_floor_polygon(np.array([1.5, 0.0, math.pi / 2]))).any()


# ---- rendering -----------------------------------------------------------------------------
def test_frame_shows_felt_in_the_safe_box_and_carpet_off_the_track(track, ground):
    frame = render_sequence(ground, [STRAIGHT], seed=1)[0]
    assert frame.shape == (480, 640, 3) and frame.dtype == np.uint8
    box = frame[safe_box_slices()].reshape(-1, 3).astype(float).mean(axis=0)
    assert box[2] > box[0] + 40  # bluish: blue well above red

    # Top-right corner region: check first that it really sees carpet only.
    cam = CameraModel()
    us, vs = np.meshgrid(np.arange(580, 640, 5), np.arange(0, 60, 5))
    pixels = np.column_stack([us.ravel(), vs.ravel()]).astype(float)
    assert not track.on_felt(cam.floor_points(pixels, STRAIGHT)).any()
    corner = frame[:60, 580:].reshape(-1, 3).astype(float).mean(axis=0)
    assert corner[0] > corner[2] + 10  # brownish: red above blue


def test_same_seed_same_frames_and_other_seed_other_noise(ground):
    poses = [STRAIGHT, STRAIGHT + [0.1, 0.0, 0.0], STRAIGHT + [0.1, 0.0, 0.3]]
    a = render_sequence(ground, poses, seed=3)
    b = render_sequence(ground, poses, seed=3)
    c = render_sequence(ground, poses, seed=4)
    for fa, fb, fc in zip(a, b, c, strict=True):
        assert np.array_equal(fa, fb)
        assert not np.array_equal(fa, fc)
    # Two frames at the same pose differ only by noise and white-balance jitter.
    again = render_sequence(ground, [STRAIGHT, STRAIGHT], seed=3)
    diff = np.abs(again[0].astype(int) - again[1].astype(int))
    assert 0 < diff.mean() < 10


def test_pose_near_the_texture_edge_looking_outwards_shows_carpet_not_black(track, ground):
    cam = CameraModel()
    pose = np.array([ground.origin_xy[0] + 0.3, ground.origin_xy[1] - 0.3, math.radians(135)])
    us, vs = np.meshgrid(np.arange(0, 640, 16), np.arange(0, 480, 16))
    seen = ground.to_texture(cam.floor_points(np.column_stack([us.ravel(), vs.ravel()]), pose))
    outside = (seen < 0).any(axis=1)
    assert outside.mean() > 0.6  # most of the view lies beyond the texture
    frame = render_sequence(ground, [pose], seed=0)[0]
    assert frame.max(axis=2).min() > 5  # no black void
    mean = frame.reshape(-1, 3).astype(float).mean(axis=0)
    assert mean[0] > mean[2] + 10  # carpet-coloured


def test_auto_exposure_adapts_with_a_lag():
    # The same floor twice, the second under half the light (same seed: same textures).
    track = load_track("training")
    lit, dim = (
        build_ground(
            track,
            AppearanceConfig(),
            LightingConfig(ambient=ambient, pool_count=0, shadow_darkness=0.0),
            np.random.default_rng(5),
        )
        for ambient in (0.9, 0.45)
    )
    pose = np.array([1.5, 0.0, math.pi])
    sensor = SensorConfig(noise_std=0.0, white_balance_jitter=0.0, exposure_lag_frames=2.0)
    renderer = CameraRenderer(CameraConfig(), sensor)
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    lit_frames = [renderer.render(lit, pose, rng).mean() for _ in range(3)]
    lit_gain = renderer.exposure_gain
    dim_frames = [renderer.render(dim, pose, rng).mean() for _ in range(15)]
    # The lights dim: the first frame is darker, then the exposure opens up over frames.
    assert dim_frames[0] < 0.6 * lit_frames[-1]
    assert dim_frames[0] < dim_frames[1] < dim_frames[2] < dim_frames[4]
    assert renderer.exposure_gain == pytest.approx(2.0 * lit_gain, rel=0.02)
    assert dim_frames[-1] == pytest.approx(lit_frames[-1], rel=0.03)


def test_instant_exposure_has_no_lag():
    track = load_track("training")
    renderer = CameraRenderer(CameraConfig(), SensorConfig(exposure_lag_frames=0.0))
    ground = build_ground(track, AppearanceConfig(), LightingConfig(), np.random.default_rng(5))
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    renderer.render(ground, np.array([1.5, 0.0, math.pi]), rng)
    g1 = renderer.exposure_gain
    renderer.render(ground, np.array([1.5, 0.0, math.pi / 2]), rng)
    g2 = renderer.exposure_gain
    renderer.render(ground, np.array([1.5, 0.0, math.pi / 2]), rng)
    assert renderer.exposure_gain == pytest.approx(g2)  # settled after one frame
    assert g1 != pytest.approx(g2)


def _detail_ratio(img: np.ndarray) -> float:
    """Horizontal over vertical mean absolute gradient."""
    f = img.astype(float)
    return float(np.abs(np.diff(f, axis=1)).mean() / np.abs(np.diff(f, axis=0)).mean())


def test_motion_blur_follows_the_motion(ground):
    sensor = SensorConfig(noise_std=0.0, white_balance_jitter=0.0, motion_blur=True)
    pose = STRAIGHT + [0.0, 0.05, 0.0]

    def render(motion):
        renderer = CameraRenderer(CameraConfig(), sensor)
        rng = np.random.default_rng(0)
        renderer.reset(rng)
        return renderer.render(ground, pose, rng, motion=motion)

    sharp = render(None)
    assert np.array_equal(sharp, render(np.zeros(3)))  # no motion, no blur
    # A pivot smears the picture sideways, driving forward smears it up and down.
    assert _detail_ratio(render(np.array([0.0, 0.0, 0.2]))) < 0.7 * _detail_ratio(sharp)
    assert _detail_ratio(render(np.array([0.1, 0.0, 0.0]))) > 1.2 * _detail_ratio(sharp)


def test_jpeg_round_trip_keeps_the_picture(ground):
    plain = render_sequence(ground, [STRAIGHT], 0)[0].astype(float)
    jpeg = render_sequence(ground, [STRAIGHT], 0, SensorConfig(jpeg_quality=30))[0].astype(float)
    err = np.abs(plain - jpeg).mean()
    assert 0.5 < err < 12


def test_sensor_config_validates():
    with pytest.raises(ValueError, match="jpeg_quality"):
        SensorConfig(jpeg_quality=101)
    with pytest.raises(ValueError, match="vignetting"):
        SensorConfig(vignetting=1.0)


def test_highlight_shoulder_keeps_bright_felt_from_clipping(ground):
    def box(knee):
        sensor = SensorConfig(
            exposure_target=150.0,
            highlight_knee=knee,
            noise_std=0.0,
            vignetting=0.0,
            white_balance_cast=0.0,
            white_balance_jitter=0.0,
        )
        return render_sequence(ground, [STRAIGHT], 0, sensor)[0][safe_box_slices()]

    hard, soft = box(1.0), box(0.7)
    assert (hard == 255).mean() > 0.3  # overexposed felt clips flat with a linear curve
    assert (soft == 255).mean() < 0.05
    # ...and keeps its fibre texture in the shoulder, where clipping flattens it.
    assert hard[..., 2].std() < 0.5 < 1.0 < soft[..., 2].std()


def test_felt_coverage_of_the_last_frame_matches_the_geometry(track, ground):
    renderer = CameraRenderer()
    assert renderer.last_felt_coverage is None
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    pose = np.array([2.6, 0.05, 0.3])
    renderer.render(ground, pose, rng)
    cover = renderer.last_felt_coverage
    assert cover.shape == (480, 640)
    us, vs = np.meshgrid(np.arange(4, 640, 24), np.arange(4, 480, 24))
    pixels = np.column_stack([us.ravel(), vs.ravel()])
    on = track.on_felt(CameraModel().floor_points(pixels.astype(float), pose))
    seen = cover[pixels[:, 1], pixels[:, 0]] >= 128
    assert 0.1 < on.mean() < 0.9
    assert (seen == on).mean() > 0.97  # all but the odd sample on a frayed edge


def test_vignetting_darkens_the_corners(ground):
    def frame(strength):
        sensor = SensorConfig(
            vignetting=strength, noise_std=0.0, white_balance_cast=0.0, white_balance_jitter=0.0
        )
        renderer = CameraRenderer(CameraConfig(), sensor)
        rng = np.random.default_rng(0)
        renderer.reset(rng)
        renderer.render(ground, STRAIGHT, rng)
        return renderer, renderer.render(ground, STRAIGHT, rng).astype(float)

    flat_renderer, flat = frame(0.0)
    dark_renderer, dark = frame(0.3)
    ratio_centre = dark[220:260, 300:340].mean() / flat[220:260, 300:340].mean()
    ratio_corner = dark[:30, :30].mean() / flat[:30, :30].mean()
    # Exposure compensates the overall loss, so compare corners with the centre.
    assert ratio_corner < 0.8 * ratio_centre
    assert dark_renderer.exposure_gain > flat_renderer.exposure_gain


def test_a_far_reaching_view_past_the_texture_never_mirrors_felt(track, ground):
    import cv2

    flat = CameraConfig(pitch_deg=26.0, vfov_deg=45.0)  # the randomized preset's extreme
    pose = np.array([1.5, -0.12, -math.pi / 2])  # on the outer edge, looking away from the track
    cam = CameraModel(flat)
    far = cam.footprint(pose)
    assert far[:, 1].min() < ground.origin_xy[1] - ground.shape[0] * ground.metres_per_px - 3.0
    # Plain mirroring at the texture edge would show the far strip of the loop again...
    tex_from_img = np.linalg.inv(cam.homography(pose, ground))
    mirrored = cv2.warpPerspective(
        ground.rgba,
        tex_from_img,
        (640, 480),
        flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
        borderMode=cv2.BORDER_REFLECT,
    )
    assert (mirrored[..., 3] > 128).mean() > 0.01
    # ...the renderer shows only carpet there (nothing of the view is on the felt).
    us, vs = np.meshgrid(np.arange(0, 640, 20), np.arange(0, 480, 20))
    pixels = np.column_stack([us.ravel(), vs.ravel()]).astype(float)
    assert not track.on_felt(cam.floor_points(pixels, pose)).any()
    renderer = CameraRenderer(flat)
    rng = np.random.default_rng(0)
    renderer.reset(rng)
    frame = renderer.render(ground, pose, rng)
    assert renderer.last_felt_coverage.max() == 0
    assert frame.max(axis=2).min() > 5
    mean = frame.reshape(-1, 3).astype(float).mean(axis=0)
    assert mean[0] > mean[2] + 10


@pytest.mark.parametrize("lens", ["pinhole", "fisheye"])
def test_the_quick_margin_check_agrees_with_projecting_the_corners(ground, lens):
    # The renderer answers "does the view reach past the carpet margin?" from the pose alone
    # when the footprint's reach cannot get there; it must never answer differently from
    # projecting the footprint's corners, near the edges included.
    config = (
        CameraConfig()
        if lens == "pinhole"
        else CameraConfig(lens="fisheye", distortion=(0.2, 0.0, 0.0, 0.0))
    )
    renderer = CameraRenderer(config)
    h, w = ground.shape
    rng = np.random.default_rng(5)
    x0, y0 = ground.origin_xy
    s = ground.metres_per_px
    poses = np.column_stack(
        [
            rng.uniform(x0 - 1.0, x0 + w * s + 1.0, 3000),
            rng.uniform(y0 - h * s - 1.0, y0 + 1.0, 3000),
            rng.uniform(-math.pi, math.pi, 3000),
        ]
    )

    def exact(pose):
        corners = ground.to_texture(renderer.model.footprint(pose))
        beyond = max(
            float(-corners.min()),
            float(corners[:, 0].max()) - (w - 1),
            float(corners[:, 1].max()) - (h - 1),
        )
        return beyond * s > 0.9 * ground.margin_m

    answers = [renderer._sees_past_margin(ground, p) for p in poses]
    assert answers == [exact(p) for p in poses]
    assert 0 < sum(answers) < len(answers)  # both answers occur


def test_the_last_pose_kept_by_the_camera_never_answers_for_another_pose():
    cam, fresh = CameraModel(), CameraModel()
    for pose in ([1.0, 2.0, 0.3], [1.0, 2.0, 0.3], [1.0, 2.0, 0.30000000000000004], [0, 0, 0]):
        pose = np.array(pose, dtype=float)
        assert np.array_equal(cam.footprint(pose), CameraModel().footprint(pose))
        assert np.array_equal(
            cam.safe_box_floor_polygon(pose),
            fresh.floor_points(
                np.array([[294.5, 429.5], [344.5, 429.5], [344.5, 479.5], [294.5, 479.5]]), pose
            ),
        )
        assert np.array_equal(cam.image_from_world(pose), CameraModel().image_from_world(pose))


@pytest.mark.parametrize("knee", [0.5, 0.7, 1.0])
def test_tone_table_is_the_stated_curve(knee):
    # level × gain up to the knee, then a shoulder easing towards 255 (slope 1 at the knee),
    # rounded to the nearest level.
    renderer = CameraRenderer(sensor=SensorConfig(highlight_knee=knee))
    k, span = 255.0 * knee, 255.0 * (1.0 - knee)
    for gain in np.geomspace(0.4, 3.0, 97):
        curve = [
            v * gain
            if span == 0 or v * gain <= k
            else k + span * -math.expm1(-(v * gain - k) / span)
            for v in range(256)
        ]
        expected = np.clip(np.rint(curve), 0, 255)
        table = renderer._tone_table(float(gain)).astype(float)
        # Exact, except that a level within rounding error of a half may round either way.
        tie = np.abs(np.asarray(curve) % 1.0 - 0.5) < 1e-9
        assert np.array_equal(table[~tie], expected[~tie]), gain
        assert np.all(np.abs(table - expected) <= 1.0), gain
