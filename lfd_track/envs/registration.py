"""Gymnasium registration of the lfd-track environments (entry points are strings)."""

from __future__ import annotations

import gymnasium as gym


def register_envs() -> None:
    """Register ``LfDTrack-v0`` and ``LfDTrack-Hardware-v0`` once (idempotent)."""
    registry = gym.envs.registration.registry
    if "LfDTrack-v0" not in registry:
        # No max_episode_steps here: the env truncates itself at its step budget, which depends
        # on the track (3x the commands an ideal driver needs, lfd_track/world/episode.py). The
        # made env's spec states that budget as max_episode_steps (LfDTrackEnv.spec). The
        # hardware env has no step limit: it drives until stopped.
        gym.register(
            id="LfDTrack-v0",
            entry_point="lfd_track.envs.track_env:LfDTrackEnv",
            # make_vec's default: the worlds of one process stepped on a thread pool.
            vector_entry_point="lfd_track.envs.vector:make_vector_env",
        )
    if "LfDTrack-Hardware-v0" not in registry:
        gym.register(id="LfDTrack-Hardware-v0", entry_point="lfd_track.hardware.env:HardwareEnv")
