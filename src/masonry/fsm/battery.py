"""A UAV's battery in seconds of flight: the drain measured in the air, the flight a route takes.

The machines budget their battery in time (docs/state-machines.md, "Battery budget"): a task is taken only if the
flight left above ``battery_low_fraction`` covers the task, a budget of waiting for clearance and the way home
(the mission handler holds it for a swap otherwise); a UAV waiting in the air for clearance gives its task up
while the flight left above ``battery_critical_fraction`` still covers its way home (or the put-back of its brick)
and the waiting it may meet on it. Both need the drain per airborne second (:class:`DrainMeter`) and what a
route of the machine's own legs takes (:func:`route_s`).

Pure: the standard library and :mod:`masonry.timing` (the legs' durations come from the caller's navigator).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

from masonry.timing import MIN_JERK_PEAK_TO_MEAN_SPEED

Vec3 = tuple[float, float, float]

#: Each leg ends with the UAV brought to rest (below ``arrive_speed_mps``, settled before a transit's request):
#: seconds added to a leg's planned duration. On the arducopter vehicle a leg took 1-2 s past its plan.
LEG_SETTLE_S = 1.5
#: The autopilot's LAND from the cruise altitude, and the disarm: mean descent speed (m/s) and the touchdown (s).
LAND_SPEED_MPS = 0.5
LAND_TOUCHDOWN_S = 1.0
#: A take-off from the pad to the transit altitude (ArduCopter's auto take-off, about 3 s for 1.2 m).
TAKEOFF_S = 4.0


@dataclass
class DrainMeter:
    """The battery's drain per airborne second, measured over the pack in use (the previous pack's until this
    one has flown ``min_airborne_s``); None until a pack has.

    A rise of the charge by more than ``step`` between two readings is a fresh pack (a swap); a fall by more (a
    voltage sag, the autopilot's estimate corrected, a test's scripted step) is no drain of the pack's either, it
    is not counted. Seconds on the ground do not count (a landed UAV waiting for its swap, or for a task, draws
    next to nothing).
    """

    min_airborne_s: float = 10.0
    step: float = 0.02
    _drop: float = 0.0
    _airborne_s: float = 0.0
    _last: tuple[float, float] | None = None
    _previous_per_s: float | None = None

    def update(self, now_s: float, fraction: float, airborne: bool) -> None:
        """One reading of the charge (0..1) at ``now_s``; ``airborne``: the UAV flew since the last one."""
        if not math.isfinite(fraction):
            return
        if self._last is not None:
            last_s, last_fraction = self._last
            if fraction > last_fraction + self.step:
                current = self._pack_per_s()
                if current is not None:
                    self._previous_per_s = current
                self._drop, self._airborne_s = 0.0, 0.0
            elif airborne and now_s > last_s and fraction >= last_fraction - self.step:
                self._drop += max(0.0, last_fraction - fraction)
                self._airborne_s += now_s - last_s
        self._last = (now_s, fraction)

    def _pack_per_s(self) -> float | None:
        if self._airborne_s < self.min_airborne_s or self._drop <= 0.0:
            return None
        return self._drop / self._airborne_s

    @property
    def drain_per_s(self) -> float | None:
        """Charge used per airborne second (None: not measured yet)."""
        current = self._pack_per_s()
        return current if current is not None else self._previous_per_s


def flight_left_s(fraction: float, floor_fraction: float, drain_per_s: float) -> float:
    """Seconds of flight from ``fraction`` down to ``floor_fraction`` at ``drain_per_s`` (0 below the floor)."""
    return max(0.0, fraction - floor_fraction) / drain_per_s


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
