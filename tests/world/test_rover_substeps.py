"""The rover's substep loop against the plain loop it was written from: the same poses to the bit
(pure Python float arithmetic, no BLAS)."""

from __future__ import annotations

import math

import numpy as np

from lfd_track.world.rover import Rover, RoverConfig


def _integrate_reference(
    rover: Rover, left_mps: float, right_mps: float, dt: float, n_sub: int
) -> None:
    velocity, angular_velocity, angle, set_force, set_torque, step = rover._substep_calls()
    b, kd = rover._b, rover.config.drive_gain_npmps
    traction, c_pt, limit = rover._traction_n, rover._c_pt, rover._lateral_limit_n
    for _ in range(n_sub):
        v = velocity()
        vx, vy = v.x, v.y
        w = angular_velocity()
        th = angle()
        c, s = math.cos(th), math.sin(th)
        v_fwd = vx * c + vy * s
        v_left = -vx * s + vy * c
        f_l = kd * (left_mps - (v_fwd - w * b))
        f_r = kd * (right_mps - (v_fwd + w * b))
        f_l = traction if f_l > traction else (-traction if f_l < -traction else f_l)
        f_r = traction if f_r > traction else (-traction if f_r < -traction else f_r)
        f_fwd = f_l + f_r
        torque = b * (f_r - f_l)
        f_side = 0.0
        for x in rover._along:
            f = -2.0 * c_pt * (v_left + w * x)
            lim = 2.0 * limit
            f = lim if f > lim else (-lim if f < -lim else f)
            f_side += f
            torque += x * f
        set_force((f_fwd * c - f_side * s, f_fwd * s + f_side * c))
        set_torque(torque)
        step(dt)


def test_substeps_give_the_reference_poses() -> None:
    config = RoverConfig()
    fast, reference = Rover(config), Rover(config)
    reference._integrate = lambda *args: _integrate_reference(reference, *args)  # type: ignore[method-assign]
    commands = np.random.default_rng(3).integers(0, 3, 400)
    rng_fast, rng_reference = np.random.default_rng(9), np.random.default_rng(9)
    fast.reset((0.5, 0.2, 0.3), rng_fast)
    reference.reset((0.5, 0.2, 0.3), rng_reference)
    for command in commands:
        fast.step(int(command), rng_fast)
        reference.step(int(command), rng_reference)
        assert fast.pose.tolist() == reference.pose.tolist()
