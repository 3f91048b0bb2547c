"""The shared vocabulary every other part imports: commands, frame and camera geometry, configs.

Its modules import nothing of the package but :mod:`lfd_track.errors` and
:mod:`lfd_track.utils.files` (configs read their files); nothing is re-exported here, so importing
one of them stays cheap.
"""
