"""Environment presets: world, camera, lighting, physics and randomization settings as data.

A preset is a TOML file in ``envs/`` (or any path) with the tables ``[rover]``, ``[camera]``,
``[sensor]``, ``[appearance]``, ``[lighting]``, ``[episode]`` and ``[randomization]``; missing
tables and keys take the paper defaults of the matching config dataclass.

``[randomization]`` maps ``"<table>.<key>"`` to a ``[low, high]`` range drawn uniformly once per
episode (domain randomization); for tuple-valued keys (colours) low and high are lists of the same
length and each component is drawn independently. Integer keys are rounded.

Every numeric value, and both ends of every range, must lie within :data:`BOUNDS` (physically
meaningful limits, listed with their reasons in ``envs/README.md``), and the step's physics must
stay affordable (at most :data:`MAX_SUBSTEPS_PER_COMMAND` physics substeps per command). The
randomization ranges are checked *jointly*: every corner of the box of drawn values in a table
(each field at its low or high end) must make a valid config, so a draw can never fail
mid-episode (the config checks are monotone in each field, so the corners bound every draw).
"""

from __future__ import annotations

import dataclasses
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from ..core.camera_model import CameraConfig
from ..core.config import dataclass_from_table, read_toml
from ..core.frame import GRID_COLUMNS, GRID_ROWS, grid_fits
from ..errors import FileFormatError
from ..render.camera import SensorConfig
from ..render.texture import AppearanceConfig, LightingConfig
from ..utils.data import resolve_data_file
from ..world.episode import EpisodeRules
from ..world.rover import RoverConfig

SECTIONS: dict[str, type] = {
    "rover": RoverConfig,
    "camera": CameraConfig,
    "sensor": SensorConfig,
    "appearance": AppearanceConfig,
    "lighting": LightingConfig,
    "episode": EpisodeRules,
}
_TOP_KEYS = {"name", "description", *SECTIONS, "randomization"}
MAX_FILE_BYTES = 1 << 20
"""Largest preset file read."""
MAX_SUBSTEPS_PER_COMMAND = 1000
"""Most physics substeps one command may take (control_period_s / physics_dt_s)."""

BOUNDS: dict[str, tuple[float, float]] = {
    # [rover] a small tracked rover on a floor
    "rover.body_width_m": (0.05, 1.0),
    "rover.body_length_m": (0.05, 1.0),
    "rover.mass_kg": (0.1, 50.0),
    "rover.tread_width_m": (0.005, 0.5),
    "rover.forward_speed_mps": (0.01, 2.0),
    "rover.pivot_rate_radps": (0.05, 10.0),
    "rover.control_period_s": (0.02, 5.0),
    "rover.physics_dt_s": (0.001, 0.05),
    "rover.calibration_commands": (1, 20),
    "rover.drive_gain_npmps": (0.1, 10_000.0),
    "rover.traction_coeff": (0.01, 3.0),
    "rover.lateral_stiffness_npmps": (0.1, 10_000.0),
    "rover.lateral_friction_coeff": (0.01, 3.0),
    "rover.contacts_per_tread": (1, 20),
    "rover.gravity_mps2": (1.0, 30.0),
    "rover.motor_asymmetry_std": (0.0, 0.3),
    "rover.slip_noise_std": (0.0, 0.3),
    # [camera] a phone on a mast
    "camera.width_px": (640, 640),
    "camera.height_px": (480, 480),
    # Frames of width_px x height_px times scale (0.5: 320 x 240 of the same view); not drawn per
    # episode (the observation's shape is fixed).
    "camera.scale": (0.125, 1.0),
    "camera.height_m": (0.05, 2.0),
    # Pitch may tilt up when the frame is shifted below the lens axis; the camera model itself
    # refuses any combination that shows the horizon.
    "camera.pitch_deg": (-89.0, 89.0),
    "camera.vfov_deg": (10.0, 120.0),
    "camera.forward_offset_m": (-0.5, 0.5),
    "camera.distortion": (-2.0, 2.0),
    "camera.principal_shift_px": (-1920.0, 1920.0),
    # [sensor] a phone camera's processing
    "sensor.exposure_target": (10.0, 245.0),
    "sensor.exposure_lag_frames": (0.0, 100.0),
    "sensor.exposure_min_gain": (0.01, 10.0),
    "sensor.exposure_max_gain": (0.01, 100.0),
    "sensor.white_balance_cast": (0.0, 0.5),
    "sensor.white_balance_jitter": (0.0, 0.5),
    "sensor.white_balance_pool": (1, 64),
    "sensor.highlight_knee": (0.01, 1.0),
    "sensor.noise_std": (0.0, 64.0),
    "sensor.noise_pool_frames": (1, 32),
    "sensor.vignetting": (0.0, 0.99),
    "sensor.motion_blur_fraction": (0.0, 1.0),
    "sensor.jpeg_quality": (0, 100),
    # [appearance] felt and carpet
    "appearance.felt_rgb": (0, 255),
    "appearance.carpet_rgb": (0, 255),
    "appearance.metres_per_px": (0.0005, 0.002),
    "appearance.margin_m": (0.5, 5.0),
    "appearance.carpet_pile_strength": (0.0, 1.0),
    "appearance.carpet_pile_scale_m": (0.001, 1.0),
    "appearance.carpet_fleck_strength": (0.0, 1.0),
    "appearance.carpet_patchiness": (0.0, 1.0),
    "appearance.felt_fibre_strength": (0.0, 1.0),
    "appearance.felt_fibre_length_m": (0.001, 1.0),
    "appearance.felt_nonuniformity": (0.0, 1.0),
    "appearance.felt_tint_variation": (0.0, 1.0),
    "appearance.felt_nonuniformity_scale_m": (0.001, 10.0),
    "appearance.edge_fuzz_m": (0.0, 0.05),
    # [lighting] a room's lamps and shadows
    "lighting.ambient": (0.05, 2.0),
    "lighting.pool_count": (0, 20),
    "lighting.pool_radius_m": (0.05, 10.0),
    "lighting.pool_strength": (0.0, 2.0),
    "lighting.max_illumination": (0.1, 4.0),
    "lighting.shadow_count": (0, 20),
    "lighting.shadow_width_m": (0.01, 5.0),
    "lighting.shadow_darkness": (0.0, 0.99),
    "lighting.shadow_softness_m": (0.001, 2.0),
    "lighting.shadow_min_crossing_deg": (0.0, 90.0),
    "lighting.grid_m": (0.005, 0.5),
    # [episode] margins of the success and failure rules
    "episode.corner_margin_m": (0.05, 2.0),
    "episode.reverse_margin_m": (0.05, 5.0),
    "episode.end_margin_m": (0.05, 2.0),
    "episode.start_offset_m": (0.0, 2.0),
}
"""Inclusive [low, high] of every numeric preset value (for colours: of each component)."""


def _bounds_problem(section: str, config: Any) -> str:
    """First value of ``config`` outside :data:`BOUNDS`, or a joint limit it breaks; else ""."""
    for f in dataclasses.fields(config):
        name = f"{section}.{f.name}"
        if name not in BOUNDS:
            continue
        low, high = BOUNDS[name]
        value = getattr(config, f.name)
        for v in value if isinstance(value, tuple) else (value,):
            if not low <= v <= high:
                return f"'{name}' = {value!r} is outside [{low:g}, {high:g}]"
    if section == "rover":
        substeps = config.control_period_s / config.physics_dt_s
        if substeps > MAX_SUBSTEPS_PER_COMMAND:
            return (
                f"rover.control_period_s / rover.physics_dt_s = {substeps:.0f} physics substeps per"
                f" command, more than {MAX_SUBSTEPS_PER_COMMAND}"
            )
    return ""


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
        if name == "camera.scale":
            raise FileFormatError(
                path, "randomization cannot draw camera.scale (every frame of an env has one size)"
            )
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
        except (TypeError, ValueError, OverflowError):
            raise FileFormatError(path, f"randomization '{name}' bounds must be numbers") from None
        if low.shape != (width,) or high.shape != (width,):
            raise FileFormatError(path, f"randomization '{name}' bounds must have {width} entries")
        if not (np.isfinite(low).all() and np.isfinite(high).all()):
            raise FileFormatError(path, f"randomization '{name}' bounds must be finite")
        if (low > high).any():
            raise FileFormatError(path, f"randomization '{name}' has low > high")
        bound_low, bound_high = BOUNDS[name]
        if low.min() < bound_low or high.max() > bound_high:
            raise FileFormatError(
                path,
                f"randomization '{name}' = [{_plain(lo)}, {_plain(hi)}] reaches outside"
                f" [{bound_low:g}, {bound_high:g}]",
            )
        ranges.append(Range(section, key, tuple(low), tuple(high), is_tuple, elem is int))
    return tuple(ranges)


def _plain(value: Any) -> str:
    return str(value).replace("'", "")


def _check_ranges_jointly(preset: Preset, path: Path) -> None:
    """Every corner of each table's box of drawn values must make a valid config."""
    by_section: dict[str, list[tuple[Range, int]]] = {}
    for r in preset.randomization:
        for component in range(len(r.low)):
            by_section.setdefault(r.section, []).append((r, component))
    for section, axes in by_section.items():
        if len(axes) > 16:  # 65536 corners: refuse rather than hang
            raise FileFormatError(
                path, f"[randomization] draws {len(axes)} values of [{section}] (at most 16)"
            )
        base = getattr(preset, section)
        for corner in range(1 << len(axes)):
            values: dict[str, list[float]] = {}
            for bit, (r, component) in enumerate(axes):
                current = values.setdefault(r.key, list(r.low))
                current[component] = r.high[component] if corner >> bit & 1 else r.low[component]
            fields: dict[str, Any] = {}
            for r, _ in axes:
                cast = int if r.is_int else float
                drawn = [cast(round(v)) if r.is_int else cast(v) for v in values[r.key]]
                fields[r.key] = tuple(drawn) if r.is_tuple else drawn[0]
            try:
                config = dataclasses.replace(base, **fields)
            except (TypeError, ValueError) as exc:
                shown = ", ".join(f"{section}.{k} = {_plain(v)}" for k, v in fields.items())
                raise FileFormatError(
                    path, f"randomization can draw {shown}, which is invalid: {exc}"
                ) from None
            problem = _bounds_problem(section, config)
            if problem:
                raise FileFormatError(path, f"randomization can draw {problem}")


def load_preset(name_or_path: str | Path = "paper") -> Preset:
    """Load a shipped preset by name (``"paper"``, ``"randomized"``) or a preset TOML file."""
    path = resolve_data_file("envs", name_or_path)
    data = read_toml(path, max_bytes=MAX_FILE_BYTES, what="preset")
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
            f"camera must be 640 x 480 px (the road-value grid is 8 x 5 regions of 80 x 96 px;"
            f" [camera] scale takes smaller frames of the same view),"
            f" got {camera.width_px} x {camera.height_px}",
        )
    if camera is not None and not grid_fits(camera.frame_width_px, camera.frame_height_px):
        raise FileFormatError(
            path,
            f"camera scale {camera.scale} makes {camera.frame_width_px} x"
            f" {camera.frame_height_px} px frames, which the road-value grid of"
            f" {GRID_COLUMNS} x {GRID_ROWS} regions does not divide evenly",
        )
    for section in SECTIONS:
        problem = _bounds_problem(section, kwargs.get(section, SECTIONS[section]()))
        if problem:
            raise FileFormatError(path, problem)
    name = data.get("name", path.stem)
    if not isinstance(name, str):
        raise FileFormatError(path, "'name' must be a string")
    if not isinstance(data.get("description", ""), str):
        raise FileFormatError(path, "'description' must be a string")
    preset = Preset(name=name, source=str(path), **kwargs)
    _check_ranges_jointly(preset, path)
    return preset
