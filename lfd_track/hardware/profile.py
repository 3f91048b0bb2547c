"""A robot profile: the map geometry a calibration measured on one robot, as a JSON file.

``lfd-track hardware calibrate`` (:mod:`lfd_track.hardware.calibrate`) writes it; ``lfd-track
teach --backend hardware``, ``lfd-track hardware drive`` and ``lfd-track hardware demo`` read it
with ``--profile FILE``, and the robot's ``fresh_felt`` map then assumes its geometry
(:func:`~lfd_track.policy.map_geometry.hardware_geometry`) instead of the paper preset's.

The file (schema 1) is one JSON object with the keys:

* ``format``: ``"lfd-track robot profile"``;
* ``schema_version``: ``1``;
* ``control_period_s``: the command length [s] it was measured at (a run at another one prints
  a note: :meth:`RobotProfile.period_note`);
* ``map_geometry``: :meth:`~lfd_track.policy.map_geometry.MapGeometry.to_dict`, whose
  ``step_m`` and ``pivot_deg`` are the measured ones and whose camera is the one the
  calibration assumed (the mount is not measured);
* ``calibration``: what was measured, :class:`Calibration` (``commands_per_run``, the per-command
  value of every run: ``forward_step_m``, ``left_pivot_deg``, ``right_pivot_deg``, and the
  relative spreads ``step_spread`` and ``pivot_spread``).

No date or host is recorded, so the same measurement writes the same bytes. A file that is not
a profile, or holds a missing, unknown or bad value, is refused with one line naming the file
and the problem (:class:`~lfd_track.errors.FileFormatError`).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ..errors import FileFormatError
from ..policy.map_geometry import MapGeometry
from ..utils.atomic import atomic_write_text
from ..utils.files import parse_json_file_text, read_regular_text

PROFILE_FORMAT = "lfd-track robot profile"
PROFILE_SCHEMA = 1
MAX_FILE_BYTES = 1 << 16
"""Largest profile file read (a profile is well under 2 kB)."""


@dataclass(frozen=True)
class Calibration:
    """What a calibration measured: the per-command motion of every run of identical commands.

    Each value is one run's motion divided by its commands (a run starts from rest, as the
    simulator's rates are defined: :class:`~lfd_track.world.rover.RoverConfig`)."""

    commands_per_run: int
    """Identical commands in each run."""
    forward_step_m: tuple[float, ...]
    """[m] the advance per forward command of each forward run."""
    left_pivot_deg: tuple[float, ...]
    """[deg] the turn per left pivot of each left run (counter-clockwise positive)."""
    right_pivot_deg: tuple[float, ...]
    """[deg] the turn per right pivot of each right run (clockwise positive)."""

    def __post_init__(self) -> None:
        runs = self.commands_per_run
        if isinstance(runs, bool) or not isinstance(runs, int) or not 1 <= runs <= 100:
            raise ValueError(
                f"calibration commands_per_run must be an integer in 1..100, got {runs!r}"
            )
        for name in ("forward_step_m", "left_pivot_deg", "right_pivot_deg"):
            values = getattr(self, name)
            if not isinstance(values, list | tuple) or not values:
                raise ValueError(f"calibration {name} must be a non-empty list of numbers")
            for value in values:
                if isinstance(value, bool) or not isinstance(value, int | float):
                    raise ValueError(f"calibration {name} must hold numbers, got {value!r}")
                if not (math.isfinite(value) and value > 0):
                    raise ValueError(
                        f"calibration {name} must hold finite numbers > 0, got {value!r}"
                    )
            object.__setattr__(self, name, tuple(float(v) for v in values))

    @property
    def pivot_samples_deg(self) -> tuple[float, ...]:
        """[deg] every run's pivot per command, left and right runs together."""
        return self.left_pivot_deg + self.right_pivot_deg

    @property
    def step_m(self) -> float:
        """[m] the forward step: the median of the runs'."""
        return _median(self.forward_step_m)

    @property
    def pivot_deg(self) -> float:
        """[deg] the pivot: the median of the left and right runs'."""
        return _median(self.pivot_samples_deg)

    @property
    def step_spread(self) -> float:
        """The runs' forward steps' standard deviation relative to :attr:`step_m` (0 for one run)."""
        return _relative_spread(self.forward_step_m)

    @property
    def pivot_spread(self) -> float:
        """The runs' pivots' standard deviation relative to :attr:`pivot_deg` (0 for one run)."""
        return _relative_spread(self.pivot_samples_deg)

    def to_dict(self) -> dict[str, Any]:
        """The measurement, JSON-friendly (the derived spreads included, for a reader's eye)."""
        return {
            "commands_per_run": self.commands_per_run,
            "forward_step_m": list(self.forward_step_m),
            "left_pivot_deg": list(self.left_pivot_deg),
            "right_pivot_deg": list(self.right_pivot_deg),
            "step_spread": self.step_spread,
            "pivot_spread": self.pivot_spread,
        }

    @classmethod
    def from_dict(cls, data: Any) -> Calibration:
        """The measurement :meth:`to_dict` wrote (the spreads are derived, so not read back);
        a missing or unknown key or a bad value raises ``ValueError``."""
        if not isinstance(data, dict):
            raise ValueError(f"calibration must be an object, got {type(data).__name__}")
        keys = {"commands_per_run", "forward_step_m", "left_pivot_deg", "right_pivot_deg"}
        derived = {"step_spread", "pivot_spread"}
        unknown = sorted(set(data) - keys - derived)
        if unknown:
            raise ValueError(f"unknown calibration key '{unknown[0]}'")
        missing = sorted(keys - set(data))
        if missing:
            raise ValueError(f"calibration is missing '{missing[0]}'")
        return cls(**{key: data[key] for key in keys})


@dataclass(frozen=True)
class RobotProfile:
    """One robot's calibrated map geometry and the measurement behind it."""

    geometry: MapGeometry
    """The map geometry: the measured step and pivot, the camera the calibration assumed."""
    calibration: Calibration
    """What was measured."""
    control_period_s: float
    """[s] the command length it was measured at: the step and pivot are per command of it."""

    def __post_init__(self) -> None:
        period = self.control_period_s
        if isinstance(period, bool) or not isinstance(period, int | float):
            raise ValueError(f"control_period_s must be a number, got {period!r}")
        if not (math.isfinite(period) and 0.0 < period <= 60.0):
            raise ValueError(f"control_period_s must be in (0, 60] s, got {period!r}")
        object.__setattr__(self, "control_period_s", float(period))

    def period_note(self, path: str | Path, period_s: float) -> str | None:
        """One line saying the profile at ``path`` was measured at another command length than
        ``period_s`` [s] (its step and pivot are then not the robot's), None if they agree."""
        if abs(period_s - self.control_period_s) <= 1e-9:
            return None
        return (
            f"lfd-track: note: {path} was calibrated with {self.control_period_s:g} s commands and"
            f" this run's are {period_s:g} s: its step and pivot per command do not hold; run"
            f" `lfd-track hardware calibrate --period {period_s:g}`"
        )

    def to_dict(self) -> dict[str, Any]:
        """The file's JSON object."""
        return {
            "format": PROFILE_FORMAT,
            "schema_version": PROFILE_SCHEMA,
            "control_period_s": self.control_period_s,
            "map_geometry": self.geometry.to_dict(),
            "calibration": self.calibration.to_dict(),
        }

    def save(self, path: str | Path) -> None:
        """Write the profile atomically: a reader sees the old file or the whole new one, and a
        write that fails leaves an existing file as it was."""
        text = json.dumps(self.to_dict(), indent=2, sort_keys=True, allow_nan=False)
        atomic_write_text(path, text + "\n")

    @classmethod
    def from_dict(cls, data: Any) -> RobotProfile:
        """The profile :meth:`to_dict` made; anything else raises ``ValueError``."""
        if not isinstance(data, dict):
            raise ValueError("top level must be a JSON object")
        if data.get("format") != PROFILE_FORMAT:
            raise ValueError(f"not a robot profile ('format' must be '{PROFILE_FORMAT}')")
        version = data.get("schema_version")
        if version != PROFILE_SCHEMA or isinstance(version, bool):
            raise ValueError(
                f"robot profile schema_version {version!r} is not supported (this lfd-track"
                f" reads {PROFILE_SCHEMA})"
            )
        keys = ("control_period_s", "map_geometry", "calibration")
        unknown = sorted(set(data) - {"format", "schema_version", *keys})
        if unknown:
            raise ValueError(f"unknown key '{unknown[0]}'")
        for key in keys:
            if key not in data:
                raise ValueError(f"missing '{key}'")
        return cls(
            geometry=MapGeometry.from_dict(data["map_geometry"]),
            calibration=Calibration.from_dict(data["calibration"]),
            control_period_s=data["control_period_s"],
        )


def load_profile(path: str | Path) -> RobotProfile:
    """Read a robot profile; anything malformed raises ``FileFormatError(path, problem)``."""
    text = read_regular_text(path, MAX_FILE_BYTES, "robot profile")
    data = parse_json_file_text(path, text, "robot profile")
    try:
        return RobotProfile.from_dict(data)
    except (ValueError, TypeError, OverflowError, RecursionError) as exc:
        message = (str(exc) or type(exc).__name__).splitlines()[0]
        raise FileFormatError(path, message) from None


def _median(values: tuple[float, ...]) -> float:
    ordered = sorted(values)
    middle = len(ordered) // 2
    if len(ordered) % 2:
        return ordered[middle]
    return 0.5 * (ordered[middle - 1] + ordered[middle])


def _relative_spread(values: tuple[float, ...]) -> float:
    if len(values) < 2:
        return 0.0
    mean = sum(values) / len(values)
    variance = sum((v - mean) ** 2 for v in values) / (len(values) - 1)
    centre = abs(_median(values))
    return math.sqrt(variance) / centre if centre > 0 else math.inf
