"""Episode rules shared by the env and the benchmark (paper §4.2, §4.2.5).

Progress is arc length along the centreline in the driving direction, tracked continuously. A
corner is *reached* when progress passes ``corner_margin_m`` before it and *negotiated* when
progress passes ``corner_margin_m`` after it with the rover on the felt. The episode fails when the
rover reversed direction (progress fell more than ``reverse_margin_m`` below its maximum) or when
both treads are completely off the felt; it succeeds when every corner is negotiated and the end is
reached (open track: within ``end_margin_m`` of the far end; loop: back across the start, which on
a loop is also the last corner met).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .track import ProgressTracker, Track

REVERSED = "reversed"
OFF_TRACK = "off_track"


@dataclass(frozen=True)
class EpisodeRules:
    """Distances that define the episode rules."""

    corner_margin_m: float = 0.30  # reached / negotiated this far before / after a corner [m]
    reverse_margin_m: float = 0.30  # progress this far below its maximum means reversed [m]
    end_margin_m: float = 0.40  # open track: success within this distance of the far end [m]
    start_offset_m: float = 0.15  # open track: start this far along the centreline [m]

    def __post_init__(self) -> None:
        for name in ("corner_margin_m", "reverse_margin_m", "end_margin_m", "start_offset_m"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise ValueError(f"{name} must be a finite number >= 0, got {value}")
        if self.reverse_margin_m == 0.0:
            raise ValueError("reverse_margin_m must be > 0 (any wobble would count as reversing)")


@dataclass
class EpisodeState:
    """What the episode tracker knows after the latest pose."""

    progress_m: float = 0.0
    max_progress_m: float = 0.0
    corners_reached: list[str] = field(default_factory=list)
    corners_negotiated: list[str] = field(default_factory=list)
    on_felt: tuple[bool, bool] = (True, True)
    failure: str | None = None
    success: bool = False


class EpisodeTracker:
    """Applies the episode rules to a sequence of rover poses on one track."""

    def __init__(self, track: Track, rules: EpisodeRules = EpisodeRules()) -> None:
        self.track = track
        self.rules = rules
        self._progress = ProgressTracker(track)
        self.state = EpisodeState()

    @property
    def goal_progress_m(self) -> float:
        """Progress at which the end is reached [m]."""
        if self.track.closed:
            return self.track.length_m + self.rules.corner_margin_m
        return self.track.length_m - self.rules.end_margin_m

    def start_pose(self) -> np.ndarray:
        """The start pose (x, y, theta): on the centreline at the start, facing the driving way."""
        offset = 0.0 if self.track.closed else self.rules.start_offset_m
        point, heading = self.track.point_at(offset)
        return np.array([point[0], point[1], heading])

    def reset(self, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> EpisodeState:
        """Start a new episode at ``pose`` (x, y, theta)."""
        start = 0.0 if self.track.closed else self.rules.start_offset_m
        self._progress = ProgressTracker(self.track, start_progress_m=start)
        progress = self._progress.update(np.asarray(pose[:2]))
        self.state = EpisodeState(
            progress_m=progress, max_progress_m=progress, on_felt=tread_on_felt
        )
        return self.state

    def update(self, pose: np.ndarray, tread_on_felt: tuple[bool, bool]) -> EpisodeState:
        """Advance the rules by one pose; returns the (mutated) state."""
        st = self.state
        if st.failure is not None or st.success:
            return st
        rules = self.rules
        st.progress_m = self._progress.update(np.asarray(pose[:2]))
        st.max_progress_m = max(st.max_progress_m, st.progress_m)
        st.on_felt = (bool(tread_on_felt[0]), bool(tread_on_felt[1]))
        any_on_felt = st.on_felt[0] or st.on_felt[1]
        for index, corner in enumerate(self.track.corners):
            if (
                corner.label not in st.corners_reached
                and st.max_progress_m >= corner.s_m - rules.corner_margin_m
            ):
                st.corners_reached.append(corner.label)
            if (
                corner.label in st.corners_reached
                and corner.label not in st.corners_negotiated
                and st.progress_m >= corner.s_m + rules.corner_margin_m
                and any_on_felt
                # Corners are negotiated in order: a later one never before an earlier one.
                and len(st.corners_negotiated) == index
            ):
                st.corners_negotiated.append(corner.label)
        if not any_on_felt:
            st.failure = OFF_TRACK
        elif st.progress_m < st.max_progress_m - rules.reverse_margin_m:
            st.failure = REVERSED
        elif (
            len(st.corners_negotiated) == len(self.track.corners)
            and st.progress_m >= self.goal_progress_m
        ):
            st.success = True
        return st

    @property
    def next_corner(self) -> str | None:
        """The first corner not yet negotiated (None once all are)."""
        for corner in self.track.corners:
            if corner.label not in self.state.corners_negotiated:
                return corner.label
        return None

    @property
    def failed_corner(self) -> str | None:
        """The corner a failure is charged to: the first corner not yet negotiated."""
        return None if self.state.failure is None else self.next_corner

    def lap_fraction(self) -> float:
        """Progress as a fraction of the track length (may exceed 1 past the end of a loop)."""
        return self.state.progress_m / self.track.length_m


def reference_step_count(track: Track, forward_step_m: float, pivot_step_rad: float) -> int:
    """Commands an ideal driver needs: the length in forward steps plus every corner in pivots."""
    turns = float(np.abs(track.vertex_turns_rad).sum())
    return int(math.ceil(track.length_m / forward_step_m + turns / pivot_step_rad))
