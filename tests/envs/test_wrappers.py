import gymnasium as gym
import numpy as np
import pytest

from lfd_track.envs.wrappers import RoadValueObservation
from lfd_track.vision.road_library import RoadLibrary
from lfd_track.vision.synthetic import synthetic_frames


class FrameEnv(gym.Env):
    """Minimal env whose observations are synthetic camera frames."""

    observation_space = gym.spaces.Box(0, 255, (480, 640, 3), np.uint8)
    action_space = gym.spaces.Discrete(3)

    def __init__(self):
        self.frames = synthetic_frames(np.random.default_rng(0), 4)
        self.t = 0

    def reset(self, *, seed=None, options=None):
        super().reset(seed=seed)
        self.t = 0
        return self.frames[0], {}

    def step(self, action):
        self.t += 1
        return self.frames[self.t % 4], 0.0, False, self.t >= 3, {}


def test_observations_are_road_values():
    env = FrameEnv()
    library = RoadLibrary()
    library.learn(env.frames[0])
    reference = RoadLibrary.from_dict(library.to_dict())
    wrapped = RoadValueObservation(env, library)
    assert wrapped.observation_space == gym.spaces.Box(-1, 1, (40,), np.float32)
    obs, _ = wrapped.reset(seed=0)
    assert obs.dtype == np.float32 and wrapped.observation_space.contains(obs)
    np.testing.assert_allclose(obs, reference.road_values(env.frames[0]), atol=1e-6)
    obs, *_ = wrapped.step(0)
    np.testing.assert_allclose(obs, reference.road_values(env.frames[1]), atol=1e-6)
    assert library.n_models == 1  # frozen by default


def test_learn_option_runs_algorithm_1_each_frame():
    env = FrameEnv()
    library = RoadLibrary()
    wrapped = RoadValueObservation(env, library, learn=True)
    wrapped.reset(seed=0)
    wrapped.step(0)
    wrapped.step(1)
    assert library.n_models == 3


def test_library_type_is_checked_at_construction():
    for library in (None, "lib"):
        # Accepted before, then reset() failed with an AttributeError in the perception.
        with pytest.raises(TypeError, match="library must be a RoadLibrary, got"):
            RoadValueObservation(FrameEnv(), library)
