"""A driving session's colour balance matched to the library's felt
(``colour_balance = "safe_box"``, :mod:`lfd_track.vision.colour_balance`)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lfd_track.core.frame import safe_box_slices
from lfd_track.envs.presets import load_preset
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.policy.memory import FreshFeltConfig, memory_config
from lfd_track.teaching.perception import Perception
from lfd_track.vision.colour_balance import (
    MAX_LOG_SPREAD,
    SETTLE_SAMPLES,
    SafeBoxBalance,
    histogram_means,
)
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.world.driver import CentrelineDriver

#: How close the estimated gains come to the colour change of the same views between the two
#: sessions [natural log of a channel's ratio]: the frames' white-balance jitter (1.5 %) and the
#: histograms' 32 bins are in both.
GAIN_TOLERANCE = 0.03


def _teach(env: LfDTrackEnv, steps: int) -> RoadLibrary:
    """A library taught by a careful perception along the first ``steps`` of a lap."""
    obs, info = env.reset(seed=0)
    driver = CentrelineDriver(env.track)
    library = RoadLibrary()
    perception = Perception(library, "careful")
    for _ in range(steps):
        perception.perceive(obs, info["safe_box_on_felt"])
        command = driver.act(np.asarray(info["pose"]), info["progress_m"])
        obs, _, terminated, truncated, info = env.step(int(command))
        assert not (terminated or truncated)
    return library


def _cast_preset(cast: float):
    paper = load_preset("paper")
    sensor = dataclasses.replace(paper.sensor, white_balance_cast=cast)
    return dataclasses.replace(paper, name=f"cast{cast}", sensor=sensor)


@pytest.fixture(scope="module")
def taught():
    """A library taught in a session of a world with a strong cast, and that session's cast."""
    env = LfDTrackEnv(track="testing", preset=_cast_preset(0.08))
    library = _teach(env, 60)
    return library, env._renderer._cast.copy()


def _session(seed: int):
    env = LfDTrackEnv(track="testing", preset=_cast_preset(0.08))
    obs, info = env.reset(seed=seed)
    return env, obs, info


def _chroma(gains: np.ndarray) -> np.ndarray:
    log = np.log(gains)
    return log - log.mean()


def test_histogram_means_read_the_level_of_a_flat_patch():
    hists = np.zeros((5, 32), dtype=np.float32)
    hists[0, 10] = hists[1, 20] = hists[2, 3] = 1.0
    assert histogram_means(hists) == pytest.approx([84.0, 164.0, 28.0])


def test_an_empty_library_leaves_frames_as_they_are():
    balance = SafeBoxBalance()
    frame = np.full((480, 640, 3), 90, dtype=np.uint8)
    balance.update(frame, RoadLibrary())
    assert balance.samples == 0
    assert balance.apply(frame) is frame
    assert np.array_equal(balance.gains, np.ones(3))


def test_another_sessions_cast_is_undone(taught):
    library, teaching_cast = taught
    env, obs, info = _session(seed=3)
    # this session's felt differs from the teaching session's by several per cent
    assert np.max(np.abs(_chroma(env._renderer._cast) - _chroma(teaching_cast))) > 0.05
    teaching = LfDTrackEnv(track="testing", preset=_cast_preset(0.08))
    teaching.reset(seed=0)  # the teaching session's camera again
    rows, cols = safe_box_slices()
    rng = np.random.default_rng(1)
    driver = CentrelineDriver(env.track)
    balance = SafeBoxBalance()
    observed = []  # the colour of the same safe box in the teaching session over in this one
    for _ in range(30):
        pose = np.asarray(info["pose"])
        balance.update(obs, library)
        there = teaching.view_from(pose, rng)[rows, cols].reshape(-1, 3).mean(axis=0)
        observed.append(_chroma(there / obs[rows, cols].reshape(-1, 3).mean(axis=0)))
        obs, *_, info = env.step(int(driver.act(pose, info["progress_m"])))
    assert balance.samples >= 20
    assert np.log(balance.gains) == pytest.approx(np.median(observed, axis=0), abs=GAIN_TOLERANCE)
    assert np.log(balance.gains).sum() == pytest.approx(0.0, abs=1e-9)  # colour, not brightness
    # the felt under the rover reads as the library's felt again
    before = library.road_values(obs, update_statistics=False)[35:]
    after = library.road_values(balance.apply(obs), update_statistics=False)[35:]
    felt = before.argmax()
    assert after[felt] > before[felt] + 0.05


def test_the_carpet_is_not_a_sample_once_settled(taught):
    library, _ = taught
    env, obs, info = _session(seed=3)
    balance = SafeBoxBalance()
    for _ in range(SETTLE_SAMPLES + 3):
        balance.update(obs, library)
    settled = balance.gains.copy()
    count = balance.samples
    # the same view shifted in colour well beyond a session's spread: a different floor
    shifted = obs.astype(np.float64) * np.array([1.0, 1.0, np.exp(3 * MAX_LOG_SPREAD)])
    balance.update(np.clip(shifted, 0, 255).astype(np.uint8), library)
    assert balance.samples == count
    assert np.array_equal(balance.gains, settled)


def test_the_perception_balances_only_a_finished_librarys_frames(taught):
    library, _ = taught
    config = FreshFeltConfig(colour_balance="safe_box")
    assert memory_config(config.to_dict()) == config
    assert FreshFeltConfig().colour_balance == "none"
    env, obs, info = _session(seed=3)
    frozen = Perception(library, "frozen", config)
    plain = Perception(library, "frozen", FreshFeltConfig())
    paused = Perception(library, "paused", config)
    assert plain.balance is None and frozen.balance is not None
    for _ in range(10):
        balanced = frozen.perceive(obs, None)
        unbalanced = plain.perceive(obs, None)
        as_taught = paused.perceive(obs, None)
        assert np.array_equal(as_taught.values, unbalanced.values)
    assert paused.balance is not None and paused.balance.samples == 0
    assert frozen.balance is not None and frozen.balance.samples >= 5
    assert not np.array_equal(balanced.values, unbalanced.values)
    assert np.array_equal(
        frozen.look(obs), library.road_values(frozen.balance.apply(obs), update_statistics=False)
    )


def test_frames_are_scaled_exactly_as_the_lookup_table_says():
    """The gains are applied as a per-channel scale where that gives every level as the rounded
    table does, by the table elsewhere: either way each pixel gets the table's level."""
    rng = np.random.default_rng(5)
    frame = rng.integers(0, 256, (480, 640, 3), dtype=np.uint8)
    balance = SafeBoxBalance()
    for _ in range(400):
        log_gains = rng.uniform(-0.3, 0.3, 3)
        balance._use(log_gains - log_gains.mean())
        gains = np.exp(balance._log_gains)
        table = np.clip(np.rint(np.arange(256.0)[:, None] * gains), 0, 255).astype(np.uint8)
        expected = np.stack([table[frame[..., c], c] for c in range(3)], axis=-1)
        assert np.array_equal(balance.apply(frame), expected)  # whichever way this CPU takes
        balance._scale = None  # the table's way
        assert np.array_equal(balance.apply(frame), expected)
