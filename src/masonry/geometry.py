"""Small pure geometry helpers shared by the state machines, the simulator and the fakes (ENU world, z up)."""

from __future__ import annotations

import math

import numpy as np

Vec3 = tuple[float, float, float]


def wrap_angle_rad(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def rot_z(yaw_rad: float) -> np.ndarray:
    """3x3 rotation about world z by ``yaw_rad``."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def R_world_body(roll_rad: float, pitch_rad: float, yaw_rad: float) -> np.ndarray:
    """Rotation of the FLU body in the ENU world: Rz(yaw) Ry(pitch) Rx(roll)."""
    cr, sr = math.cos(roll_rad), math.sin(roll_rad)
    cp, sp = math.cos(pitch_rad), math.sin(pitch_rad)
    cy, sy = math.cos(yaw_rad), math.sin(yaw_rad)
    return np.array(
        [
            [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
            [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
            [-sp, cp * sr, cp * cr],
        ]
    )


def body_to_world_floats(attitude_rad: Vec3, v_body: Vec3) -> Vec3:
    """``R_world_body(*attitude_rad) @ v_body`` on plain floats (no 3x3 array per call).

    The per-tick form (the tool's distance to its target every tick of a descent): the same products as
    :func:`R_world_body` and a row-by-row dot product, equal to the numpy form to rounding (~1e-16 m);
    ``benchmarks/bench_motion.py`` prints both costs.
    """
    roll, pitch, yaw = attitude_rad
    cr, sr = math.cos(roll), math.sin(roll)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cy, sy = math.cos(yaw), math.sin(yaw)
    ox, oy, oz = v_body
    return (
        cy * cp * ox + (cy * sp * sr - sy * cr) * oy + (cy * sp * cr + sy * sr) * oz,
        sy * cp * ox + (sy * sp * sr + cy * cr) * oy + (sy * sp * cr - cy * sr) * oz,
        -sp * ox + cp * sr * oy + cp * cr * oz,
    )
