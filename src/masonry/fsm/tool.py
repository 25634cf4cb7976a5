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
    """A tool at ``offset_body_m`` in the body frame (FLU, metres; from the airframe), rotating with the body.

    ``plumb``: the tool hangs from a free joint (the brick UAV's rod on its unlocked ball joint, which is how it
    descends onto a brick or a drop-off): it turns with the heading but not with the tilt. In wind a UAV leans
    into it by 10-20 degrees; a rigid tool 0.45 m below would then be 8-15 cm from a hanging one.
    """

    offset_body_m: Vec3
    plumb: bool = False

    @classmethod
    def at(cls, offset_body_m: Sequence[float], *, plumb: bool = False) -> Tool:
        """The tool at ``offset_body_m`` (any three numbers)."""
        return cls((float(offset_body_m[0]), float(offset_body_m[1]), float(offset_body_m[2])), plumb)

    def _attitude(self, tel: Telemetry) -> Vec3:
        a = tel.attitude_rad
        return (0.0, 0.0, a[2]) if self.plumb else a

    def body_target(
        self,
        tool_target_m: Sequence[float] | np.ndarray,
        yaw_rad: float,
        tilt_rad: tuple[float, float] | None = None,
    ) -> np.ndarray:
        """Body position that puts the tool on ``tool_target_m`` at heading ``yaw_rad``, level or, with
        ``tilt_rad`` (roll, pitch), leaning so (a rigid tool in a steady wind: the lean is held there)."""
        if tilt_rad is None or self.plumb:
            return np.asarray(tool_target_m, dtype=float) - rot_z(yaw_rad) @ np.asarray(
                self.offset_body_m, dtype=float
            )
        return np.asarray(tool_target_m, dtype=float) - np.asarray(
            body_to_world_floats((tilt_rad[0], tilt_rad[1], yaw_rad), self.offset_body_m)
        )

    def position(self, tel: Telemetry) -> np.ndarray:
        """Where the tool is (world ENU), from the telemetry's pose."""
        roll, pitch, yaw = self._attitude(tel)
        return np.asarray(tel.position_m, dtype=float) + R_world_body(roll, pitch, yaw) @ np.asarray(
            self.offset_body_m
        )

    def distance_m(self, tel: Telemetry, target_m: Sequence[float] | np.ndarray) -> float:
        """``|position(tel) - target_m|`` on floats (every tick of a place descent; equal to rounding)."""
        rx, ry, rz = body_to_world_floats(self._attitude(tel), self.offset_body_m)
        px, py, pz = tel.position_m
        tx, ty, tz = target_m.tolist() if type(target_m) is np.ndarray else target_m
        dx = px + rx - tx
        dy = py + ry - ty
        dz = pz + rz - tz
        return math.sqrt(dx * dx + dy * dy + dz * dz)
