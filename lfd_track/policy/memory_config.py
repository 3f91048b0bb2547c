"""Memory settings: one frozen config class per memory kind, chosen by ``kind``.

What each kind computes is described in :mod:`lfd_track.policy.memory`; this module holds what a
user sets. :data:`MEMORY_CONFIGS` maps each kind to its class (:class:`NoMemory`,
:class:`LastBendConfig`, :class:`PreviousCommandConfig`, :class:`FreshFeltConfig`), all
subclasses of :class:`MemoryConfig`; :func:`memory_config` builds one from a table (a study's
``[conditions.memory]``, a controller file's ``memory``, the command line's flags, the teaching
station's settings), refusing unknown keys and values out of bounds in one line.

Every setting is a field declared with :func:`setting`: its default, its one-line description
with units and its bounds (``low``/``high`` or ``choices``) sit together, and every reader takes
them from there: the checks here, the command line's flags and their help
(:func:`lfd_track.cli.types.add_map_arguments`), the study files and the migration of older
files (a setting's ``before``). Adding a knob to a kind is one field here (and the code in
:mod:`lfd_track.policy.memory` that reads it).

The shipped ``fresh_felt`` defaults are the goal's chosen map (round 17: blank bearing
``"last"``, bearing over +-30 deg, the rover's own strip by 0.15 m links with regions touching in
the picture, looking to 1.0 m while blank with the distance over ``reach_m``, fresh felt faded
over 0.3 m), so ``kind = "fresh_felt"`` alone is that map. :meth:`FreshFeltConfig.plain` is the
map with every option off (the first rounds' map).

Files written before these defaults (controller schemas 1-4, study files without
``[study] schema``, ``results.json`` schema 1, recordings) stored a memory table that left out
each ``fresh_felt`` option that was off and meant the defaults of the time;
:func:`memory_table_from_v1` turns such a table into a full current one, and
:meth:`MemoryConfig.to_dict` always writes every setting, so nothing written from now on depends
on a default.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import typing
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..core.frame import N_REGIONS
from .branch_side import TURN_FROM as BRANCH_TURN_FROM  # where the side's turn counts from
from .branch_side import WINDOWS as BRANCH_WINDOWS  # which frames the side sums

#: Where the ``fresh_felt`` map's ``strip_link_m`` strip starts (``strip_from``).
STRIP_STARTS = ("axle", "nearest")
#: The ``fresh_felt`` bearing input's widest range [deg]: the whole circle.
FULL_BEARING_RANGE_DEG = 180.0
#: What the ``fresh_felt`` bearing input says while no fresh felt is left (``blank_bearing``).
BLANK_BEARINGS = ("centre", "last")
#: What the ``fresh_felt`` distance input is measured against when ``blank_reach_m`` looked
#: further (``blank_distance``).
BLANK_DISTANCES = ("blank_reach", "reach")
#: Where the ``fresh_felt`` map's camera and motion come from (``geometry``;
#: :mod:`lfd_track.policy.map_geometry`).
MAP_GEOMETRIES = ("world", "paper", "calibrated")
#: How the ``fresh_felt`` map tells felt from carpet in the road values (``felt_levels``).
FELT_LEVELS = ("fixed", "library")
#: How a driving session's frames are colour balanced before the road library reads them
#: (``colour_balance``; :mod:`lfd_track.vision.colour_balance`).
COLOUR_BALANCES = ("none", "safe_box")
#: How the ``fresh_felt`` map moves at each executed command (``motion``;
#: :mod:`lfd_track.policy.odometry`).
MAP_MOTIONS = ("nominal", "visual")
#: How hard ``motion = "visual"`` searches each command's motion (``registration``;
#: :data:`lfd_track.policy.odometry.REGISTRATIONS`).
MAP_REGISTRATIONS = ("full", "quick", "coarse")
#: Where the ``fresh_felt`` map's visited felt is measured from (``visited_from``).
VISITED_FROM = ("path", "strip", "centreline", "path_and_centreline")


def setting(
    default: Any,
    doc: str,
    *,
    low: float | None = None,
    high: float | None = None,
    low_open: bool = False,
    choices: tuple[str, ...] | None = None,
    before: Any = dataclasses.MISSING,
) -> Any:
    """A memory setting: a dataclass field with its ``default``, its one-line ``doc`` (units
    first, as ``[m]``) and its bounds: ``low`` <= value <= ``high`` (``low`` < value with
    ``low_open``) for numbers, one of ``choices`` for strings. ``before`` is the value that
    does what the memory did before the setting existed (default: ``default``): a file written
    before then, which cannot name it, is read with it (:func:`memory_table_from_v1`)."""
    bounds = {"doc": doc, "low": low, "high": high, "low_open": low_open, "choices": choices}
    if before is not dataclasses.MISSING:
        bounds["before"] = before
    return dataclasses.field(default=default, metadata=bounds)


@dataclass(frozen=True)
class SettingSpec:
    """What :func:`setting` declared for one field (read by the checks, the CLI and the docs)."""

    name: str
    """The field's name (the table key)."""
    type: type
    """``int``, ``float``, ``bool`` or ``str``."""
    default: Any
    """The shipped default."""
    doc: str
    """One line: units and meaning."""
    low: float | None = None
    """Smallest value (numbers; None: unbounded)."""
    high: float | None = None
    """Largest value (numbers; None: unbounded)."""
    low_open: bool = False
    """``low`` itself is refused."""
    choices: tuple[str, ...] | None = None
    """The values a string may take."""
    before: Any = None
    """What an older file that does not name the setting meant (see :func:`setting`)."""

    def problem(self, value: Any) -> str | None:
        """Why ``value`` is refused (``"must be ..."``), or None if it is good."""
        if self.type is bool:
            return None if isinstance(value, bool) else f"must be true or false, got {value!r}"
        if self.type is str:
            if self.choices is not None and value not in self.choices:
                return f"must be one of {', '.join(self.choices)}, got {value!r}"
            return None if isinstance(value, str) else f"must be a string, got {value!r}"
        if self.type is int and (isinstance(value, bool) or not isinstance(value, int)):
            return f"must be an integer, got {value!r}"
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            return f"must be a number, got {value!r}"
        low, high = self.low, self.high
        inside = math.isfinite(value)
        if low is not None:
            inside = inside and (value > low if self.low_open else value >= low)
        if high is not None:
            inside = inside and value <= high
        if inside:
            return None
        parts = [] if self.type is int else ["a finite number"]
        parts += [] if low is None else [f"{'>' if self.low_open else '>='} {low:g}"]
        parts += [] if high is None else [f"{'and ' if low is not None else ''}<= {high:g}"]
        return f"must be {' '.join(parts)}, got {value!r}"


@dataclass(frozen=True)
class MemoryConfig:
    """Which memory inputs the policy gets: the base of the kinds' settings (TOML table
    ``[memory]`` of a study condition; :func:`memory_config` picks the kind's class)."""

    settings_name: ClassVar[str] = "memory"
    kind: ClassVar[str] = ""
    """The kind's name (:data:`MEMORY_KINDS`)."""
    n_inputs: ClassVar[int] = 0
    """Inputs the memory adds after the per-region inputs (the 40 road values); an option of a
    kind may add more to a configuration's own (``FreshFeltConfig.branch_side``)."""

    def __post_init__(self) -> None:
        if type(self) is MemoryConfig:
            raise TypeError(
                "MemoryConfig is the base of the memory kinds' settings: use"
                " memory_config({'kind': ...}) or a kind's class (NoMemory(), FreshFeltConfig() ...)"
            )
        for spec in setting_specs(type(self)):
            value = getattr(self, spec.name)
            problem = spec.problem(value)
            if problem:
                raise ValueError(f"memory {spec.name} {problem}")
            if spec.type is float:  # an integer from a file is stored as the number it means
                object.__setattr__(self, spec.name, float(value))
        self._check()

    def _check(self) -> None:
        """Checks across settings (each setting's own bounds are checked already)."""

    def to_dict(self) -> dict[str, Any]:
        """Every setting, with ``kind`` first (JSON- and TOML-friendly; nothing left out)."""
        return {"kind": self.kind, **dataclasses.asdict(self)}

    @classmethod
    def from_dict(cls, data: Any) -> MemoryConfig:
        """Settings as stored in a file (:meth:`to_dict`; a table written before every setting
        was stored is read as it was meant, through :func:`memory_table_from_v1`). Unknown keys
        or bad values raise ``ValueError``."""
        config = memory_config(memory_table_from_v1(data))
        if cls is not MemoryConfig and not isinstance(config, cls):
            raise ValueError(f"memory settings of kind {config.kind!r} are not {cls.__name__}")
        return config

    @property
    def policy_inputs(self) -> int:
        """Inputs of a network with this memory: the 40 road values plus :attr:`n_inputs`."""
        return N_REGIONS + self.n_inputs

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        """Memory inputs (N, m) as they would be in a world flipped left to right."""
        return np.array(inputs, dtype=np.float64)


@dataclass(frozen=True)
class NoMemory(MemoryConfig):
    """``kind = "none"``: no memory inputs (the paper's 40)."""

    kind: ClassVar[str] = "none"
    n_inputs: ClassVar[int] = 0


@dataclass(frozen=True)
class LastBendConfig(MemoryConfig):
    """``kind = "last_bend"``: one input, which way the robot last turned by a whole bend (2 net
    pivots one way, :data:`lfd_track.policy.memory.BEND_PIVOTS`). No settings."""

    kind: ClassVar[str] = "last_bend"
    n_inputs: ClassVar[int] = 1

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        # a left bend becomes a right one and back; "unknown" (0.5) stays
        return 1.0 - np.asarray(inputs, dtype=np.float64)


@dataclass(frozen=True)
class PreviousCommandConfig(MemoryConfig):
    """``kind = "previous_command"``: the one-hot of the command executed at the previous step."""

    kind: ClassVar[str] = "previous_command"
    n_inputs: ClassVar[int] = 3

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        # the previous left becomes a right and back
        return np.asarray(inputs, dtype=np.float64)[:, [0, 2, 1]]


@dataclass(frozen=True)
class FreshFeltConfig(MemoryConfig):
    """``kind = "fresh_felt"``: the dead-reckoned map of felt not yet driven along (three inputs:
    bearing, amount, distance; with ``branch_side`` a fourth, the side felt branched off, and with
    ``branch_turn`` a fifth, the turn toward that side since it was set). The
    defaults are the goal's chosen map (round 17)."""

    kind: ClassVar[str] = "fresh_felt"
    n_inputs: ClassVar[int] = 3

    path_radius_m: float = setting(
        0.35,
        "[m] felt this close to a place the rover has been counts as visited",
        low=0.0,
        high=2.0,
    )
    reach_m: float = setting(
        0.6,
        "[m] fresh felt counts up to this distance from the rover's axle",
        low=0.0,
        high=5.0,
        low_open=True,
    )
    blank_bearing: str = setting(
        "last",
        "the bearing input while no fresh felt is left: centre (0.5) or last (the bearing the"
        " fresh felt last had)",
        choices=BLANK_BEARINGS,
        before="centre",
    )
    bearing_range_deg: float = setting(
        30.0,
        "[deg] the bearing the bearing input maps to 1 (left) and 0 (right), bearings beyond it"
        " clipped (180: the whole circle)",
        low=1.0,
        high=FULL_BEARING_RANGE_DEG,
        before=FULL_BEARING_RANGE_DEG,
    )
    strip_link_m: float = setting(
        0.15,
        "[m] only felt connected along felt to the rover's own strip, by links of at most this"
        " length, is fresh (0: off, any felt may be)",
        low=0.0,
        high=1.0,
        before=0.0,
    )
    strip_from: str = setting(
        "axle",
        "with strip_link_m: the rover's strip starts at the felt within 0.3 m of the axle (axle)"
        " or also at the felt nearest it (nearest; kept: round 14's study sets it, where it lost)",
        choices=STRIP_STARTS,
    )
    strip_picture_links: bool = setting(
        True,
        "with strip_link_m: felt regions that touch in one frame's 8 x 5 grid are linked too",
        before=False,
    )
    blank_reach_m: float = setting(
        1.0,
        "[m] while nothing is fresh within reach_m, look again up to this far (0: off; else"
        " above reach_m)",
        low=0.0,
        high=5.0,
        before=0.0,
    )
    blank_distance: str = setting(
        "reach",
        "with blank_reach_m: the distance input of felt found further, over blank_reach (so 1 is"
        " blank_reach_m away) or over reach (clipped to 1)",
        choices=BLANK_DISTANCES,
        before="blank_reach",
    )
    visited_fade_m: float = setting(
        0.3,
        "[m] fresh felt weighs from 0 at path_radius_m from the rover's path up to full this much"
        " further (0: off, full beyond path_radius_m)",
        low=0.0,
        high=2.0,
        before=0.0,
    )
    fresh_sight_m: float = setting(
        0.0,
        "[m] fresh felt counts only where the straight line from the axle to it crosses no"
        " carpet, read in a raster of the map in cells of this size (0: off; a short leg's next"
        " strip, seen across the carpet inside a sharp corner, no longer draws the rover across)",
        low=0.0,
        high=0.2,
        before=0.0,
    )
    visited_from: str = setting(
        "path",
        "what felt within path_radius_m of counts as visited: path (the places the rover's axle"
        " has been) or strip (those and, after each forward command, the centre of the felt"
        " abeam just behind the axle, so a strip ridden along one edge is visited across its"
        " width; round 31 of the human-taught goal's studies, where it lost) or centreline (only"
        " felt within 0.25 m of those centres, each sought within 0.25 m of the last one's side"
        " offset: the line of the strip it follows, so that a hairpin's outgoing strip beside"
        " it stays fresh; the places themselves where no centre was found; it lost at the sharp"
        " corners) or path_and_centreline (felt within path_radius_m of the places or within"
        " 0.25 m of those centres: the strip's far half visited, its neighbour not hidden)",
        choices=VISITED_FROM,
    )
    geometry: str = setting(
        "world",
        "the camera and per-command motion the map assumes: world (the world it is taught in:"
        " the env's preset, or the robot's profile), paper (the paper's constants: its"
        " camera, 0.10 m, 22.9 deg) or calibrated (the world's camera, the motion a calibration"
        " measures there before teaching; kept: the sweeps study compares it with paper)",
        choices=MAP_GEOMETRIES,
        before="paper",
    )
    felt_levels: str = setting(
        "fixed",
        "what counts as felt: fixed (road values from 0.3, carpet, to 0.5, felt: the paper"
        " world's levels) or library (levels read from the road values the library gave in the"
        " world it runs in, lfd_track.vision.felt_levels)",
        choices=FELT_LEVELS,
    )
    colour_balance: str = setting(
        "none",
        "driving with a finished library: none (frames as the camera gives them) or safe_box"
        " (each camera session's colour gains matched so that the safe box's felt has the"
        " library's felt colour, lfd_track.vision.colour_balance; the road values and the map"
        " read the balanced frames)",
        choices=COLOUR_BALANCES,
    )
    motion: str = setting(
        "nominal",
        "how the map moves at each executed command: nominal (the geometry's forward step or"
        " pivot) or visual (the motion the camera measures between the frames before and after"
        " it, lfd_track.policy.odometry, the nominal one where that is not reliable; kept: the"
        " robustness study rooms_odometry.toml compares it with nominal)",
        choices=MAP_MOTIONS,
    )
    registration: str = setting(
        "full",
        "with motion visual: how hard each command's motion is searched for, full (five"
        " starting turns, 30 iterations per fit) or quick (the nominal turn alone, 15"
        " iterations: a cheaper decision, for the robot's budget on one core) or coarse (as"
        " quick, without the fine fit: cheaper still), lfd_track.policy.odometry; kept: rounds"
        " 28 to 30 of the human-taught goal's studies set it)",
        choices=MAP_REGISTRATIONS,
    )
    branch_side: bool = setting(
        False,
        "a fourth input: the side (1 left, 0 right, 0.5 none) where felt branched off the"
        " rover's strip over its last metre of driving (lfd_track.policy.branch_side)",
    )

    branch_window: str = setting(
        "forward",
        "with branch_side: the frames the side sums, those since the last 10 forward commands"
        " (forward) or those that followed a forward command among the last 10 commands of any"
        " kind (commands: the side expires while the rover only pivots; the human-taught goal's"
        " choice since its round 9); new_felt: as commands, each frame"
        " adding only the branching felt it placed itself, not the whole map's again; heading:"
        " as commands, each frame forgotten once the rover has turned more than 90 degrees"
        " since it saw it; behind: as commands, the side forgotten when the map's fresh felt"
        " lies more than 90 degrees off on the other side; crossed: as commands, the side spent"
        " once a pivot toward it carried the fresh felt across to the other side (these four"
        " are kept because rounds 9-12 of the human-taught goal's studies set them; each lost);"
        " blank: as commands, the side given only while the map has no fresh felt (round 16)",
        choices=BRANCH_WINDOWS,
    )
    branch_turn: bool = setting(
        False,
        "with branch_side: a fifth input, how far the rover has pivoted toward the side since"
        " the side was set (0.5 + turn / 360 degrees, clipped to [0, 1]; 0.5 while no side;"
        " lfd_track.policy.branch_side; the human-taught goal's incumbent since its round 17)",
    )
    branch_turn_from: str = setting(
        "set",
        "with branch_turn: the turn counts from the frame that set the side (set: round 17's"
        " input) or from the newest frame in the side's window that saw felt branch off on that"
        " side (seen: it stays near 0.5 while the rover drives along a curve and grows while it"
        " pivots; kept because round 18 of the human-taught goal's studies sets it, where it"
        " lost)",
        choices=BRANCH_TURN_FROM,
    )

    def __post_init__(self) -> None:
        super().__post_init__()
        # the fourth and fifth inputs are this configuration's own (the kind's class keeps its
        # three)
        object.__setattr__(self, "n_inputs", 3 + self.branch_side + self.branch_turn)

    def _check(self) -> None:
        if self.registration != "full" and self.motion != "visual":
            raise ValueError('memory registration is a setting of motion = "visual"')
        if self.branch_turn and not self.branch_side:
            raise ValueError("memory branch_turn needs branch_side = true (it is the side's turn)")
        if self.branch_turn_from != "set" and not self.branch_turn:
            raise ValueError("memory branch_turn_from is a setting of branch_turn = true")
        if self.blank_reach_m and self.blank_reach_m <= self.reach_m:
            raise ValueError(
                f"memory blank_reach_m must be 0 (off) or above reach_m, got {self.blank_reach_m!r}"
            )

    @classmethod
    def plain(cls, **changes: Any) -> FreshFeltConfig:
        """The map with every option off (the first rounds' map, and the hand-written rule's):
        each setting as it was before it existed (blank bearing centre, the whole circle, no
        strip, no looking further, no fade); then ``changes``."""
        return cls(**{**{spec.name: spec.before for spec in setting_specs(cls)}, **changes})

    def mirror(self, inputs: np.ndarray) -> np.ndarray:
        # the bearing and the branch side change side; amount, distance and the turn toward
        # the side do not
        out = np.array(inputs, dtype=np.float64)
        out[:, 0] = 1.0 - out[:, 0]
        if self.branch_side:
            out[:, 3] = 1.0 - out[:, 3]
        return out


#: Each memory kind's settings class: the one place a kind is registered.
MEMORY_CONFIGS: dict[str, type[MemoryConfig]] = {
    cls.kind: cls for cls in (NoMemory, LastBendConfig, PreviousCommandConfig, FreshFeltConfig)
}
MEMORY_KINDS = tuple(MEMORY_CONFIGS)
"""The memory kinds, in the order the docs list them."""

#: Per kind, the settings removed (no committed study set them), with the only value each one
#: keeps: the constants in :mod:`lfd_track.policy.memory`. An older file may still name them.
REMOVED_SETTINGS: dict[str, dict[str, Any]] = {
    "last_bend": {"bend_pivots": 2},
    "fresh_felt": {
        "frames": 25,
        "carpet": 0.3,
        "felt": 0.5,
        "step_m": 0.10,
        "pivot_deg": 22.9,
        "path_places": "every_command",
    },
}


def setting_specs(cls: type[MemoryConfig]) -> tuple[SettingSpec, ...]:
    """The settings of a kind's class, in field order, as :func:`setting` declared them."""
    return _setting_specs(typing.cast(Any, cls))  # a dataclass's class is hashable


@functools.cache
def _setting_specs(cls: Any) -> tuple[SettingSpec, ...]:
    hints = typing.get_type_hints(cls)
    return tuple(
        SettingSpec(
            name=f.name,
            type=hints[f.name],
            default=f.default,
            **{"before": f.default, **f.metadata},
        )
        for f in dataclasses.fields(cls)
    )


def _kind_of(table: Any) -> tuple[str, type[MemoryConfig]]:
    """The kind ``table`` names (default ``"none"``) and its settings class; ``ValueError`` if
    ``table`` is not a table or names no kind of this build."""
    if not isinstance(table, Mapping):
        raise ValueError(f"memory settings must be a table, got {type(table).__name__}")
    kind = table.get("kind", "none")
    cls = MEMORY_CONFIGS.get(kind) if isinstance(kind, str) else None
    if cls is None:
        raise ValueError(f"memory kind must be one of {', '.join(MEMORY_KINDS)}, got {kind!r}")
    return kind, cls


def memory_config(table: Mapping[str, Any]) -> MemoryConfig:
    """The settings of ``table['kind']`` (default ``"none"``) from the other keys of ``table``
    (missing keys: the shipped defaults). An unknown kind or key or a value out of bounds raises
    ``ValueError`` naming it."""
    kind, cls = _kind_of(table)
    names = {spec.name for spec in setting_specs(cls)}
    unknown = sorted(set(table) - names - {"kind"})
    if unknown:
        known = f" (its settings: {', '.join(sorted(names))})" if names else ""
        raise ValueError(f"unknown memory setting '{unknown[0]}' for kind {kind!r}{known}")
    return cls(**{k: v for k, v in table.items() if k != "kind"})


def memory_table_from_v1(table: Mapping[str, Any]) -> dict[str, Any]:
    """A memory table as written before every setting was stored (``MemoryConfig.to_dict`` of
    controller schemas 1-4, ``results.json`` schema 1, study files without ``[study] schema``:
    each ``fresh_felt`` option left out while off) as a full table of today's settings with
    the same meaning.

    A missing key takes the value that does what the memory did before the setting existed
    (each setting's ``before``: every option off), so this also reads a full table written
    before a setting was added; settings of another kind, which had no effect, are dropped; a
    setting removed since must hold the only value it keeps (:data:`REMOVED_SETTINGS`, else
    ``ValueError``). A full table comes back unchanged. Values are not checked here
    (:func:`memory_config` does).
    """
    kind, cls = _kind_of(table)
    known = {spec.name for c in MEMORY_CONFIGS.values() for spec in setting_specs(c)}
    unknown = sorted(set(table) - known.union(*REMOVED_SETTINGS.values()) - {"kind"})
    if unknown:
        raise ValueError(f"unknown memory setting '{unknown[0]}'")
    for name, value in REMOVED_SETTINGS.get(kind, {}).items():
        if name in table and table[name] != value:
            raise ValueError(
                f"memory {name} = {table[name]!r} is no longer supported (kind {kind!r} has"
                f" {name} = {value!r})"
            )
    return {"kind": kind, **{s.name: table.get(s.name, s.before) for s in setting_specs(cls)}}
