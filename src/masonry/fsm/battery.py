"""A UAV's battery in seconds of flight: the drain measured in the air, the flight a route takes.

The machines budget their battery in time (docs/state-machines.md, "Battery budget"): a task is taken only if the
flight left above ``battery_low_fraction`` covers the task, a budget of waiting for clearance and the way home
(the mission handler holds it for a swap otherwise); a UAV waiting in the air for clearance gives its task up
while the flight left above ``battery_critical_fraction`` still covers its way home (or the put-back of its brick)
and the waiting it may meet on it. Both need the drain per airborne second (:class:`DrainMeter`) and what a
route of the machine's own legs takes (:func:`route_s`).

Pure: the standard library, :mod:`masonry.timing` and :mod:`masonry.battery_drain` (the legs' durations come
from the caller's navigator).
"""

from __future__ import annotations

import math
from collections.abc import Callable

from masonry.battery_drain import DrainMeter, flight_left_s
from masonry.timing import LEG_SETTLE_S, MIN_JERK_PEAK_TO_MEAN_SPEED

Vec3 = tuple[float, float, float]

#: The autopilot's LAND from the cruise altitude, and the disarm: mean descent speed (m/s) and the touchdown (s).
LAND_SPEED_MPS = 0.5
LAND_TOUCHDOWN_S = 1.0
#: A take-off from the pad to the transit altitude (ArduCopter's auto take-off, about 3 s for 1.2 m).
TAKEOFF_S = 4.0


def route_s(
    leg_s: Callable[[Vec3, Vec3], float],
    layer_speed_mps: float,
    start_m: Vec3,
    end_m: Vec3,
    layer_m: float,
) -> float:
    """What a transit from ``start_m`` to ``end_m`` at the altitude ``layer_m`` takes with no wait: the climb (or
    descent) to the layer, the lateral leg, the descent over the end, each a leg from rest (peak speed
    ``layer_speed_mps`` for the vertical legs, ``leg_s`` for the lateral one), each settled (:data:`LEG_SETTLE_S`).
    """
    total = 0.0
    for dz in (layer_m - start_m[2], layer_m - end_m[2]):
        if abs(dz) > 0.02:
            total += max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(dz) / layer_speed_mps) + LEG_SETTLE_S
    if math.hypot(end_m[0] - start_m[0], end_m[1] - start_m[1]) > 0.02:
        total += leg_s((start_m[0], start_m[1], layer_m), (end_m[0], end_m[1], layer_m)) + LEG_SETTLE_S
    return total


def land_s(altitude_m: float) -> float:
    """The autopilot's landing from ``altitude_m`` above the pad, to the disarm."""
    return max(0.0, altitude_m) / LAND_SPEED_MPS + LAND_TOUCHDOWN_S


__all__ = ["LEG_SETTLE_S", "TAKEOFF_S", "DrainMeter", "flight_left_s", "land_s", "route_s"]
