"""Top-down skid-steer model of the tracked rover (paper §4.1: Rover 5 tank chassis).

The rover is one pymunk body in a space without gravity; the floor acts only through the treads.
Each tread is a belt driven by a geared DC motor: the motor pushes the belt towards its commanded
speed with a stiff but finite gain, and the belt can only pass on as much force as its traction
allows. Sideways, each tread resists slip at a few contact points along its length with a
friction that grows linearly with the slip speed up to the Coulomb limit (carpet pile deforms
before it lets go). A pivot turn therefore slips: the tread ends are dragged sideways, so the
rover turns slower than its belts alone would make it. Straight driving drifts a little, because
the two motors are never exactly equal (a per-episode gain drawn at reset) and the carpet grips a
little differently under each command (a per-command slip factor per tread).

Commands are held for one control period. Between commands the rover keeps whatever velocity it
has: when the next command is the same, the motion simply continues (the firmware keeps the
motors on while the host re-sends the command), and when it differs, the motors drive the treads
towards the new speeds, so the deceleration is part of the next command. ``None`` commands zero
tread speed; the Rover 5 gearbox is not back-drivable, so "stop" brakes the rover within a few
centimetres rather than letting it roll.

The belt speeds that each command asks for are calibrated when a Rover is built, so that the
*achieved* forward speed and pivot rate over a short run of commands from rest match
``RoverConfig.forward_speed_mps`` and ``RoverConfig.pivot_rate_radps`` (acceleration transient and
pivot slip included). This module draws nothing on screen: it imports no renderer.

Body frame: x forward, y to the left; world frame: x right, y up seen from above, heading theta
counter-clockwise from +x.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import pymunk

try:  # The C functions pymunk's Body and Space properties call, for the substep loop below.
    from pymunk._chipmunk_cffi import lib as _chipmunk
except ImportError:  # another pymunk layout: the public properties serve
    _chipmunk = None

from .dimensions import ROVER_BODY_WIDTH_M

_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True)
class RoverConfig:
    """Geometry, drive train, floor contact and noise of the tracked rover."""

    body_width_m: float = ROVER_BODY_WIDTH_M  # [m] outer width across both treads
    body_length_m: float = 0.245  # [m] length; the treads run the full length
    mass_kg: float = 1.5  # [kg] chassis, batteries, controller board and phone
    tread_width_m: float = 0.04  # [m] each tread is the outer strip of this width on its side
    forward_speed_mps: float = 0.25  # [m/s] achieved forward speed, after slip and transients
    pivot_rate_radps: float = 1.0  # [rad/s] achieved pivot rate, after slip and transients
    control_period_s: float = 0.4  # [s] how long one command is held
    physics_dt_s: float = 1.0 / 60.0  # [s] physics substep; smaller is smoother and slower
    calibration_commands: int = 3
    """Achieved speeds are matched on average over this many identical commands from rest."""
    drive_gain_npmps: float = 25.0
    """[N s/m] per tread: motor force per m/s of belt speed error (sets the ~0.03 s spin-up)."""
    traction_coeff: float = 0.6  # [-] longitudinal friction coefficient, tread on carpet
    lateral_stiffness_npmps: float = 25.0
    """[N s/m] sideways resistance of all contact points together, below the friction limit."""
    lateral_friction_coeff: float = 0.5  # [-] sideways Coulomb limit, tread on carpet
    contacts_per_tread: int = 3  # contact points along each tread resisting sideways slip
    gravity_mps2: float = 9.81  # [m/s^2] only used for the normal loads of the treads
    motor_asymmetry_std: float = 0.02
    """[fraction] std of each motor's speed gain, drawn per episode (clipped to 3 std)."""
    slip_noise_std: float = 0.03
    """[fraction] std of each tread's speed loss on the carpet, drawn per command (clip 3 std)."""

    def __post_init__(self) -> None:
        positive = (
            "body_width_m",
            "body_length_m",
            "mass_kg",
            "tread_width_m",
            "forward_speed_mps",
            "pivot_rate_radps",
            "control_period_s",
            "physics_dt_s",
            "drive_gain_npmps",
            "traction_coeff",
            "lateral_stiffness_npmps",
            "lateral_friction_coeff",
            "gravity_mps2",
        )
        for name in positive:
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"rover {name} must be a finite number > 0, got {value!r}")
        for name in ("motor_asymmetry_std", "slip_noise_std"):
            value = getattr(self, name)
            if not (isinstance(value, (int, float)) and math.isfinite(value) and 0 <= value < 0.3):
                raise ValueError(f"rover {name} must be in [0, 0.3), got {value!r}")
        for name in ("calibration_commands", "contacts_per_tread"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or not 1 <= value <= 20:
                raise ValueError(f"rover {name} must be an integer in 1..20, got {value!r}")
        if self.tread_width_m * 2 > self.body_width_m:
            raise ValueError(
                f"rover tread_width_m {self.tread_width_m} m: two treads do not fit in "
                f"body_width_m {self.body_width_m} m"
            )
        if self.physics_dt_s > self.control_period_s:
            raise ValueError(
                f"rover physics_dt_s {self.physics_dt_s} s is longer than control_period_s "
                f"{self.control_period_s} s"
            )
        # The tread forces are evaluated from the velocity at the start of each substep
        # (explicit), which rings and then diverges when a substep is longer than the fastest
        # damping time of the body.
        rate = _fastest_damping_rate(self)
        if self.physics_dt_s * rate > 1.0:
            raise ValueError(
                f"rover physics_dt_s {self.physics_dt_s} s is too long for the drive and lateral "
                f"stiffness (fastest damping time {1 / rate:.4f} s); use at most "
                f"{1 / rate:.4f} s or softer gains"
            )

    @property
    def tread_offset_m(self) -> float:
        """Distance from the centre line of the body to the centre line of each tread [m]."""
        return 0.5 * (self.body_width_m - self.tread_width_m)

    @property
    def moment_kgm2(self) -> float:
        """Yaw moment of inertia of the body, taken as a uniform box [kg m^2]."""
        return self.mass_kg * (self.body_width_m**2 + self.body_length_m**2) / 12.0


def _contact_along_m(config: RoverConfig) -> list[float]:
    """Positions of the sideways contact points along a tread, body x [m]."""
    n = config.contacts_per_tread
    if n == 1:
        return [0.0]
    half = 0.5 * config.body_length_m
    return [-half + 2.0 * half * i / (n - 1) for i in range(n)]


def _fastest_damping_rate(config: RoverConfig) -> float:
    """Largest linear/angular damping rate of the tread forces [1/s]."""
    along = _contact_along_m(config)
    b = config.tread_offset_m
    c_pt = config.lateral_stiffness_npmps / (2 * len(along))
    linear = max(2 * config.drive_gain_npmps, config.lateral_stiffness_npmps) / config.mass_kg
    angular_damping = 2 * config.drive_gain_npmps * b * b + 2 * c_pt * sum(x * x for x in along)
    return max(linear, angular_damping / config.moment_kgm2)


def wrap_angle(angle_rad: float) -> float:
    """Wrap an angle to (-pi, pi] [rad]."""
    wrapped = math.remainder(angle_rad, _TWO_PI)
    return math.pi if wrapped == -math.pi else wrapped


class Rover:
    """The tracked rover: a pymunk body pushed around by its two treads.

    Commands: 0 forward, 1 left pivot (left tread back, right tread forward), 2 right pivot,
    ``None`` stop. Call :meth:`reset` before the first :meth:`step`.
    """

    def __init__(self, config: RoverConfig | None = None) -> None:
        self.config = config if config is not None else RoverConfig()
        cfg = self.config
        self._space = pymunk.Space()
        self._space.gravity = (0.0, 0.0)
        self._body = pymunk.Body(cfg.mass_kg, cfg.moment_kgm2)
        self._space.add(self._body)
        self._b = cfg.tread_offset_m
        self._along = _contact_along_m(cfg)
        self._c_pt = cfg.lateral_stiffness_npmps / (2 * len(self._along))
        weight = cfg.mass_kg * cfg.gravity_mps2
        self._traction_n = cfg.traction_coeff * weight / 2.0  # per tread
        self._lateral_limit_n = cfg.lateral_friction_coeff * weight / (2 * len(self._along))
        self._gains = (1.0, 1.0)
        self._tread_points_body: dict[tuple[int, int], np.ndarray] = {}
        # Belt speeds [m/s] per command, found by simulating the noise-free model.
        self._forward_belt_mps = cfg.forward_speed_mps
        self._pivot_belt_mps = cfg.pivot_rate_radps * self._b
        self._forward_belt_mps, self._pivot_belt_mps = self._calibrate()
        self._set_state(0.0, 0.0, 0.0)

    # ---- state --------------------------------------------------------------------------------
    def reset(self, pose: tuple[float, float, float], rng: np.random.Generator) -> None:
        """Place the rover at rest at ``pose`` (x [m], y [m], theta [rad]) and draw motor gains."""
        cfg = self.config
        draw = rng.standard_normal(2)
        draw = np.clip(draw, -3.0, 3.0) * cfg.motor_asymmetry_std
        self._gains = (1.0 + float(draw[0]), 1.0 + float(draw[1]))
        x, y, theta = (float(v) for v in pose)
        self._set_state(x, y, theta)

    def _set_state(self, x: float, y: float, theta: float) -> None:
        body = self._body
        body.position = (x, y)
        body.angle = theta
        body.velocity = (0.0, 0.0)
        body.angular_velocity = 0.0
        body.force = (0.0, 0.0)
        body.torque = 0.0

    @property
    def pose(self) -> np.ndarray:
        """(3,) float64: x [m], y [m], theta [rad] wrapped to (-pi, pi]; the pivot centre."""
        body = self._body
        x, y = body.position
        return np.array([x, y, wrap_angle(body.angle)], dtype=np.float64)

    @property
    def velocity(self) -> np.ndarray:
        """(3,) float64: vx [m/s], vy [m/s], omega [rad/s] in the world frame."""
        body = self._body
        vx, vy = body.velocity
        return np.array([vx, vy, body.angular_velocity], dtype=np.float64)

    @property
    def motor_gains(self) -> tuple[float, float]:
        """This episode's (left, right) motor speed gains (1.0 = nominal)."""
        return self._gains

    @property
    def belt_speeds_mps(self) -> tuple[float, float]:
        """Calibrated nominal belt speeds (forward command, pivot command) [m/s]."""
        return self._forward_belt_mps, self._pivot_belt_mps

    # ---- motion -------------------------------------------------------------------------------
    def step(
        self, command: int | None, rng: np.random.Generator, duration_s: float | None = None
    ) -> None:
        """Hold ``command`` (0 forward, 1 left, 2 right, None stop) for ``duration_s``.

        ``duration_s`` defaults to the control period; it is split into equal substeps no longer
        than ``physics_dt_s``. One slip factor per tread is drawn from ``rng`` per call.
        """
        cfg = self.config
        period = cfg.control_period_s if duration_s is None else float(duration_s)
        if not period > 0:
            raise ValueError(f"duration_s must be > 0, got {duration_s!r}")
        if command is None:
            left = right = 0.0
        else:
            cmd = int(command)
            if cmd == 0:
                left = right = self._forward_belt_mps
            elif cmd == 1:
                left, right = -self._pivot_belt_mps, self._pivot_belt_mps
            elif cmd == 2:
                left, right = self._pivot_belt_mps, -self._pivot_belt_mps
            else:
                raise ValueError(f"unknown command {command!r} (0 forward, 1 left, 2 right, None)")
        slip = cfg.slip_noise_std
        if slip > 0:
            draw = rng.standard_normal(2)
            # A slipping belt passes on less speed, never more than nominal plus noise.
            left *= self._gains[0] * (1.0 + slip * max(-3.0, min(3.0, float(draw[0]))))
            right *= self._gains[1] * (1.0 + slip * max(-3.0, min(3.0, float(draw[1]))))
        else:
            left *= self._gains[0]
            right *= self._gains[1]
        n_sub = max(1, math.ceil(period / cfg.physics_dt_s - 1e-9))
        self._integrate(left, right, period / n_sub, n_sub)

    def _substep_calls(self) -> tuple[Callable[..., Any], ...]:
        """(velocity, angular velocity, angle, set force, set torque, step space) of this rover's
        body and space: the very C calls pymunk's properties and ``Space.step`` make, bound to
        the body and space, without the Python wrappers around them (a quarter of a substep's
        time). Only while the space has nothing pending (bodies to check, additions, removals,
        which the public ``Space.step`` handles around the same call); the public properties
        otherwise, and with a pymunk that lays out its bindings differently."""
        body, space = self._body, self._space
        body_ptr = getattr(body, "_body", None)
        space_ptr = getattr(space, "_space", None)
        pending = (
            getattr(space, "_bodies_to_check", True)
            or getattr(space, "_add_later", True)
            or getattr(space, "_removed_shapes", True)
        )
        if _chipmunk is None or body_ptr is None or space_ptr is None or pending:
            return (
                lambda: body.velocity,
                lambda: body.angular_velocity,
                lambda: body.angle,
                lambda force: setattr(body, "force", force),
                lambda torque: setattr(body, "torque", torque),
                space.step,
            )
        return (
            partial(_chipmunk.cpBodyGetVelocity, body_ptr),
            partial(_chipmunk.cpBodyGetAngularVelocity, body_ptr),
            partial(_chipmunk.cpBodyGetAngle, body_ptr),
            partial(_chipmunk.cpBodySetForce, body_ptr),
            partial(_chipmunk.cpBodySetTorque, body_ptr),
            partial(_chipmunk.cpSpaceStep, space_ptr),
        )

    def _integrate(self, left_mps: float, right_mps: float, dt: float, n_sub: int) -> None:
        """Advance ``n_sub`` substeps of ``dt`` with belt speed targets (left, right) [m/s]."""
        velocity, angular_velocity, angle, set_force, set_torque, step = self._substep_calls()
        b = self._b
        kd = self.config.drive_gain_npmps
        traction = self._traction_n
        c_pt = self._c_pt
        limit = self._lateral_limit_n
        along = self._along
        cos, sin = math.cos, math.sin
        # Factors of the slip resistance below, multiplied once instead of at every point of
        # every substep (``-2.0 * c_pt * u`` is ``(-2.0 * c_pt) * u``: the same number).
        slip_gain = -2.0 * c_pt
        lim = 2.0 * limit
        for _ in range(n_sub):
            v = velocity()
            vx, vy = v.x, v.y
            w = angular_velocity()
            th = angle()
            c, s = cos(th), sin(th)
            v_fwd = vx * c + vy * s
            v_left = -vx * s + vy * c
            # Belt drive at the tread centre lines (left tread at y = +b, right at y = -b).
            f_l = kd * (left_mps - (v_fwd - w * b))
            f_r = kd * (right_mps - (v_fwd + w * b))
            f_l = traction if f_l > traction else (-traction if f_l < -traction else f_l)
            f_r = traction if f_r > traction else (-traction if f_r < -traction else f_r)
            f_fwd = f_l + f_r
            torque = b * (f_r - f_l)
            # Sideways slip resistance at each contact point; both treads' points share body x,
            # so one value per position covers the pair.
            f_side = 0.0
            for x in along:
                f = slip_gain * (v_left + w * x)
                f = lim if f > lim else (-lim if f < -lim else f)
                f_side += f
                torque += x * f
            set_force((f_fwd * c - f_side * s, f_fwd * s + f_side * c))
            set_torque(torque)
            step(dt)

    def _calibrate(self) -> tuple[float, float]:
        """Belt speeds [m/s] giving the configured achieved speeds over a run from rest."""
        cfg = self.config
        n_cmd = cfg.calibration_commands
        period = cfg.control_period_s
        n_sub = max(1, math.ceil(period / cfg.physics_dt_s - 1e-9))
        dt = period / n_sub
        belts = []
        for sign_left, target in ((1.0, cfg.forward_speed_mps), (-1.0, cfg.pivot_rate_radps)):
            belt = target if sign_left > 0 else target * self._b
            for _ in range(8):
                self._set_state(0.0, 0.0, 0.0)
                for _ in range(n_cmd):
                    self._integrate(sign_left * belt, belt, dt, n_sub)
                if sign_left > 0:
                    achieved = float(self._body.position[0]) / (n_cmd * period)
                else:
                    achieved = float(self._body.angle) / (n_cmd * period)
                ratio = target / achieved
                belt *= ratio
                if abs(ratio - 1.0) < 1e-6:
                    break
            belts.append(belt)
        return belts[0], belts[1]

    # ---- footprint ----------------------------------------------------------------------------
    def tread_points(self, n_along: int = 7, n_across: int = 2) -> np.ndarray:
        """World points covering each tread's footprint, edges included.

        Returns (2, n_along * n_across, 2) float64 [m]: index 0 the left tread, 1 the right.
        """
        key = (int(n_along), int(n_across))
        local = self._tread_points_body.get(key)
        if local is None:
            local = self._footprint_body(*key)
            self._tread_points_body[key] = local
        body = self._body
        x, y = body.position
        th = body.angle
        c, s = math.cos(th), math.sin(th)
        rot = np.array([[c, s], [-s, c]])  # row vectors: p_world = p_body @ rot
        return local @ rot + np.array([x, y])

    def _footprint_body(self, n_along: int, n_across: int) -> np.ndarray:
        if n_along < 1 or n_across < 1:
            raise ValueError(f"n_along and n_across must be >= 1, got {n_along}, {n_across}")
        cfg = self.config
        half_len = 0.5 * cfg.body_length_m
        outer = 0.5 * cfg.body_width_m
        inner = outer - cfg.tread_width_m
        xs = np.linspace(-half_len, half_len, n_along) if n_along > 1 else np.zeros(1)
        ys = (
            np.linspace(inner, outer, n_across)
            if n_across > 1
            else np.full(1, 0.5 * (inner + outer))
        )
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        left = np.stack([gx.ravel(), gy.ravel()], axis=1)
        right = left * np.array([1.0, -1.0])
        return np.stack([left, right]).astype(np.float64)
