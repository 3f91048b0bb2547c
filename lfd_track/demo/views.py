"""Shifted and turned views: cases from the poses one command before each demonstrated pose.

A demonstration shows the human's command only at the poses the rover passed, so a learner never
sees what to do a little off them. Three poses lead to a demonstrated pose P in one command: one
forward step behind P (a forward command reaches P), P turned one pivot to the right (a left
pivot reaches P) and P turned one pivot to the left (a right pivot reaches P). A *view* is the
case the rover would have recorded standing at such a pose, labelled with that command, the way
back to P, where the human's own command takes over. Its labels need no human: views add no
human commands.

A view is made only where its inputs can be computed exactly. In the simulated world the camera
frame from any pose is rendered like every other frame (the same world, the camera's exposure as
it stands; :meth:`lfd_track.envs.LfDTrackEnv.view_from`), its road values come from the road
library as it was at the case (nothing learned or counted), and a ``fresh_felt`` map is the map
the rover had before the case's frame, placed at the view's pose and shown the view's frame
(:meth:`lfd_track.teaching.perception.Perception.view`); the other memories read executed
commands only and are the case's. A recording of a real robot holds the road values of the frames
its camera took, and the road values of a shifted or turned 8 x 5 grid need pixels the camera did
not see (the grid covers the whole frame), so views are made while the simulated demonstration
runs and are not stored in the recording.

Where the human pivoted from P one way, the view turned that way is not made: the human was about
to stand there, and the next case says what to do there (a view would say "pivot back").
Views are made for the human's cases only (the protocol's turnarounds are not cases).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np

from ..core.commands import Command
from ..policy.features import DEFAULT_FEATURES, check_features, frame_features

if TYPE_CHECKING:
    from ..teaching.perception import Perception
    from ..teaching.types import Step

#: The views made for a case with each command: the commands they are labelled with (the way back
#: to the case's pose), forward first.
VIEW_LABELS = {
    Command.FORWARD: (Command.FORWARD, Command.LEFT, Command.RIGHT),
    Command.LEFT: (Command.FORWARD, Command.LEFT),  # the view turned left (label right) is skipped
    Command.RIGHT: (Command.FORWARD, Command.RIGHT),
}


def pose_before(
    pose: np.ndarray, command: Command | int, step_m: float, pivot_rad: float
) -> np.ndarray:
    """The pose (x [m], y [m], theta [rad]) from which ``command``'s nominal motion (a forward
    step of ``step_m``, a pivot of ``pivot_rad`` on the spot) brings the rover to ``pose``."""
    x, y, theta = (float(v) for v in pose)
    cmd = Command(int(command))
    if cmd == Command.FORWARD:
        return np.array([x - step_m * math.cos(theta), y - step_m * math.sin(theta), theta])
    turn = pivot_rad if cmd == Command.LEFT else -pivot_rad
    return np.array([x, y, theta - turn])


@dataclass
class ViewCases:
    """The views of a demonstration: per view its road values, region histograms, memory inputs
    and label (each a list, one entry per view, in the order they were made)."""

    values: list[np.ndarray] = field(default_factory=list)
    histograms: list[np.ndarray] = field(default_factory=list)
    memory: list[np.ndarray] = field(default_factory=list)
    labels: list[int] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.labels)

    @property
    def commands(self) -> np.ndarray:
        """(N,) int64 labels: 0 forward, 1 left, 2 right."""
        return np.asarray(self.labels, dtype=np.int64)

    def policy_inputs(self, features: str = DEFAULT_FEATURES) -> np.ndarray:
        """(N, f + m) float64 — the views' inputs laid out as
        :meth:`lfd_track.dataset.Demonstration.policy_inputs` lays out a recording's."""
        check_features(features)
        n = len(self)
        memory = np.asarray(self.memory, dtype=np.float64).reshape(n, -1)
        if features == "none":
            return memory
        values = np.asarray(self.values, dtype=np.float64).reshape(n, -1)
        if features == DEFAULT_FEATURES:
            return np.hstack([values, memory])
        histograms = np.asarray(self.histograms, dtype=np.float32)
        return np.hstack([frame_features(values, histograms, features), memory])


class PredecessorViews:
    """An observer of a simulated demonstration that makes the views of every case.

    ``env`` is the :class:`~lfd_track.envs.LfDTrackEnv` the loop drives, ``perception`` the
    loop's, ``views`` where the views go (a new :class:`ViewCases` if None); ``rng`` draws the views' white balance and noise (never the episode's own streams, so
    the demonstration runs exactly as without views). The nominal motion is the preset's: a
    forward step of forward speed x control period, a pivot of pivot rate x control period.
    """

    def __init__(
        self,
        env: Any,
        perception: Perception,
        rng: np.random.Generator,
        views: ViewCases | None = None,
    ) -> None:
        self.env = env
        self.perception = perception
        self.rng = rng
        rover = env.preset.rover
        self.step_m = rover.forward_speed_mps * rover.control_period_s
        self.pivot_rad = rover.pivot_rate_radps * rover.control_period_s
        self.views = ViewCases() if views is None else views

    def start(self, info: dict[str, Any]) -> None:
        pass

    def observe(self, step: Step) -> None:
        if not step.is_case or step.command is None:
            return
        pose = step.moment.pose
        if pose is None:
            raise RuntimeError("views need the world's pose in info['pose'] (a simulated world)")
        for label in VIEW_LABELS[Command(int(step.command))]:
            where = pose_before(pose, label, self.step_m, self.pivot_rad)
            percept = self.perception.view(self.env.view_from(where, self.rng), label)
            self.views.values.append(percept.values)
            self.views.histograms.append(percept.histograms)
            self.views.memory.append(percept.memory)
            self.views.labels.append(int(label))
