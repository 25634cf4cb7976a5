"""The least separation of two airborne UAVs as mission control heard them: the measure a mission of real autopilots
has (``masonry mission-control``; a simulation's report has the world's true one, ``masonry.sim.world``).

Every UAV reports its position in its heartbeats (about 1 s apart) and progress messages; mission control notes
each on its own clock (mission time). When a UAV reports, each other UAV's last report (heard since this one's
previous) is set against this one's track between its previous report and this, interpolated linearly at that
report's time, where both of this UAV's reports were airborne and at most ``max_gap_s`` apart. So every report of
either UAV of a pair is compared once with the other's track, holding one report per UAV: O(UAVs) a report, memory
O(UAVs). Between two reports a UAV flies a leg about a second long, so the interpolation's error is that leg's
curvature plus the link's latency; the autopilot's own position estimate (GPS: decimetres) comes with it.

Pure: no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from masonry.errors import InvalidArgument

Vec3 = tuple[float, float, float]

#: Two reports of one UAV further apart than this (mission seconds) are not interpolated between (a gap in its
#: link, or a landing and a take-off between them).
MAX_GAP_S = 2.5

__all__ = ["MAX_GAP_S", "HeardSeparation"]


@dataclass(frozen=True)
class _Fix:
    t_s: float
    position_m: Vec3


class HeardSeparation:
    """Each UAV's reported positions, noted as heard; :attr:`min_separation_m` the least airborne distance so far.

    Args:
        max_gap_s: the longest time between two airborne reports of one UAV that are interpolated between.
    """

    def __init__(self, max_gap_s: float = MAX_GAP_S) -> None:
        if not (math.isfinite(max_gap_s) and max_gap_s > 0.0):
            raise InvalidArgument(f"max_gap_s must be a finite number > 0, got {max_gap_s!r}")
        self.max_gap_s = float(max_gap_s)
        self._last: dict[str, _Fix] = {}  #: each airborne UAV's last report (none: on its pad, or not heard)
        self.min_separation_m: float | None = None  #: None until two UAVs were heard airborne at once

    def note(self, uav: str, t_s: float, position_m: Vec3, *, airborne: bool) -> None:
        """``uav`` reported ``position_m`` at mission time ``t_s`` (``airborne``: off its pad)."""
        if not airborne:
            self._last.pop(uav, None)
            return
        fix = _Fix(float(t_s), (float(position_m[0]), float(position_m[1]), float(position_m[2])))
        previous = self._last.get(uav)
        if previous is not None and fix.t_s - previous.t_s > self.max_gap_s:
            previous = None
        for other, last in self._last.items():
            if other == uav:
                continue
            at = _at(previous, fix, last.t_s)
            if at is not None:
                self._lower(math.dist(last.position_m, at))
        self._last[uav] = fix

    def _lower(self, d_m: float) -> None:
        if self.min_separation_m is None or d_m < self.min_separation_m:
            self.min_separation_m = d_m


def _at(previous: _Fix | None, fix: _Fix, t_s: float) -> Vec3 | None:
    """Where a UAV was at ``t_s`` on its track from ``previous`` to ``fix``: interpolated inside it (``fix`` itself
    at its own time); None when ``t_s`` is not on that stretch."""
    if t_s == fix.t_s:
        return fix.position_m
    if previous is None or not (previous.t_s <= t_s <= fix.t_s):
        return None
    span = fix.t_s - previous.t_s
    w = 0.0 if span <= 0.0 else (t_s - previous.t_s) / span
    b, e = previous.position_m, fix.position_m
    return (b[0] + w * (e[0] - b[0]), b[1] + w * (e[1] - b[1]), b[2] + w * (e[2] - b[2]))
