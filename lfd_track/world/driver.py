"""The privileged centreline driver: pure pursuit on the known track, as three discrete commands.

The driver sees the true pose and the continuous progress along the centreline (not pixels). It
aims at the centreline point ``lookahead_m`` further along the driving direction and pivots only
when the bearing to that point is off by more than a dead-band. The dead-band has to exceed half
of one pivot command (about 11.5° at 1 rad/s for 0.4 s): with a narrower one a single pivot
overshoots the band on the other side and the driver flips left/right without end.

Human traits (reaction delay, lapses, rate limits) belong to the demonstrator that wraps this
driver; the decision rule here is a pure function of (pose, progress) and the config.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..core.commands import Command
from .track import Track


@dataclass(frozen=True)
class DriverConfig:
    """Pure pursuit with a heading dead-band."""

    lookahead_m: float = 0.35
    """[m] how far along the centreline, past the current progress, the driver aims."""
    dead_band_deg: float = 15.0
    """[deg] heading errors inside ±this drive forward; outside, pivot towards the target."""

    def __post_init__(self) -> None:
        if not (math.isfinite(self.lookahead_m) and self.lookahead_m > 0):
            raise ValueError(
                f"driver lookahead_m must be a finite number > 0, got {self.lookahead_m!r}"
            )
        if not (math.isfinite(self.dead_band_deg) and 0 <= self.dead_band_deg < 90):
            raise ValueError(f"driver dead_band_deg must be in [0, 90), got {self.dead_band_deg!r}")


class CentrelineDriver:
    """Drives a track by pure pursuit on its centreline, in the track's driving direction."""

    def __init__(self, track: Track, config: DriverConfig | None = None) -> None:
        self.track = track
        self.config = config if config is not None else DriverConfig()
        self._dead_band_rad = math.radians(self.config.dead_band_deg)
        if not track.closed:
            end = track.vertices[-1]
            d = end - track.vertices[-2]
            self._end = end.astype(np.float64)
            self._end_dir = d / np.linalg.norm(d)

    def target(self, progress_m: float) -> np.ndarray:
        """(2,) float64 centreline point [m] ``lookahead_m`` past ``progress_m``.

        Past the far end of an open track the point continues straight along the last strip, so
        the driver keeps its heading rather than turning towards the end vertex.
        """
        s = float(progress_m) + self.config.lookahead_m
        track = self.track
        if not track.closed and s > track.length_m:
            return self._end + self._end_dir * (s - track.length_m)
        point, _ = track.point_at(s)
        return point

    def heading_error(self, pose: np.ndarray, progress_m: float) -> float:
        """Bearing to the target minus heading, wrapped to (-pi, pi] [rad]; positive = to the left.

        ``pose`` is (3,) x [m], y [m], theta [rad]; ``progress_m`` the arc length of the pivot
        centre along the driving direction (from ``ProgressTracker``).
        """
        tx, ty = self.target(progress_m)
        x, y, theta = float(pose[0]), float(pose[1]), float(pose[2])
        error = math.remainder(math.atan2(ty - y, tx - x) - theta, 2.0 * math.pi)
        return math.pi if error == -math.pi else error

    def act(self, pose: np.ndarray, progress_m: float) -> Command:
        """The command for ``pose`` (3,) at ``progress_m`` [m]: LEFT/RIGHT outside the dead-band."""
        return self.command_for_error(self.heading_error(pose, progress_m))

    def command_for_error(self, heading_error_rad: float) -> Command:
        """Dead-band rule: LEFT above +dead_band, RIGHT below -dead_band, else FORWARD."""
        if heading_error_rad > self._dead_band_rad:
            return Command.LEFT
        if heading_error_rad < -self._dead_band_rad:
            return Command.RIGHT
        return Command.FORWARD
