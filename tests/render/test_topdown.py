"""Top-down debug and report pictures."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.core.camera_model import CameraModel
from lfd_track.render.topdown import (
    CARPET_RGB,
    FELT_RGB,
    ROVER_RGB,
    TRAJECTORY_RGB,
    TopDownView,
    draw_topdown,
    draw_trajectories,
)


def pixel(img, view, point):
    c, r = np.rint(view.to_px(np.asarray(point, dtype=float))).astype(int)
    return tuple(int(v) for v in img[r, c])


def test_picture_shows_felt_on_carpet(track):
    img = draw_topdown(track, size_px=800, labels=False)
    view = TopDownView(track, 800)
    assert img.dtype == np.uint8 and img.shape[1] == 800 and img.shape[2] == 3
    assert pixel(img, view, [1.5, 0.1]) == FELT_RGB
    assert pixel(img, view, [1.5, 0.6]) == CARPET_RGB  # inside the loop
    assert img.shape[0] == view.size_px[1]


def test_fixed_size_keeps_the_scale_isotropic(track):
    view = TopDownView(track, (400, 400))
    a, b = view.to_px(np.array([[0.0, 0.0], [1.0, 1.0]]))
    assert b[0] - a[0] == pytest.approx(a[1] - b[1])  # x right, y up
    img = draw_topdown(track, size_px=(400, 400))
    assert img.shape == (400, 400, 3)


def test_rover_trajectory_and_footprint_are_drawn(track):
    pose = np.array([1.5, 0.0, 0.0])
    traj = np.array([[0.2, 0.0], [0.8, 0.05], [1.2, -0.05]])
    img = draw_topdown(
        track, pose=pose, trajectory=traj, footprint=CameraModel().footprint(pose), labels=False
    )
    view = TopDownView(track, 800)
    assert pixel(img, view, [1.5 - 0.08, 0.05]) == ROVER_RGB
    assert pixel(img, view, [0.5, 0.025]) == TRAJECTORY_RGB
    plain = draw_topdown(track, labels=False)
    assert not np.array_equal(img, plain)
    # Labels add pixels too.
    assert not np.array_equal(draw_topdown(track), plain)


def test_several_trajectories_in_their_colours(track):
    red, green = (220, 40, 40), (40, 200, 60)
    paths = [np.array([[0.3, 0.0], [2.7, 0.0]]), np.array([[3.0, 0.3], [3.0, 1.5]])]
    img = draw_trajectories(track, paths, [red, green], mark_ends=False)
    view = TopDownView(track, 800)
    assert pixel(img, view, [1.5, 0.0]) == red
    assert pixel(img, view, [3.0, 0.9]) == green
    with pytest.raises(ValueError, match="colours"):
        draw_trajectories(track, paths, [red])
