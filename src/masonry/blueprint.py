"""Wall blueprint values (bricks, markers, fleet) and their loading and validation.

The values are frozen; positions are world ENU metres, angles radians.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Literal

Role = Literal["brick", "adhesion"]
ROLES: tuple[str, ...] = ("brick", "adhesion")

DEFAULT_CLEARANCE_M = 1.5
DEFAULT_CRUISE_ALTITUDE_M = 1.2
DEFAULT_BRICK_SIZE_M = (0.30, 0.15, 0.10)


@dataclass(frozen=True)
class MarkerSpec:
    """The two ArUco markers on each brick's top face (brick k carries ids 2k and 2k+1)."""

    dictionary: str = "DICT_4X4_50"
    size_m: float = 0.05
    spacing_m: float = 0.175


@dataclass(frozen=True)
class Brick:
    """One brick of the wall: its blueprint pose, size, and where it waits to be picked up."""

    id: int
    position_m: tuple[float, float, float]
    size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    yaw_rad: float = 0.0
    placed: bool = False
    pickup_m: tuple[float, float, float] | None = None

    @property
    def bottom_z_m(self) -> float:
        return self.position_m[2] - self.size_m[2] / 2.0

    @property
    def top_z_m(self) -> float:
        return self.position_m[2] + self.size_m[2] / 2.0

    @property
    def top_center_m(self) -> tuple[float, float, float]:
        return (self.position_m[0], self.position_m[1], self.top_z_m)

    def footprint_m(self) -> tuple[tuple[float, float], ...]:
        """Corners of the brick's footprint (a rotated rectangle), counter-clockwise."""
        hx, hy = self.size_m[0] / 2.0, self.size_m[1] / 2.0
        c, s = math.cos(self.yaw_rad), math.sin(self.yaw_rad)
        x0, y0 = self.position_m[0], self.position_m[1]
        return tuple(
            (x0 + c * dx - s * dy, y0 + s * dx + c * dy)
            for dx, dy in ((-hx, -hy), (hx, -hy), (hx, hy), (-hx, hy))
        )

    def marker_ids(self) -> tuple[int, int]:
        """The ArUco ids on this brick: 2k (at +spacing/2 on the length axis) and 2k+1 (at -spacing/2)."""
        return (2 * self.id, 2 * self.id + 1)


@dataclass(frozen=True)
class UavSpec:
    """One UAV of the fleet."""

    name: str
    role: Role
    home_m: tuple[float, float, float]


@dataclass(frozen=True)
class Blueprint:
    """A validated wall blueprint."""

    bricks: tuple[Brick, ...]
    fleet: tuple[UavSpec, ...]
    name: str | None = None
    clearance_m: float = DEFAULT_CLEARANCE_M
    cruise_altitude_m: float = DEFAULT_CRUISE_ALTITUDE_M
    brick_size_m: tuple[float, float, float] = DEFAULT_BRICK_SIZE_M
    markers: MarkerSpec = field(default_factory=MarkerSpec)
    source: str = "<blueprint>"

    def brick(self, brick_id: int) -> Brick:
        for b in self.bricks:
            if b.id == brick_id:
                return b
        raise KeyError(brick_id)

    def uavs(self, role: Role) -> tuple[UavSpec, ...]:
        return tuple(u for u in self.fleet if u.role == role)
