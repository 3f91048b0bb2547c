"""ProgressTracker.update (float by float) against its numpy reference on random walks."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.world.track import ProgressTracker, load_track


@pytest.mark.parametrize("name", ["testing", "training", "sbend", "notch", "random:test:3"])
@pytest.mark.parametrize("reverse", [False, True])
def test_update_equals_array_reference(name: str, reverse: bool) -> None:
    track = load_track(name, reverse=reverse)
    rng = np.random.default_rng(len(name) + reverse)
    fast, reference = ProgressTracker(track), ProgressTracker(track)
    # A wandering point along the centreline, with jumps off it and far away now and then.
    s = 0.0
    for i in range(600):
        s += float(rng.normal(0.03, 0.05))
        point, _ = track.point_at(s)
        point = point + rng.normal(0.0, 0.15, 2)
        if i % 97 == 0:
            point = point + rng.normal(0.0, 2.0, 2)
        assert fast.update(point) == reference._update_arrays(point)  # the same bits
    assert fast.progress_m == reference.progress_m


def test_update_not_finite_takes_the_array_path() -> None:
    track = load_track("testing")
    fast, reference = ProgressTracker(track), ProgressTracker(track)
    point = np.array([np.nan, 1.0])
    assert np.isnan(fast.update(point)) == np.isnan(reference._update_arrays(point))


def _on_felt_reference(track, points: np.ndarray) -> np.ndarray:
    pts = np.asarray(points, dtype=np.float64)
    flat = pts.reshape(-1, 2)
    a, d, lengths, ext_a, ext_b = track._strip_frames
    rel = flat[:, None, :] - a[None, :, :]
    along = rel[..., 0] * d[None, :, 0] + rel[..., 1] * d[None, :, 1]
    across = -rel[..., 0] * d[None, :, 1] + rel[..., 1] * d[None, :, 0]
    inside = (
        (along >= -ext_a[None])
        & (along <= lengths[None] + ext_b[None])
        & (np.abs(across) <= track.width_m / 2.0)
    )
    return inside.any(axis=1).reshape(pts.shape[:-1])


@pytest.mark.parametrize("name", ["testing", "training", "sbend", "random:test:3"])
def test_on_felt_equals_reference(name: str) -> None:
    track = load_track(name)
    rng = np.random.default_rng(7)
    xmin, ymin, xmax, ymax = track.bounds(0.3)
    points = np.column_stack([rng.uniform(xmin, xmax, 5000), rng.uniform(ymin, ymax, 5000)])
    # Points on the strips' edges and ends, where a rounding would flip the answer.
    half = track.width_m / 2.0
    for a, b in zip(track.segment_starts, track.segment_ends, strict=True):
        d = (b - a) / np.hypot(*(b - a))
        normal = np.array([-d[1], d[0]])
        t = rng.uniform(-half, np.hypot(*(b - a)) + half, (200, 1))
        points = np.concatenate([points, a + t * d + half * normal, a + t * d - half * normal])
    inside = track.on_felt(points)
    np.testing.assert_array_equal(inside, _on_felt_reference(track, points))
    assert 0 < inside.sum() < len(inside)
    shaped = points[:12].reshape(3, 4, 2)
    np.testing.assert_array_equal(track.on_felt(shaped), _on_felt_reference(track, shaped))
    assert track.on_felt(np.zeros((0, 2))).shape == (0,)
