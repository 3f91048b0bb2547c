"""Part 77 of ``README.md``: the goal's map fed what the camera should have told it (oracles).

Parts 70-76 measured what the map's memory lacks: given the track's visited felt, the goal's
learner laps all 400 of the rooms' own laps. What the map is fed was not measured for the
goal's learner: the felt each region reads (a road value, levels 0.3 and 0.5) and the motion it
moves by (``motion = "visual"``, the camera's floor registration). Part 25 gave the map rule a
perfect point sensor at the regions on older rooms; part 75 traced one room whose start laps are
lost where felt in a shadow band reads as carpet. Two oracles, each a prototype map that reads
the true pose the env reports after every step (``oracle_visited.NOW``, kept by the env's
patched ``reset``/``step``):

- :class:`TrueFeltMemory`: each region reads 1 where the floor under its centre is felt and 0
  where it is carpet (the map's levels 0 and 1), in place of its road value; everything else
  (the motion measured by the camera, the library, the colour balance) as it is;
- :class:`TrueMotionMemory`: the map moves at every command by the rover's true motion between
  the two frames, in place of the motion the camera measures; the felt read as it is;
- :class:`TrueSensesMemory`: both.

The teacher, the learner, the added cases and the trials are the goal's; the demonstration is
recorded on the oracle's map (taught and driven on it), as part 70's first run. Oracles, not
configurations: they read the track and the true pose, and no robot could run them. They drive
the validation rooms' laps only (``hairpin_trace.py --true-felt`` / ``--true-motion`` /
``--true-senses``); nothing is chosen on them and no test loop is driven.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

import oracle_learner  # noqa: E402
import oracle_visited  # noqa: E402

from lfd_track.envs.track_env import LfDTrackEnv  # noqa: E402
from lfd_track.policy.odometry import PlanarMotion  # noqa: E402


def use_true_pose() -> None:
    """From now on every env this process makes keeps ``oracle_visited.NOW`` (its track, the
    rover's true pose and progress) after each reset and step."""
    LfDTrackEnv.reset, LfDTrackEnv.step = (  # type: ignore[method-assign]
        oracle_visited.reset,
        oracle_visited.step,
    )


class _TruePoseMemory(oracle_learner.PrototypeMemory):
    """A map that reads the rover's true pose (``oracle_visited.NOW``)."""

    @staticmethod
    def prepare() -> None:
        """What the map needs before it runs (``hairpin_trace.py`` calls it): the true pose."""
        use_true_pose()


class TrueFeltMemory(_TruePoseMemory):
    """The goal's map whose regions read the floor's true felt (see the module docstring)."""

    def see(self, values: np.ndarray, levels: tuple[float, float] | None = None) -> None:
        now = oracle_visited.NOW
        if now["track"] is None or now["pose"] is None:
            super().see(values, levels)
            return
        floor = oracle_visited.to_floor(self._region_points, now["pose"])
        super().see(now["track"].on_felt(floor).astype(np.float64), (0.0, 1.0))


class TrueMotionMemory(_TruePoseMemory):
    """The goal's map moved by the rover's true motion (see the module docstring)."""

    def reset(self) -> None:
        super().reset()
        self._true_pose: tuple[float, float, float] | None = None

    def arrive(self, frame: np.ndarray) -> None:
        pose = oracle_visited.NOW["pose"]
        if self._odometry is None or pose is None:
            super().arrive(frame)
            return
        if self._pending is not None:
            before = self._true_pose
            self._settle(None if before is None else PlanarMotion.from_poses(before, pose))
        self._view = None  # the camera's registration is not used
        self._true_pose = tuple(float(v) for v in pose)  # type: ignore[assignment]


class TrueSensesMemory(TrueMotionMemory, TrueFeltMemory):
    """The goal's map with both: the true felt and the true motion."""
