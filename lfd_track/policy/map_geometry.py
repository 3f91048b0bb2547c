"""The fresh-felt map's geometry: the camera that places the regions on the floor, and the motion
of one command.

The ``fresh_felt`` map (:class:`~lfd_track.policy.memory.FreshFeltMemory`) puts each frame's 40
road values on the floor where the regions' centres look, and moves them by the rover's motion
for every executed command. Both depend on the robot: :class:`MapGeometry` holds the camera's
settings the floor points depend on (mount height, pitch, field of view, lens and its
distortion, principal point, forward offset, frame size) and the nominal motion per command (a
forward step [m], a pivot [deg]).

Where a map's geometry comes from:

* ``[memory] geometry = "paper"`` (every file written before the setting existed): the paper's
  constants, :data:`PAPER_GEOMETRY` — the paper preset's camera, 0.10 m per forward command and
  22.9° per pivot — whatever world the robot is in;
* ``geometry = "world"`` (the default): the world the policy is taught in. In simulation that is
  :meth:`MapGeometry.from_preset` of the env's preset: its camera and the motion a calibration
  would measure there (forward speed x control period, pivot rate x control period; the paper
  preset gives 0.10 m and 22.918°). For a preset with ``[randomization]`` it is the preset's
  nominal world (the values its ranges are drawn around are the base tables), since the drawn
  world changes at every episode and is not known before the first one; a room drawn once and
  kept is a preset of its own, whose geometry is then exact. On hardware it is the robot's
  profile where one exists, else :func:`hardware_geometry` (the paper preset's camera and rates
  at the robot's control period).
* ``geometry = "calibrated"``: the world's camera (as ``"world"``) with the motion per command
  that a calibration (:mod:`lfd_track.hardware.calibrate`) measures in the world the policy is
  taught in, before teaching: in simulation on the simulated rover, from a stream of the
  repetition's own (:func:`lfd_track.methods.common.simulated_calibration`); on hardware the
  robot's profile, which is that calibration.

A perception built without a geometry (tests, tools that replay frames) uses
:data:`PAPER_GEOMETRY`. A controller file records the geometry its map was taught with
(:mod:`lfd_track.policy.controller`); driving it in a world whose geometry differs by more than
:data:`TOLERANCES` prints one line (:func:`geometry_note`) and the map keeps the recorded
geometry: the robot's belief about itself, as a real robot would carry it.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np

from ..core.frame import N_REGIONS, region_bounds

if TYPE_CHECKING:
    from ..core.camera_model import CameraConfig

#: What counts as a different geometry (:meth:`MapGeometry.differences`): a forward step or a
#: pivot more than 5 % apart, a camera more than 1 cm higher or lower or further forward, its
#: pitch or vertical field of view more than 1° apart, its principal point more than 5 px apart
#: (full-size pixels), a distortion coefficient more than 0.01 apart, or another lens kind.
TOLERANCES: dict[str, float] = {
    "step_m": 0.05,  # relative
    "pivot_deg": 0.05,  # relative
    "height_m": 0.01,
    "forward_offset_m": 0.01,
    "pitch_deg": 1.0,
    "vfov_deg": 1.0,
    "principal_shift_px": 5.0,
    "distortion": 0.01,
}


class _World(Protocol):
    """What :meth:`MapGeometry.from_preset` reads: a preset (or any object with its tables)."""

    @property
    def camera(self) -> Any: ...

    @property
    def rover(self) -> Any: ...


@dataclass(frozen=True)
class MapGeometry:
    """The camera and per-command motion the ``fresh_felt`` map assumes (see the module
    docstring). The defaults are the paper's constants (:data:`PAPER_GEOMETRY`)."""

    step_m: float = 0.10
    """[m] the rover's advance per forward command."""
    pivot_deg: float = 22.9
    """[deg] the rover's turn per pivot command."""
    height_m: float = 0.31
    """[m] the camera's optical centre above the floor."""
    pitch_deg: float = 30.0
    """[deg] the optical axis below horizontal."""
    vfov_deg: float = 41.0
    """[deg] the vertical field of view of the centred frame."""
    forward_offset_m: float = 0.0
    """[m] the optical centre ahead of the rover's pivot centre."""
    lens: str = "pinhole"
    """The lens projection (``"pinhole"`` or ``"fisheye"``)."""
    distortion: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    """The lens's radial coefficients (k1, k2, k3, k4)."""
    principal_shift_px: float = 0.0
    """[px] the principal point above the image centre (full-size pixels)."""
    width_px: int = 640
    """[px] the full-size frame's width."""
    height_px: int = 480
    """[px] the full-size frame's height."""
    scale: float = 1.0
    """The frames' size relative to the full-size one."""

    def __post_init__(self) -> None:
        for name in ("step_m", "pivot_deg"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ValueError(f"map geometry {name} must be a number, got {value!r}")
        if not (math.isfinite(self.step_m) and 0.0 < self.step_m <= 10.0):
            raise ValueError(f"map geometry step_m must be in (0, 10] m, got {self.step_m!r}")
        if not (math.isfinite(self.pivot_deg) and 0.0 < self.pivot_deg < 180.0):
            raise ValueError(
                f"map geometry pivot_deg must be in (0, 180) deg, got {self.pivot_deg!r}"
            )
        object.__setattr__(self, "step_m", float(self.step_m))
        object.__setattr__(self, "pivot_deg", float(self.pivot_deg))
        object.__setattr__(self, "distortion", tuple(float(k) for k in self.distortion))
        self.camera()  # the camera's own checks (a ValueError names the setting)

    def camera(self) -> CameraConfig:
        """The camera these settings describe (the renderer's settings left at their defaults:
        they do not move a floor point)."""
        from ..core.camera_model import CameraConfig

        return CameraConfig(
            width_px=self.width_px,
            height_px=self.height_px,
            height_m=self.height_m,
            pitch_deg=self.pitch_deg,
            vfov_deg=self.vfov_deg,
            forward_offset_m=self.forward_offset_m,
            lens=self.lens,
            distortion=self.distortion,
            principal_shift_px=self.principal_shift_px,
            scale=self.scale,
        )

    @classmethod
    def from_camera(cls, camera: CameraConfig, step_m: float, pivot_deg: float) -> MapGeometry:
        """The geometry of ``camera`` with the motion ``step_m`` [m] and ``pivot_deg`` [deg]."""
        return cls(
            step_m=step_m,
            pivot_deg=pivot_deg,
            height_m=camera.height_m,
            pitch_deg=camera.pitch_deg,
            vfov_deg=camera.vfov_deg,
            forward_offset_m=camera.forward_offset_m,
            lens=camera.lens,
            distortion=tuple(camera.distortion),  # type: ignore[arg-type]
            principal_shift_px=camera.principal_shift_px,
            width_px=camera.width_px,
            height_px=camera.height_px,
            scale=camera.scale,
        )

    @classmethod
    def from_preset(cls, preset: _World, period_s: float | None = None) -> MapGeometry:
        """The geometry of the world ``preset`` describes (a
        :class:`~lfd_track.envs.presets.Preset`, e.g. an env's ``preset``): its camera, a forward
        step of forward speed x control period and a pivot of pivot rate x control period (the
        nominal motion a calibration would measure there; ``period_s`` replaces the preset's
        control period, for a robot driven at another one)."""
        rover = preset.rover
        period = float(rover.control_period_s if period_s is None else period_s)
        return cls.from_camera(
            preset.camera,
            step_m=float(rover.forward_speed_mps) * period,
            pivot_deg=math.degrees(float(rover.pivot_rate_radps) * period),
        )

    def floor_points(self) -> np.ndarray:
        """(40, 2) float64 floor points [m] (x ahead, y left of the rover's axle) that the
        centres of the 40 regions see with this camera (read-only; computed once per geometry)."""
        return _floor_points(self)

    def to_dict(self) -> dict[str, Any]:
        """Every setting (JSON-friendly: the distortion as a list)."""
        out = dataclasses.asdict(self)
        out["distortion"] = list(self.distortion)
        return out

    @classmethod
    def from_dict(cls, data: Any) -> MapGeometry:
        """The geometry :meth:`to_dict` wrote; a missing or unknown key or a bad value raises
        ``ValueError``."""
        if not isinstance(data, dict):
            raise ValueError(f"map geometry must be an object, got {type(data).__name__}")
        names = [f.name for f in dataclasses.fields(cls)]
        unknown = sorted(set(data) - set(names))
        if unknown:
            raise ValueError(f"unknown map geometry key '{unknown[0]}'")
        missing = [n for n in names if n not in data]
        if missing:
            raise ValueError(f"map geometry is missing '{missing[0]}'")
        distortion = data["distortion"]
        if not isinstance(distortion, list | tuple) or len(distortion) != 4:
            raise ValueError("map geometry distortion must be 4 numbers")
        try:
            return cls(**{**data, "distortion": tuple(distortion)})
        except TypeError as exc:  # e.g. a string where a number belongs
            raise ValueError(f"map geometry: {exc}") from None

    def differences(self, other: MapGeometry) -> list[str]:
        """What differs between this geometry and ``other`` beyond :data:`TOLERANCES`, one
        phrase each (``"pivot 22.9 -> 26.4 deg (+15.2 %)"``); empty when they agree."""
        out = []
        for name, unit in (("step_m", "m"), ("pivot_deg", "deg")):
            mine, theirs = getattr(self, name), getattr(other, name)
            change = theirs / mine - 1.0
            if abs(change) > TOLERANCES[name]:
                out.append(
                    f"{name.split('_')[0]} {mine:.4g} -> {theirs:.4g} {unit} ({100 * change:+.1f} %)"
                )
        for name, unit, label in (
            ("height_m", "m", "camera height"),
            ("forward_offset_m", "m", "camera forward offset"),
            ("pitch_deg", "deg", "pitch"),
            ("vfov_deg", "deg", "vertical field of view"),
            ("principal_shift_px", "px", "principal point shift"),
        ):
            mine, theirs = getattr(self, name), getattr(other, name)
            if abs(theirs - mine) > TOLERANCES[name]:
                out.append(f"{label} {mine:.4g} -> {theirs:.4g} {unit}")
        if self.lens != other.lens:
            out.append(f"lens {self.lens} -> {other.lens}")
        if any(
            abs(a - b) > TOLERANCES["distortion"]
            for a, b in zip(self.distortion, other.distortion, strict=True)
        ):
            out.append(f"distortion {list(self.distortion)} -> {list(other.distortion)}")
        return out

    def describe(self) -> str:
        """A short description: ``"step 0.1 m, pivot 22.9 deg, pinhole camera 0.31 m high,
        pitch 30 deg, vfov 41 deg"``."""
        return (
            f"step {self.step_m:.4g} m, pivot {self.pivot_deg:.4g} deg, {self.lens} camera"
            f" {self.height_m:.4g} m high, pitch {self.pitch_deg:.4g} deg,"
            f" vfov {self.vfov_deg:.4g} deg"
        )


PAPER_GEOMETRY = MapGeometry()
"""The paper's constants: the paper preset's camera (0.31 m high, pitched 30° down, 41° vertical
field of view, pinhole), 0.10 m per forward command and 22.9° per pivot. What every map assumed
before its geometry came from the world (``[memory] geometry = "paper"``)."""


def hardware_geometry(
    profile: MapGeometry | None = None, period_s: float | None = None
) -> MapGeometry:
    """The map geometry of a real robot: its ``profile`` (a calibration's result) where there is
    one, else the paper preset's camera and rates at the robot's control period ``period_s``
    (default the preset's 0.4 s): nothing measured yet, the robot is assumed to be the paper's."""
    if profile is not None:
        return profile
    from ..envs.presets import load_preset  # the preset's data, not the env

    return MapGeometry.from_preset(load_preset("paper"), period_s)


def geometry_note(learned: MapGeometry, world: MapGeometry, differences: list[str]) -> str:
    """The one line that says a controller's map drives in a world of another geometry."""
    return (
        f"lfd-track: note: this controller's map was taught with {learned.describe()} and drives"
        f" where the world has {world.describe()} ({'; '.join(differences)}); the map keeps the"
        " geometry it was taught with"
    )


@functools.lru_cache(maxsize=16)
def _floor_points(geometry: MapGeometry) -> np.ndarray:
    from ..core.camera_model import CameraModel  # the camera's geometry, not its renderer

    camera = geometry.camera()
    width, height = camera.frame_width_px, camera.frame_height_px
    # Pixel centres: a pixel's index is its centre, so a region spanning columns x0..x1-1 is
    # centred on (x0 + x1 - 1) / 2 (the 640 x 480 image's centre column is 319.5).
    bounds = np.array([region_bounds(i, width, height) for i in range(N_REGIONS)], dtype=np.float64)
    centres = (bounds[:, :2] + bounds[:, 2:] - 1.0) / 2.0
    points = CameraModel(camera).floor_points(centres, np.zeros(3))
    points.flags.writeable = False
    return points
