"""masonry's world frame (ENU) against a MAVLink autopilot's local frame (NED): :class:`FrameTransform`
(re-exported by :mod:`masonry.adapters.mavlink`, where the flight controller uses it)."""

from __future__ import annotations

import math
from dataclasses import dataclass

from masonry.ports import Vec3

__all__ = ["FrameTransform"]


@dataclass(frozen=True)
class FrameTransform:
    """masonry world ENU <-> autopilot local NED: ``p_world = R_z(yaw_rad) @ enu(p_local) + offset_m``.

    ``offset_m`` is the autopilot's local origin expressed in the world frame, ``yaw_rad`` the rotation of the
    autopilot's local ENU axes (east, north, up from its NED) about world z. The identity (the default) fits a
    motion-capture setup whose poses are fed to the autopilot in the world frame.
    """

    offset_m: Vec3 = (0.0, 0.0, 0.0)
    yaw_rad: float = 0.0

    def _rotate(self, x: float, y: float, angle: float) -> tuple[float, float]:
        c, s = math.cos(angle), math.sin(angle)
        return (c * x - s * y, s * x + c * y)

    def position_to_world(self, p_ned: Vec3) -> Vec3:
        """A local NED position (m) as a world ENU position (m)."""
        east, north, up = p_ned[1], p_ned[0], -p_ned[2]
        x, y = self._rotate(east, north, self.yaw_rad)
        return (x + self.offset_m[0], y + self.offset_m[1], up + self.offset_m[2])

    def position_to_ned(self, p_world: Vec3) -> Vec3:
        """A world ENU position (m) as a local NED position (m)."""
        x, y = self._rotate(p_world[0] - self.offset_m[0], p_world[1] - self.offset_m[1], -self.yaw_rad)
        return (y, x, -(p_world[2] - self.offset_m[2]))

    def velocity_to_world(self, v_ned: Vec3) -> Vec3:
        """A local NED velocity (m/s) as a world ENU velocity (m/s)."""
        x, y = self._rotate(v_ned[1], v_ned[0], self.yaw_rad)
        return (x, y, -v_ned[2])

    def velocity_to_ned(self, v_world: Vec3) -> Vec3:
        """A world ENU velocity (m/s) as a local NED velocity (m/s)."""
        x, y = self._rotate(v_world[0], v_world[1], -self.yaw_rad)
        return (y, x, -v_world[2])

    def attitude_to_world(self, roll_rad: float, pitch_rad: float, yaw_ned_rad: float) -> Vec3:
        """FRD roll/pitch/yaw in NED as FLU roll/pitch and yaw about world +z from world +x."""
        return (roll_rad, -pitch_rad, _wrap(math.pi / 2.0 - yaw_ned_rad + self.yaw_rad))

    def attitude_to_ned(self, roll_rad: float, pitch_rad: float, yaw_world_rad: float) -> Vec3:
        """World FLU roll/pitch/yaw as FRD roll/pitch and yaw in the autopilot's NED frame."""
        return (roll_rad, -pitch_rad, _wrap(math.pi / 2.0 - yaw_world_rad + self.yaw_rad))

    @staticmethod
    def yaw_rate_to_ned(yaw_rate_radps: float) -> float:
        """Yaw rate about +z up (ENU) as yaw rate about +z down (NED)."""
        return -yaw_rate_radps

    @staticmethod
    def yaw_rate_to_world(yaw_rate_ned_radps: float) -> float:
        return -yaw_rate_ned_radps


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi
