"""Perception: the road library and the rule that says when it may learn (paper §4.2.1, §6).

Learning rules:

* ``careful`` — learn from the safe box only while it lies on the felt, as an operator watching
  the phone's screen would (where the loop cannot know, e.g. a real camera, it learns: the
  operator pauses it by hand);
* ``paused`` — a careful operator's pause: no learning, but road-value selections still count
  (the library is still being taught, its usage statistics matter for later evictions);
* ``frozen`` — the library of a finished controller: nothing changes, not even the counts;
* ``always`` — learn from every frame (the paper's §6 warning: carpet gets learned as road).

:meth:`Perception.look` never mutates the library (overlays, evaluation, previews);
only :meth:`Perception.perceive`, the loop's learn step, does.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..vision.road_library import RoadLibrary

LEARNING_RULES = ("careful", "paused", "frozen", "always")


@dataclass(frozen=True)
class Percept:
    """What the loop saw in one frame."""

    values: np.ndarray
    """Road values of the 40 regions, (40,) float64, row-major from the top-left."""
    histograms: np.ndarray
    """Region histograms, (40, 5, bins) float32 (lets values be recomputed later)."""
    learned: bool
    """True when Algorithm 1 learned from this frame's safe box before the values were taken."""
    box_on_felt: bool | None
    """Whether the safe box lay on the felt (None when the loop cannot know)."""


class Perception:
    """A road library plus its learning rule (one of :data:`LEARNING_RULES`)."""

    def __init__(self, library: RoadLibrary, rule: str = "careful") -> None:
        self.library = library
        self.rule = rule

    @property
    def rule(self) -> str:
        """The learning rule; may be switched between frames (e.g. an operator's pause)."""
        return self._rule

    @rule.setter
    def rule(self, value: str) -> None:
        if value not in LEARNING_RULES:
            raise ValueError(f"learning rule must be one of {', '.join(LEARNING_RULES)}")
        self._rule = value

    def would_learn(self, box_on_felt: bool | None) -> bool:
        """Whether the current rule learns from a frame whose safe box is (not) on the felt."""
        if self._rule == "always":
            return True
        if self._rule == "careful":
            return box_on_felt is None or bool(box_on_felt)
        return False

    def perceive(self, frame: np.ndarray, box_on_felt: bool | None = None) -> Percept:
        """The loop's learn step: Algorithm 1 if the rule allows, then Algorithm 2.

        ``frame``: RGB uint8 (480, 640, 3). Selections are counted unless the rule is ``frozen``.
        """
        learn = self.would_learn(box_on_felt)
        if learn:
            self.library.learn(frame)
        histograms = self.library.region_histograms(frame)
        values = self.library.road_values_from_histograms(
            histograms, update_statistics=self._rule != "frozen"
        )
        return Percept(values=values, histograms=histograms, learned=learn, box_on_felt=box_on_felt)

    def look(self, frame: np.ndarray) -> np.ndarray:
        """Road values (40,) float64 of a frame without touching the library (no counts)."""
        return self.library.road_values(frame, update_statistics=False)
