import pytest

from lfd_track.study.stats import controller_interval, rate_summary, wilson_interval


def test_wilson_interval_known_values():
    # Textbook values: 8 of 10 -> (0.490, 0.943); 0 of 10 -> (0, z^2 / (n + z^2)).
    low, high = wilson_interval(8, 10)
    assert low == pytest.approx(0.4902, abs=1e-4) and high == pytest.approx(0.9433, abs=1e-4)
    assert wilson_interval(0, 10) == (0.0, pytest.approx(3.8415 / 13.8415, abs=1e-4))
    assert wilson_interval(10, 10) == (pytest.approx(1 - 3.8415 / 13.8415, abs=1e-4), 1.0)
    # The paper's testing track, 28 of 60 laps (worked by hand: centre 0.4687, half 0.1224).
    low, high = wilson_interval(28, 60)
    assert low == pytest.approx(0.3463, abs=1e-4) and high == pytest.approx(0.5911, abs=1e-4)


def test_interval_is_symmetric_contains_the_rate_and_narrows_with_trials():
    for n in (1, 5, 60, 1000):
        for k in range(0, n + 1, max(1, n // 7)):
            low, high = wilson_interval(k, n)
            assert 0 <= low <= k / n <= high <= 1
            mirrored = wilson_interval(n - k, n)
            assert mirrored == (pytest.approx(1 - high), pytest.approx(1 - low))
    assert wilson_interval(30, 60)[1] - wilson_interval(30, 60)[0] > (
        wilson_interval(300, 600)[1] - wilson_interval(300, 600)[0]
    )


def test_rate_summary_and_bad_counts():
    assert rate_summary(3, 4) == {
        "successes": 3,
        "trials": 4,
        "rate": 0.75,
        "ci95": list(wilson_interval(3, 4)),
    }
    assert rate_summary(0, 0) == {"successes": 0, "trials": 0, "rate": None, "ci95": [0.0, 1.0]}
    with pytest.raises(ValueError):
        wilson_interval(5, 4)


def test_controller_interval_is_deterministic_and_contains_the_pooled_rate():
    groups = [(6, 6), (3, 6), (4, 6), (0, 6), (5, 6), (2, 6)] * 5
    interval = controller_interval(groups)
    assert interval == controller_interval(list(groups))  # same counts, same numbers
    low, high = interval
    assert low < 100 / 180 < high  # 20 of 36 laps per six controllers


def test_controller_interval_widens_when_controllers_are_all_or_nothing():
    # 30 controllers, 6 laps each, 90 of 180 laps pooled either way.
    mixed = [(3, 6)] * 30  # every controller laps half: trials look independent
    split = [(6, 6)] * 15 + [(0, 6)] * 15  # half the controllers lap everything, half nothing
    w_low, w_high = wilson_interval(90, 180)
    m_low, m_high = controller_interval(mixed)
    s_low, s_high = controller_interval(split)
    assert (m_low, m_high) == (0.5, 0.5)  # no spread between controllers at all
    assert s_high - s_low > w_high - w_low  # shared controllers: fewer independent units
    assert s_low < 0.5 < s_high


def test_controller_interval_edge_cases():
    assert controller_interval([]) is None
    assert controller_interval([(0, 0), (0, 0)]) is None
    assert controller_interval([(0, 0), (2, 4)]) == [0.5, 0.5]  # empty groups are ignored
    with pytest.raises(ValueError):
        controller_interval([(5, 4)])
    with pytest.raises(ValueError):
        controller_interval([(-1, 4)])
