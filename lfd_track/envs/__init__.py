"""The Gymnasium face: registration, the simulated track env, presets and wrappers.

Nothing is re-exported here: ``import lfd_track`` registers the environments through
:mod:`lfd_track.envs.registration` without importing the env, its renderer or its physics.
"""
