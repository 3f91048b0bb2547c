"""Report pictures: successes and other runs apart with counts, marks explained, metre scale,
fitness axes with round ticks."""

from __future__ import annotations

import numpy as np
import pytest

from lfd_track.render.topdown import TopDownView
from lfd_track.viz.plots import (
    FAILURE_RGB,
    SUCCESS_RGB,
    TIMEOUT_RGB,
    DirectionRuns,
    TrackRun,
    _finish_and_scale,
    fitness_notes,
    fitness_plot,
    laps_plot,
    nice_ticks,
    trajectory_grid,
)
from lfd_track.world.track import load_track


def _count(img: np.ndarray, rgb: tuple[int, int, int]) -> int:
    return int(np.all(img == np.array(rgb, dtype=np.uint8), axis=2).sum())


def _path(track, start_m: float, end_m: float) -> np.ndarray:
    return np.array([track.point_at(s)[0] for s in np.linspace(start_m, end_m, 40)])


def test_successes_and_failures_get_their_own_panels():
    track = load_track("testing", reverse=True)
    # 9 successes on the same path as one failure: drawn together, the failure would vanish.
    runs = [TrackRun(_path(track, 0.0, track.length_m), True, None) for _ in range(9)]
    runs.append(TrackRun(_path(track, 0.0, track.length_m * 0.7), False, "reversed"))
    runs.append(TrackRun(_path(track, 0.0, 1.0), False, "timeout"))
    picture = trajectory_grid(
        [DirectionRuns("Testing track, clockwise", track, runs, finish_m=0.3)],
        title="t",
        panel_px=300,
    )
    half = picture.shape[1] // 2
    left, right = picture[:, :half], picture[:, half:]
    legend_rows = 130  # the legend at the bottom shows every colour once
    assert _count(left[:-legend_rows], SUCCESS_RGB) > 200
    assert _count(left[:-legend_rows], FAILURE_RGB) == 0
    assert _count(right[:-legend_rows], FAILURE_RGB) > 100
    assert _count(right[:-legend_rows], TIMEOUT_RGB) > 20
    assert _count(right[:-legend_rows], SUCCESS_RGB) == 0
    for colour in (SUCCESS_RGB, FAILURE_RGB, TIMEOUT_RGB):
        assert _count(picture[-legend_rows:], colour) > 20


def test_scale_bar_is_one_metre_and_the_finish_line_crosses_the_felt():
    track = load_track("training")
    view = TopDownView(track, 500)
    img = view.blank(track, labels=False)
    before = img.copy()
    _finish_and_scale(view, img, track, finish_m=track.length_m - 0.4)
    white = np.all(img == 255, axis=2) & ~np.all(before == 255, axis=2)
    bar_row = view.size_px[1] - 14
    cols = np.flatnonzero(white[bar_row])
    assert cols[-1] - cols[0] == pytest.approx(view.px_per_m, abs=3)
    point, _ = track.point_at(track.length_m - 0.4)
    col, row = view.to_px(point).round().astype(int)
    assert white[row - 3 : row + 4, col - 3 : col + 4].any()


def test_laps_plot_has_a_title_legend_and_lap_labels():
    track = load_track("training")
    runs = [
        TrackRun(_path(track, 0.15, track.length_m - 0.4), True, None, "lap 1"),
        TrackRun(_path(track, 0.15, 1.0), False, "reversed", "lap 2"),
    ]
    unlabelled = [TrackRun(r.path, r.success, r.failure) for r in runs]
    picture = laps_plot(track, runs, title="training track", finish_m=track.length_m - 0.4)
    plain = laps_plot(track, unlabelled, title="training track", finish_m=track.length_m - 0.4)
    assert picture.shape == plain.shape
    assert (picture != plain).any(axis=2).sum() > 100  # the "lap k" labels
    assert np.all(picture[:20] == 255, axis=2).mean() > 0.5  # a white title strip on top
    assert _count(picture[-110:], SUCCESS_RGB) > 20 and _count(picture[-110:], FAILURE_RGB) > 20


def test_nice_ticks():
    assert nice_ticks(0.0, 0.93).tolist() == [0.0, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert nice_ticks(0, 200).tolist() == [0, 50, 100, 150, 200]
    assert nice_ticks(0.0, 0.3).tolist() == [0.0, 0.1, 0.2, 0.3]


def test_fitness_plot_says_lower_is_better_and_why_the_best_curve_rises():
    assert "no elitism" in " ".join(fitness_notes(0)) and "rise" in " ".join(fitness_notes(0))
    assert "never rises" in " ".join(fitness_notes(2))
    curve = np.linspace(0.9, 0.2, 200)
    img = fitness_plot([("best", curve, (200, 30, 30))], notes=fitness_notes(0))
    with_notes_height = img.shape[0]
    assert fitness_plot([("best", curve, (200, 30, 30))]).shape[0] == with_notes_height
    pixels = img.astype(int)
    drawn = (pixels[..., 0] > pixels[..., 1] + 60) & (pixels[..., 0] > pixels[..., 2] + 60)
    assert np.ptp(np.flatnonzero(drawn.any(axis=0))) > 0.8 * img.shape[1]  # the whole curve
