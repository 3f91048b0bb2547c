"""LfDTrack-v0: spaces, kwargs, info, every episode rule firing, determinism, Gymnasium checks."""

from __future__ import annotations

import math
import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers the env)
from lfd_track.errors import FileFormatError
from lfd_track.world.driver import CentrelineDriver

INFO_KEYS = {
    "pose",
    "progress_m",
    "lap_fraction",
    "corners_reached",
    "corners_negotiated",
    "on_felt",
    "failure",
    "success",
}


def drive_with_privileged_driver(env):
    """Run the centreline driver to the end of an episode; returns (steps, last info)."""
    unwrapped = env.unwrapped
    driver = CentrelineDriver(unwrapped.track)
    _, info = env.reset(seed=11)
    steps = 0
    while True:
        action = int(driver.act(unwrapped.rover_pose, info["progress_m"]))
        _, _, terminated, truncated, info = env.step(action)
        steps += 1
        assert INFO_KEYS <= set(info)
        if terminated or truncated:
            return steps, info


def test_spaces_match_the_paper_contract():
    env = gym.make("LfDTrack-v0")
    assert env.observation_space == gym.spaces.Box(0, 255, (480, 640, 3), np.uint8)
    assert env.action_space == gym.spaces.Discrete(3)
    obs, info = env.reset(seed=0)
    assert obs.dtype == np.uint8 and obs.shape == (480, 640, 3)
    assert INFO_KEYS <= set(info)
    assert info["corners_reached"] == [] and info["failure"] is None and not info["success"]
    assert info["on_felt"] == (True, True)
    env.close()


def test_make_without_prior_import_in_a_fresh_interpreter():
    code = (
        "import gymnasium as gym\n"
        "env = gym.make('lfd_track:LfDTrack-v0')\n"
        "obs, info = env.reset(seed=0)\n"
        "print(obs.shape)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "(480, 640, 3)"


@pytest.mark.parametrize(
    ("track", "reverse", "order"),
    [
        ("testing", False, ["1", "2", "3", "4"]),
        ("testing", True, ["3", "2", "1", "4"]),
        ("training", False, ["1", "2"]),
        ("training", True, ["2", "1"]),
    ],
)
def test_privileged_driver_succeeds_in_every_direction(track, reverse, order):
    env = gym.make("LfDTrack-v0", track=track, reverse=reverse)
    steps, info = drive_with_privileged_driver(env)
    assert info["success"], info
    assert info["failure"] is None
    assert info["corners_reached"] == order
    assert info["corners_negotiated"] == order
    assert steps < info["max_steps"] / 2


def test_default_start_is_corner_4_counter_clockwise():
    env = gym.make("LfDTrack-v0")
    _, info = env.reset(seed=0)
    x, y, theta = info["pose"]
    assert math.hypot(x, y) < 0.01 and abs(theta) < 0.01  # corner 4, heading to corner 1
    env_cw = gym.make("LfDTrack-v0", reverse=True)
    _, info = env_cw.reset(seed=0)
    assert info["pose"][2] == pytest.approx(math.pi / 4, abs=0.01)  # towards corner 3
    env_c2 = gym.make("LfDTrack-v0", start_corner="2")
    _, info = env_c2.reset(seed=0)
    assert info["pose"][:2] == pytest.approx((3.0, 1.8), abs=0.01)


def test_driving_straight_off_a_straight_ends_off_track():
    env = gym.make("LfDTrack-v0", track="training")
    env.reset(seed=0, options={"pose": (1.5, 0.0, math.pi / 2)})  # facing across the strip
    for _ in range(20):
        _, reward, terminated, truncated, info = env.step(0)
        if terminated:
            break
    assert info["failure"] == "off_track"
    assert info["on_felt"] == (False, False)
    assert reward < -0.5  # the failure penalty
    assert not info["success"]


def test_turning_around_ends_reversed_and_is_charged_to_the_next_corner():
    env = gym.make("LfDTrack-v0")
    env.reset(seed=0, options={"pose": (1.0, 0.0, 0.0)})
    for _ in range(8):  # pivot round on the straight
        _, _, terminated, _, info = env.step(1)
        assert not terminated
    rewards = []
    for _ in range(10):
        _, reward, terminated, _, info = env.step(0)
        rewards.append(reward)
        if terminated:
            break
    assert rewards[0] < 0  # driving back along the track earns negative reward
    assert info["failure"] == "reversed"
    assert info["failed_corner"] == "1"


def test_step_budget_truncates():
    env = gym.make("LfDTrack-v0", max_steps=5)
    env.reset(seed=0)
    results = [env.step(1)[2:4] for _ in range(5)]  # pivoting in place never ends otherwise
    assert results[-1] == (False, True)
    assert all(r == (False, False) for r in results[:-1])


def test_default_budget_is_three_times_the_ideal_driver():
    env = gym.make("LfDTrack-v0").unwrapped
    # 8.55 m at 0.1 m per command plus 360° at 23° per command ≈ 101 commands.
    assert 290 <= env.max_steps <= 320


def test_progress_and_reward_are_continuous_through_the_135_degree_corner():
    env = gym.make("LfDTrack-v0", start_corner="3")
    unwrapped = env.unwrapped
    driver = CentrelineDriver(unwrapped.track)
    _, info = env.reset(seed=4)
    last = info["progress_m"]
    total_reward = 0.0
    while True:
        _, reward, terminated, truncated, info = env.step(
            int(driver.act(unwrapped.rover_pose, info["progress_m"]))
        )
        total_reward += reward
        assert info["progress_m"] > last - 0.05  # never a jump back
        assert info["progress_m"] - last < 0.2  # never a jump forward
        last = info["progress_m"]
        if terminated or truncated:
            break
    assert info["success"]
    assert "4" in info["corners_negotiated"]
    assert total_reward == pytest.approx(info["progress_m"], abs=0.01)


def test_same_seed_is_bit_identical_and_other_seeds_differ():
    def run(seed):
        env = gym.make("LfDTrack-v0")
        obs, info = env.reset(seed=seed)
        frames, infos = [obs], [info]
        rng = np.random.default_rng(123)
        for _ in range(200):
            obs, _, terminated, truncated, info = env.step(int(rng.integers(3)))
            frames.append(obs)
            infos.append(info)
            if terminated or truncated:
                obs, info = env.reset()
        return frames, infos

    frames_a, infos_a = run(7)
    frames_b, infos_b = run(7)
    assert all(np.array_equal(a, b) for a, b in zip(frames_a, frames_b, strict=True))
    assert infos_a == infos_b
    frames_c, _ = run(8)
    assert not np.array_equal(frames_a[0], frames_c[0])
    # The ground texture itself differs, not only the noise.
    env_a, env_c = gym.make("LfDTrack-v0").unwrapped, gym.make("LfDTrack-v0").unwrapped
    env_a.reset(seed=7)
    env_c.reset(seed=8)
    assert not np.array_equal(env_a._ground.image, env_c._ground.image)


def test_gymnasium_env_checker_passes():
    from gymnasium.utils.env_checker import check_env

    env = gym.make("LfDTrack-v0", render_mode="rgb_array").unwrapped
    check_env(env, skip_render_check=False)


def test_async_vector_env_steps():
    envs = gym.make_vec("LfDTrack-v0", num_envs=2, vectorization_mode="async")
    try:
        obs, infos = envs.reset(seed=[1, 2])
        assert obs.shape == (2, 480, 640, 3)
        obs, rewards, terminated, truncated, infos = envs.step(np.array([0, 1]))
        assert rewards.shape == (2,)
        assert not np.array_equal(obs[0], obs[1])
    finally:
        envs.close()


def test_rgb_array_render_is_a_top_down_picture():
    from lfd_track.render import topdown

    env = gym.make("LfDTrack-v0", render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    for _ in range(8):
        env.step(0)
    picture = env.render()
    assert picture.dtype == np.uint8 and picture.ndim == 3 and picture.shape[2] == 3
    assert picture.shape[1] >= 400

    def count(image, rgb):
        return int((np.abs(image.astype(int) - rgb).sum(axis=2) <= 6).sum())

    for rgb in (topdown.FELT_RGB, topdown.CARPET_RGB, topdown.ROVER_RGB, topdown.FOOTPRINT_RGB):
        assert count(picture, rgb) > 50, rgb
    # The trajectory grows as the rover drives; the rover moves with it.
    assert count(picture, topdown.TRAJECTORY_RGB) > count(before, topdown.TRAJECTORY_RGB) + 50
    rover_before = np.argwhere(np.abs(before.astype(int) - topdown.ROVER_RGB).sum(axis=2) <= 6)
    rover_after = np.argwhere(np.abs(picture.astype(int) - topdown.ROVER_RGB).sum(axis=2) <= 6)
    assert rover_after[:, 1].mean() > rover_before[:, 1].mean() + 20  # drove right (+x)


def test_randomized_preset_varies_the_world_per_episode():
    env = gym.make("LfDTrack-v0", preset="randomized").unwrapped
    env.reset(seed=1)
    first = (env.preset.camera, env.preset.appearance)
    env.reset()
    second = (env.preset.camera, env.preset.appearance)
    assert first != second
    assert 0.28 <= env.preset.camera.height_m <= 0.34


def test_track_and_preset_paths_are_accepted(tmp_path):
    from lfd_track.utils.data import data_dir

    track_path = data_dir("tracks") / "sbend.toml"
    preset_path = tmp_path / "mine.toml"
    preset_path.write_text("[camera]\npitch_deg = 32.0\n")
    env = gym.make("LfDTrack-v0", track=str(track_path), preset=str(preset_path)).unwrapped
    env.reset(seed=0)
    assert env.track.name == "sbend"
    assert env.preset.camera.pitch_deg == 32.0


@pytest.mark.parametrize(
    ("text", "problem"),
    [
        ("[camera]\npitch_deg = 'steep'\n", "'camera.pitch_deg' must be a number"),
        ("[camera]\nzoom = 2.0\n", "unknown key 'camera.zoom'"),
        ("[weather]\nrain = true\n", "unknown table or key 'weather'"),
        ("[camera]\npitch_deg = nan\n", "must be finite"),
        ('[randomization]\n"camera.zoom" = [1.0, 2.0]\n', "names no preset field"),
        ('[randomization]\n"camera.height_m" = [0.4, 0.3]\n', "low > high"),
        ("[camera\n", "not valid TOML"),
        ("[camera]\nwidth_px = 320\n", "camera must be 640 x 480"),
        ("[episode]\ncorner_margin_m = -0.3\n", "corner_margin_m must be a finite number >= 0"),
    ],
)
def test_bad_presets_are_rejected_with_one_line(tmp_path, text, problem):
    path = tmp_path / "bad.toml"
    path.write_text(text)
    with pytest.raises(FileFormatError) as excinfo:
        gym.make("LfDTrack-v0", preset=str(path))
    message = str(excinfo.value)
    assert "\n" not in message and str(path) in message and problem in message


def test_unknown_preset_name_is_one_line():
    with pytest.raises(FileNotFoundError, match="unknown preset 'sunny'"):
        gym.make("LfDTrack-v0", preset="sunny")


def test_invalid_action_is_rejected():
    env = gym.make("LfDTrack-v0").unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match="invalid action"):
        env.step(3)


@pytest.mark.parametrize("action", [True, False, np.True_, 1.0, np.array([1]), "1", None])
def test_bools_and_other_non_integers_are_not_actions(action):
    # Gymnasium's Discrete(3).contains(True) is True (bool is an int); the env refuses it anyway.
    env = gym.make("LfDTrack-v0").unwrapped
    env.reset(seed=0)
    with pytest.raises(ValueError, match="invalid action"):
        env.step(action)
    for ok in (1, np.int64(1), np.array(1, dtype=np.int8)):
        env.step(ok)  # integers of every kind still step


def test_a_track_shorter_than_the_episode_margins_is_refused(tmp_path):
    path = tmp_path / "stub.toml"
    path.write_text("closed = false\nvertices = [[0.0, 0.0], [0.5, 0.0]]\n")
    with pytest.raises(ValueError, match="too short for the episode rules"):
        gym.make("LfDTrack-v0", track=str(path))


@pytest.mark.parametrize("kwargs", [{}, {"track": "training"}, {"max_steps": 7}])
def test_spec_states_the_step_budget_without_a_second_time_limit(kwargs):
    env = gym.make("LfDTrack-v0", **kwargs)
    assert env.spec.max_episode_steps == env.unwrapped.max_steps
    assert "TimeLimit" not in str(env)  # the env truncates itself; no wrapper doubles it
    env.reset(seed=0)
    steps = 0
    while True:
        _, _, terminated, truncated, _ = env.step(1)  # pivoting in place: only the budget ends it
        steps += 1
        if terminated or truncated:
            break
    assert truncated and steps == env.spec.max_episode_steps
    # A TimeLimit asked for in make keeps its own limit.
    assert gym.make("LfDTrack-v0", max_episode_steps=5, **kwargs).spec.max_episode_steps == 5


def test_render_without_a_render_mode_warns():
    env = gym.make("LfDTrack-v0")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match='render_mode="rgb_array"'):
        assert env.render() is None
