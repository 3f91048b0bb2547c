"""Environment presets: world, camera, lighting, physics and randomization settings as data.

A preset is a TOML file in ``envs/`` (or any path) with the tables ``[rover]``, ``[camera]``,
``[sensor]``, ``[appearance]``, ``[lighting]``, ``[episode]`` and ``[randomization]``; missing
tables and keys take the paper defaults of the matching config dataclass.

``[randomization]`` maps ``"<table>.<key>"`` to a ``[low, high]`` range drawn uniformly once per
episode (domain randomization); for tuple-valued keys (colours) low and high are lists of the same
length and each component is drawn independently. Integer keys are rounded.
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ._data import resolve_data_file
from .config import dataclass_from_table, read_toml
from .errors import FileFormatError
from .render.camera import CameraConfig, SensorConfig
from .render.texture import AppearanceConfig, LightingConfig
from .world.episode import EpisodeRules
from .world.rover import RoverConfig

SECTIONS: dict[str, type] = {
    "rover": RoverConfig,
    "camera": CameraConfig,
    "sensor": SensorConfig,
    "appearance": AppearanceConfig,
    "lighting": LightingConfig,
    "episode": EpisodeRules,
}
_TOP_KEYS = {"name", "description", *SECTIONS, "randomization"}


@dataclass(frozen=True)
class Range:
    """A per-episode uniform draw for one config field."""

    section: str
    key: str
    low: tuple[float, ...]
    high: tuple[float, ...]
    is_tuple: bool
    is_int: bool


@dataclass(frozen=True)
class Preset:
    """A complete, validated environment preset."""

    name: str
    source: str
    rover: RoverConfig = RoverConfig()
    camera: CameraConfig = CameraConfig()
    sensor: SensorConfig = SensorConfig()
    appearance: AppearanceConfig = AppearanceConfig()
    lighting: LightingConfig = LightingConfig()
    episode: EpisodeRules = EpisodeRules()
    randomization: tuple[Range, ...] = ()

    @property
    def randomized(self) -> bool:
        """Whether any field is drawn per episode."""
        return bool(self.randomization)

    def sample(self, rng: np.random.Generator) -> Preset:
        """Return a copy with every randomized field drawn from ``rng`` (self if none)."""
        if not self.randomization:
            return self
        updates: dict[str, dict[str, Any]] = {}
        for rng_range in self.randomization:
            low = np.asarray(rng_range.low)
            high = np.asarray(rng_range.high)
            value = rng.uniform(low, high)
            if rng_range.is_int:
                value = np.rint(value).astype(int)
            cast = int if rng_range.is_int else float
            drawn = tuple(cast(v) for v in value) if rng_range.is_tuple else cast(value[0])
            updates.setdefault(rng_range.section, {})[rng_range.key] = drawn
        changes = {
            section: dataclasses.replace(getattr(self, section), **fields)
            for section, fields in updates.items()
        }
        return dataclasses.replace(self, **changes)


def _parse_ranges(table: Any, path: Path) -> tuple[Range, ...]:
    if not isinstance(table, dict):
        raise FileFormatError(path, "[randomization] must be a table")
    ranges = []
    for name, bounds in table.items():
        section, _, key = name.partition(".")
        cls = SECTIONS.get(section)
        if cls is None or key not in {f.name for f in dataclasses.fields(cls)}:
            raise FileFormatError(path, f"randomization key '{name}' names no preset field")
        hint = typing.get_type_hints(cls)[key]
        is_tuple = typing.get_origin(hint) is tuple
        elem = typing.get_args(hint)[0] if is_tuple else hint
        if elem not in (int, float):
            raise FileFormatError(path, f"randomization key '{name}' is not numeric")
        default = getattr(cls(), key)
        width = len(default) if is_tuple else 1
        if not (isinstance(bounds, list) and len(bounds) == 2):
            raise FileFormatError(path, f"randomization '{name}' must be [low, high]")
        lo, hi = bounds
        if not is_tuple:
            lo, hi = [lo], [hi]
        try:
            low = np.asarray(lo, dtype=float)
            high = np.asarray(hi, dtype=float)
        except (TypeError, ValueError):
            raise FileFormatError(path, f"randomization '{name}' bounds must be numbers") from None
        if low.shape != (width,) or high.shape != (width,):
            raise FileFormatError(path, f"randomization '{name}' bounds must have {width} entries")
        if not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise FileFormatError(path, f"randomization '{name}' bounds must be finite")
        if (low > high).any():
            raise FileFormatError(path, f"randomization '{name}' has low > high")
        # Both ends must make a valid config, so a draw never fails mid-episode.
        for end in (low, high):
            val = tuple(elem(v) for v in end) if is_tuple else elem(end[0])
            try:
                dataclasses.replace(cls(), **{key: val})
            except (TypeError, ValueError) as exc:
                raise FileFormatError(path, f"randomization '{name}': {exc}") from None
        ranges.append(Range(section, key, tuple(low), tuple(high), is_tuple, elem is int))
    return tuple(ranges)


def load_preset(name_or_path: str | Path = "paper") -> Preset:
    """Load a shipped preset by name (``"paper"``, ``"randomized"``) or a preset TOML file."""
    path = resolve_data_file("envs", name_or_path)
    data = read_toml(path)
    unknown = sorted(set(data) - _TOP_KEYS)
    if unknown:
        raise FileFormatError(path, f"unknown table or key '{unknown[0]}'")
    kwargs: dict[str, Any] = {
        section: dataclass_from_table(cls, data[section], section, path)
        for section, cls in SECTIONS.items()
        if section in data
    }
    kwargs["randomization"] = _parse_ranges(data.get("randomization", {}), path)
    camera = kwargs.get("camera")
    if camera is not None and (camera.width_px, camera.height_px) != (640, 480):
        raise FileFormatError(
            path,
            f"camera must be 640 x 480 px (the road-value grid is 8 x 5 regions of 80 x 96 px),"
            f" got {camera.width_px} x {camera.height_px}",
        )
    name = data.get("name", path.stem)
    if not isinstance(name, str):
        raise FileFormatError(path, "'name' must be a string")
    return Preset(name=name, source=str(path), **kwargs)
