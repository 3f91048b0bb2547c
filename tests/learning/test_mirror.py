"""Mirrored cases: exactly the road values of the flipped frame, commands and memory swapped."""

import numpy as np
import pytest

from lfd_track.benchmark.runner import BenchmarkConfig, config_dict
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.learning.mirror import mirror_cases, with_mirrored
from lfd_track.policy.memory import LastBendConfig
from lfd_track.vision.road_library import RoadLibrary

LAST_BEND = LastBendConfig()


def _frames():
    env = LfDTrackEnv(track="testing")
    frames = [env.reset(seed=4)[0]]
    for command in (1, 1, 0, 2, 0, 1):
        frames.append(env.step(command)[0])
    env.close()
    return frames


def test_mirrored_road_values_are_those_of_the_flipped_frame_exactly():
    frames = _frames()
    library = RoadLibrary()
    for frame in frames[:3]:
        library.learn(frame)
    values = np.stack([library.road_values(f, update_statistics=False) for f in frames])
    flipped = np.stack(
        [
            library.road_values(np.ascontiguousarray(f[:, ::-1]), update_statistics=False)
            for f in frames
        ]
    )
    mirrored, commands = mirror_cases(values, np.array([0, 1, 2, 0, 1, 2, 0]))
    np.testing.assert_array_equal(mirrored, flipped)
    assert commands.tolist() == [0, 2, 1, 0, 2, 1, 0]


def test_memory_sides_swap_and_mirroring_twice_is_the_identity():
    rng = np.random.default_rng(0)
    x = np.hstack([rng.uniform(0, 1, (5, 40)), np.array([[0.0], [1.0], [0.5], [1.0], [0.0]])])
    a = rng.integers(0, 3, 5)
    m, b = mirror_cases(x, a, LAST_BEND)
    assert m[:, 40].tolist() == [1.0, 0.0, 0.5, 0.0, 1.0]
    np.testing.assert_array_equal(
        m[:, :40].reshape(5, 5, 8), x[:, :40].reshape(5, 5, 8)[:, :, ::-1]
    )
    back, c = mirror_cases(m, b, LAST_BEND)
    np.testing.assert_array_equal(back, x)
    np.testing.assert_array_equal(c, a)
    both, actions = with_mirrored(x, a, LAST_BEND)
    assert both.shape == (10, 41) and actions.tolist() == [*a, *b]
    with pytest.raises(ValueError, match=r"shape \(N, 41\) for memory 'last_bend'"):
        mirror_cases(x[:, :40], a, LAST_BEND)


def test_mirroring_is_stored_only_when_asked_for():
    assert config_dict(BenchmarkConfig())["mirror"] is False  # every setting is written
    assert config_dict(BenchmarkConfig(mirror=True))["mirror"] is True
