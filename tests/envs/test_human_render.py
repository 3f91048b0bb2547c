"""``render_mode="human"`` opens a window, and ``gymnasium.utils.play.play`` drives the env by keys.

Both run under SDL's dummy video driver (set before pygame opens its display), so no screen is
needed; the play test feeds real pygame key events into ``play``'s own loop, frame by frame.
"""

from __future__ import annotations

import sys

import gymnasium as gym
import numpy as np
import pytest

import lfd_track  # noqa: F401  (registers LfDTrack-v0)
from lfd_track.envs.track_env import LfDTrackEnv
from lfd_track.utils.extras import MissingExtraError, install_line

pygame = pytest.importorskip("pygame")  # the play extra; part of the test extra

ACTIONS = (0, 1, 1, 2, 0)


@pytest.fixture
def dummy_display(monkeypatch):
    """SDL draws into memory: set before pygame initialises its display."""
    monkeypatch.setenv("SDL_VIDEODRIVER", "dummy")
    monkeypatch.setenv("SDL_AUDIODRIVER", "dummy")
    yield
    pygame.quit()


def _shown() -> np.ndarray:
    """What the window shows, as an (H, W, 3) RGB array."""
    return pygame.surfarray.array3d(pygame.display.get_surface()).transpose(1, 0, 2)


def test_human_rendering_opens_a_window_shows_each_step_and_closes(dummy_display):
    env = gym.make("LfDTrack-v0", track="training", render_mode="human")
    twin = gym.make("LfDTrack-v0", track="training", render_mode="rgb_array")
    assert env.render_mode == "human"
    assert env.unwrapped.metadata["render_modes"] == ["human", "rgb_array"]
    assert not pygame.display.get_init()
    obs, _ = env.reset(seed=3)
    twin_obs, _ = twin.reset(seed=3)
    assert pygame.display.get_init() and pygame.display.get_surface() is not None
    np.testing.assert_array_equal(_shown(), twin.render())
    np.testing.assert_array_equal(obs, twin_obs)  # the window changes no observation
    for action in ACTIONS:
        obs, reward, terminated, truncated, info = env.step(action)
        twin_step = twin.step(action)
        np.testing.assert_array_equal(obs, twin_step[0])
        assert (reward, terminated, truncated) == twin_step[1:4]
        assert info == twin_step[4]
        np.testing.assert_array_equal(_shown(), twin.render())  # the picture of this step
    assert env.render() is None  # human mode draws; it returns nothing
    env.close()
    assert not pygame.display.get_init()
    env.close()  # closing twice is harmless
    twin.close()


def test_the_key_map_is_arrows_and_wasd():
    keys = LfDTrackEnv().get_keys_to_action()
    assert keys == {
        (pygame.K_UP,): 0,
        (pygame.K_w,): 0,
        (pygame.K_LEFT,): 1,
        (pygame.K_a,): 1,
        (pygame.K_RIGHT,): 2,
        (pygame.K_d,): 2,
    }


def _key(kind: int, key: int):
    return pygame.event.Event(kind, key=key)


# Frame -> the key events that arrive during it. play steps at the start of a frame (with the keys
# held then) and reads events at its end; frame 0 only resets.
SCRIPT = {
    0: [_key(pygame.KEYDOWN, pygame.K_UP)],  # frames 1-3: forward
    3: [_key(pygame.KEYUP, pygame.K_UP), _key(pygame.KEYDOWN, pygame.K_a)],  # 4-5: left
    5: [_key(pygame.KEYUP, pygame.K_a), _key(pygame.KEYDOWN, pygame.K_RIGHT)],  # 6: right
    6: [_key(pygame.KEYDOWN, pygame.K_LEFT)],  # 7: two keys, no mapped pair: noop (forward)
    7: [_key(pygame.KEYUP, pygame.K_RIGHT), _key(pygame.KEYUP, pygame.K_LEFT)],
    # frames 8-9: no key held, so play waits (wait_on_player=True) and the rover stays put
    9: [pygame.event.Event(pygame.QUIT)],
}
EXPECTED = [0, 0, 0, 1, 1, 2, 0]
LAST_FRAME = 9


@pytest.mark.filterwarnings("ignore:.*matplotlib is not installed")  # play's live plots only
def test_play_drives_the_env_with_the_documented_call(dummy_display, monkeypatch):
    from gymnasium.utils.play import play

    real_get = pygame.event.get
    frames = []

    def get(*args, **kwargs):
        frame = len(frames)
        frames.append(frame)
        # Past the script a window close every frame: play ends even if a step misbehaved.
        script = SCRIPT.get(frame, []) if frame <= LAST_FRAME else [pygame.event.Event(pygame.QUIT)]
        for event in script:
            pygame.event.post(event)
        return real_get(*args, **kwargs)

    monkeypatch.setattr(pygame.event, "get", get)
    steps = []

    def callback(obs_t, obs_tp1, action, reward, terminated, truncated, info):
        steps.append((action, info["step"], info["pose"]))

    env = gym.make("LfDTrack-v0", track="training", render_mode="rgb_array")
    play(env, noop=0, wait_on_player=True, callback=callback, seed=0)
    assert len(frames) == LAST_FRAME + 1  # the window close of the script ended it
    assert [a for a, _, _ in steps] == EXPECTED
    assert [s for _, s, _ in steps] == list(range(1, len(EXPECTED) + 1))  # one episode
    assert not pygame.display.get_init()  # play quits pygame when it ends
    # The same commands from the same seed: a twin ends each step where play's rover did.
    twin = gym.make("LfDTrack-v0", track="training")
    twin.reset(seed=0)
    for action, _, pose in steps:
        assert twin.step(action)[4]["pose"] == pose
    start = twin.unwrapped.episode.start_pose()
    assert np.hypot(steps[2][2][0] - start[0], steps[2][2][1] - start[1]) > 0.2  # it drove


def test_without_pygame_the_window_and_the_key_map_fail_in_one_line(monkeypatch):
    monkeypatch.setitem(sys.modules, "pygame", None)  # what Python does for an absent module
    with pytest.raises(MissingExtraError) as caught:
        gym.make("LfDTrack-v0", render_mode="human")
    assert str(caught.value) == install_line("play")
    assert "\n" not in str(caught.value)
    assert str(caught.value).endswith("pip install 'lfd-track[play]'")
    with pytest.raises(MissingExtraError, match=r"lfd-track\[play\]"):
        LfDTrackEnv().get_keys_to_action()
    gym.make("LfDTrack-v0", render_mode="rgb_array").reset(seed=0)  # the rest needs no pygame
