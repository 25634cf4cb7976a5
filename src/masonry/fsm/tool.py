"""A UAV's tool (the brick effector, the adhesive nozzle): where it sits on the body and where that puts it."""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from masonry.geometry import R_world_body, body_to_world_floats, rot_z
from masonry.ports import Telemetry

Vec3 = tuple[float, float, float]


@dataclass(frozen=True)
class Tool:
    """A tool at ``offset_body_m`` in the body frame (FLU, metres; from the airframe), rotating with the body."""

    offset_body_m: Vec3

    @classmethod
    def at(cls, offset_body_m: Sequence[float]) -> Tool:
        """The tool at ``offset_body_m`` (any three numbers)."""
        return cls((float(offset_body_m[0]), float(offset_body_m[1]), float(offset_body_m[2])))

    def body_target(self, tool_target_m: Sequence[float] | np.ndarray, yaw_rad: float) -> np.ndarray:
        """Body position that puts the tool on ``tool_target_m`` at heading ``yaw_rad`` (level)."""
        return np.asarray(tool_target_m, dtype=float) - rot_z(yaw_rad) @ np.asarray(
            self.offset_body_m, dtype=float
        )

    def position(self, tel: Telemetry) -> np.ndarray:
        """Where the tool is (world ENU), from the telemetry's pose."""
        roll, pitch, yaw = tel.attitude_rad
        return np.asarray(tel.position_m, dtype=float) + R_world_body(roll, pitch, yaw) @ np.asarray(
            self.offset_body_m
        )

    def distance_m(self, tel: Telemetry, target_m: Sequence[float] | np.ndarray) -> float:
        """``|position(tel) - target_m|`` on floats (every tick of a place descent; equal to rounding)."""
        rx, ry, rz = body_to_world_floats(tel.attitude_rad, self.offset_body_m)
        px, py, pz = tel.position_m
        tx, ty, tz = target_m.tolist() if type(target_m) is np.ndarray else target_m
        dx = px + rx - tx
        dy = py + ry - ty
        dz = pz + rz - tz
        return math.sqrt(dx * dx + dy * dy + dz * dz)
