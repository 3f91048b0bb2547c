"""Perception: the road library, the rule that says when it may learn (paper §4.2.1, §6), the
per-region features the policy reads (:mod:`lfd_track.policy.features`: the road values, or
also the regions' colours) and its memory inputs (:mod:`lfd_track.policy.memory`), if any.

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

import copy
import sys
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from ..core.commands import Command
from ..policy.features import (
    DEFAULT_FEATURES,
    check_features,
    colour_features,
    near_felt_features,
    reads_road_values,
)
from ..policy.map_geometry import MapGeometry, geometry_note
from ..policy.memory import (
    FreshFeltConfig,
    FreshFeltMemory,
    MemoryConfig,
    NoMemory,
    memory_for,
    policy_inputs,
)
from ..vision.colour_balance import SafeBoxBalance
from ..vision.felt_levels import RoadValueLevels
from ..vision.road_library import RoadLibrary

#: Pairs of (learned, seen) frame sizes already reported in this process (one line each).
_SIZES_REPORTED: set[tuple[tuple[int, int], tuple[int, int]]] = set()
#: Pairs of (map, world) geometries already reported in this process (one line each).
_GEOMETRIES_REPORTED: set[tuple[MapGeometry, MapGeometry]] = set()


def frame_size_note(learned: tuple[int, int], seen: tuple[int, int]) -> str:
    """The one line that says a controller drives on frames of another size than it learned on."""
    return (
        f"lfd-track: note: this controller learned on {learned[0]} x {learned[1]} frames and"
        f" drives on {seen[0]} x {seen[1]} ones (the same view and grid; its road values differ"
        " a little from those it learned on)"
    )


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
    memory: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """Memory inputs at this frame, (m,) float64 (m = 0 without memory)."""
    colour: np.ndarray = field(default_factory=lambda: np.zeros(0))
    """The frame's inputs beyond the road values one by one: the regions' colour features,
    (120,) float64 with the ``road_values+colour`` features, the two ``near_felt`` inputs with
    those, else (0,) (computed from :attr:`values` and :attr:`histograms`, as for a recorded
    case)."""

    road_inputs: bool = True
    """Whether the policy reads the road values one by one (False with the ``"near_felt"`` and
    ``"none"`` features)."""

    @cached_property
    def inputs(self) -> np.ndarray:
        """The policy's inputs: the road values (unless the features are ``"near_felt"`` or
        ``"none"``), then any colour or ``near_felt`` features, then the memory inputs,
        (40 + c + m,), (2 + m,) or (m,) float64 (joined once, on first use)."""
        if not self.road_inputs:
            return np.concatenate([self.colour, self.memory]) if len(self.colour) else self.memory
        if not len(self.memory) and not len(self.colour):
            return self.values
        return np.concatenate([self.values, self.colour, self.memory])


class Perception:
    """A road library plus its learning rule (one of :data:`LEARNING_RULES`), the memory
    inputs ``memory`` asks for (none by default) and the per-region ``features``
    (:data:`~lfd_track.policy.features.FEATURE_SETS`; the road values by default).

    ``expected_frame_size`` (width, height) [px]: the frames a controller learned on; the first
    frame of another size prints :func:`frame_size_note` to stderr (once per process and pair of
    sizes) and driving goes on. None: any size, silently.

    ``geometry``: the camera and per-command motion of the world the policy is taught in (or,
    for a controller, the ones it recorded), which a ``fresh_felt`` map with ``geometry =
    "world"`` assumes (:mod:`lfd_track.policy.map_geometry`; None: the paper's constants).
    ``world_geometry``: the world's where the map drives with another one (a controller's);
    if the map's geometry differs from it beyond the tolerances, one line
    (:func:`~lfd_track.policy.map_geometry.geometry_note`) goes to stderr (once per process
    and pair) and the map keeps its own.
    """

    def __init__(
        self,
        library: RoadLibrary,
        rule: str = "careful",
        memory: MemoryConfig | None = None,
        features: str = DEFAULT_FEATURES,
        *,
        expected_frame_size: tuple[int, int] | None = None,
        geometry: MapGeometry | None = None,
        world_geometry: MapGeometry | None = None,
    ) -> None:
        self.library = library
        self._expected_shape = (
            None
            if expected_frame_size is None
            else (int(expected_frame_size[1]), int(expected_frame_size[0]), 3)
        )
        self.rule = rule
        self.memory_config = memory or NoMemory()
        self.features = check_features(features)
        if features == "none" and not self.memory_config.n_inputs:
            raise ValueError(
                "features 'none' leave the policy only its memory inputs: set a memory kind"
            )
        self._memory = memory_for(memory, geometry)
        self._memory_before = copy.copy(self._memory)  # the memory as it was before the last frame
        # A map with felt_levels = "library" reads felt by levels from the road values seen.
        self.felt_levels: RoadValueLevels | None = (
            RoadValueLevels()
            if isinstance(memory, FreshFeltConfig) and memory.felt_levels == "library"
            else None
        )
        """The road values' felt and carpet levels read so far (None: fixed levels)."""
        self._levels_used: tuple[float, float] | None = None  # at the last perceived frame
        # A map with colour_balance = "safe_box" balances a driving session's frames.
        self.balance: SafeBoxBalance | None = (
            SafeBoxBalance()
            if isinstance(memory, FreshFeltConfig) and memory.colour_balance == "safe_box"
            else None
        )
        """This camera session's colour balance (None: frames as they come); it acts only while
        the rule is ``frozen`` (a finished library, the reference it matches)."""
        if world_geometry is not None and self.map_geometry is not None:
            _report_geometry(self.map_geometry, world_geometry)

    @property
    def map_geometry(self) -> MapGeometry | None:
        """The geometry the ``fresh_felt`` map assumes (None without a map)."""
        memory = self._memory
        return memory.geometry if isinstance(memory, FreshFeltMemory) else None

    @property
    def n_inputs(self) -> int:
        """Length of :attr:`Percept.inputs`: the per-region features plus the memory inputs."""
        return policy_inputs(self.memory_config, self.features)

    def start_episode(self) -> None:
        """A new episode: the memory forgets (the library does not)."""
        if self._memory is not None:
            self._memory.reset()
            self._memory_before = copy.copy(self._memory)

    def note(self, command: Command | int) -> None:
        """The loop executed ``command`` (the memory counts it)."""
        if self._memory is not None:
            self._memory.note(command)

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
        if self._expected_shape is not None and frame.shape != self._expected_shape:
            self._report_size(frame)
        learn = self.would_learn(box_on_felt)
        if self.balance is not None and self._rule == "frozen":
            self.balance.update(frame, self.library)
        seen = self._balanced(frame)
        if learn:
            self.library.learn(seen)
        histograms = self.library.region_histograms(seen)
        values = self.library.road_values_from_histograms(
            histograms, update_statistics=self._rule != "frozen"
        )
        if self._memory is None:
            memory = np.zeros(0)
        else:
            if isinstance(self._memory, FreshFeltMemory):  # motion = "visual": the frame moves it
                self._memory.arrive(frame)
            # A shallow copy is a snapshot: the memories replace their arrays, never write them.
            self._memory_before = copy.copy(self._memory)
            if self.felt_levels is not None and isinstance(self._memory, FreshFeltMemory):
                if self.library.n_models:  # an empty library's zeros say nothing of the floor
                    self.felt_levels.add(values)
                self._levels_used = self.felt_levels.levels()
                self._memory.see(values, self._levels_used)
            else:
                self._memory.see(values)
            memory = self._memory.inputs()
        return self._percept(values, histograms, learn, box_on_felt, memory)

    def _report_size(self, frame: np.ndarray) -> None:
        assert self._expected_shape is not None
        learned = (self._expected_shape[1], self._expected_shape[0])
        seen = (int(frame.shape[1]), int(frame.shape[0])) if frame.ndim >= 2 else (0, 0)
        if (learned, seen) not in _SIZES_REPORTED:
            _SIZES_REPORTED.add((learned, seen))
            print(frame_size_note(learned, seen), file=sys.stderr)

    def view(self, frame: np.ndarray, before: Command | int) -> Percept:
        """The last perceived frame's percept as seen from another pose: the one ``before``
        would bring the rover from to where it stood (one step behind it for a forward command,
        one pivot the other way for a pivot). ``frame`` is the camera's view from that pose.

        The road values come from the library as it is (nothing learned, nothing counted), the
        memory inputs from the memory as it was before the last frame, placed there
        (:meth:`~lfd_track.policy.memory.FreshFeltMemory.place_before`) and shown ``frame``.
        Nothing in this perception changes (a colour balance applies its gains as they are).
        """
        histograms = self.library.region_histograms(self._balanced(frame))
        values = self.library.road_values_from_histograms(histograms, update_statistics=False)
        memory = np.zeros(0)
        if self._memory_before is not None:  # set with the memory, None without one
            placed = copy.copy(self._memory_before)
            placed.place_before(before)
            if isinstance(placed, FreshFeltMemory):  # with the last frame's levels, if any
                placed.see(values, self._levels_used)
            else:
                placed.see(values)
            memory = placed.inputs()
        return self._percept(values, histograms, False, None, memory)

    def _percept(
        self,
        values: np.ndarray,
        histograms: np.ndarray,
        learned: bool,
        box_on_felt: bool | None,
        memory: np.ndarray,
    ) -> Percept:
        if self.features == "road_values+colour":
            colour = colour_features(histograms)
        elif self.features == "near_felt":
            colour = near_felt_features(values)
        else:
            colour = np.zeros(0)
        return Percept(
            values=values,
            histograms=histograms,
            learned=learned,
            box_on_felt=box_on_felt,
            memory=memory,
            colour=colour,
            road_inputs=reads_road_values(self.features),
        )

    def look(self, frame: np.ndarray) -> np.ndarray:
        """Road values (40,) float64 of a frame without touching the library (no counts; a
        colour balance applies its gains as they are)."""
        return self.library.road_values(self._balanced(frame), update_statistics=False)

    def _balanced(self, frame: np.ndarray) -> np.ndarray:
        """``frame`` with this session's colour gains (itself without a balance at work)."""
        if self.balance is None or self._rule != "frozen":
            return frame
        return self.balance.apply(frame)


def _report_geometry(learned: MapGeometry, world: MapGeometry) -> None:
    """Print :func:`~lfd_track.policy.map_geometry.geometry_note` if ``learned`` and ``world``
    differ beyond the tolerances (once per process and pair)."""
    differences = learned.differences(world)
    if differences and (learned, world) not in _GEOMETRIES_REPORTED:
        _GEOMETRIES_REPORTED.add((learned, world))
        print(geometry_note(learned, world, differences), file=sys.stderr)
