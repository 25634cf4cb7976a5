"""A battery's drain per airborne second and the flight it leaves: shared by the UAV machines' battery budget
(:mod:`masonry.fsm.battery`) and mission control's linger budget (:mod:`masonry.mission.linger`), which measures
each UAV's drain from its heartbeats. Pure: the standard library only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


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


__all__ = ["DrainMeter", "flight_left_s"]
