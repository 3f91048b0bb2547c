import numpy as np

from lfd_track.vision.overlay import draw_road_values, road_value_colour


def test_overlay_tints_regions_by_value(frames):
    frame = frames[0]
    values = np.linspace(-1, 1, 40)
    before = frame.copy()
    out = draw_road_values(frame, values)
    assert out.shape == frame.shape and out.dtype == np.uint8
    np.testing.assert_array_equal(frame, before)  # input untouched
    low = out[40:90, 10:70].astype(int)  # region 0, value -1: red tint
    high = out[420:470, 570:630].astype(int)  # region 39, value 1: green tint
    tint = out.astype(int) - frame.astype(int)
    assert tint[40:90, 10:70, 0].mean() > tint[40:90, 10:70, 1].mean()
    assert tint[430:470, 570:630, 1].mean() > tint[430:470, 570:630, 0].mean()
    assert low.shape == high.shape
    assert road_value_colour(1.0) == (0, 255, 0) and road_value_colour(-0.5) == (255, 0, 0)


def test_safe_box_outline_optional(frames):
    values = np.zeros(40)
    with_box = draw_road_values(frames[0], values, safe_box=True)
    without = draw_road_values(frames[0], values, safe_box=False)
    assert np.all(with_box[430, 300] == 255)
    assert not np.array_equal(with_box[430:480, 295:345], without[430:480, 295:345])
