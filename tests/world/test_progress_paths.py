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
