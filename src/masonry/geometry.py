"""Small pure geometry helpers shared by the planner, the simulator and perception (ENU world, z up)."""

from __future__ import annotations

import math

Vec3 = tuple[float, float, float]


def wrap_angle_rad(angle_rad: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def rot_z(yaw_rad: float) -> tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]:
    """Rotation matrix about z by ``yaw_rad`` as nested tuples (row major)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return ((c, -s, 0.0), (s, c, 0.0), (0.0, 0.0, 1.0))
