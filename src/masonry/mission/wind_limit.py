"""Mission control's wind limit: above a UAV's ``max_wind_mps`` it gets no task; the mission resumes below it.

A UAV flying a task when the wind rises finishes that task (a brick in the air is better placed than carried
home; a task's remaining steps are a minute or two), then, with nothing assigned, flies home and lands as any
idle UAV does. Once the reading is back at or below the limit less ``resume_margin_mps`` (so a wind hovering at
the limit does not start and stop the fleet every tick), dispatch goes on.

The reading is the mean wind at 10 m, in the units of ``--wind`` and of a forecast: the simulated site's
(:meth:`masonry.sim.wind.WindConfig.speed_at`) in ``masonry sim``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Protocol

from masonry.blueprint import UavSpec
from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.blueprint import UavSpec

__all__ = ["DEFAULT_MAX_WIND_MPS", "HeardWind", "SiteWind", "WindLimit", "site_wind_limit"]

#: A 4.5 kg hexacopter (docs/simulator.md, "Wind"): its 30 degree tilt runs out at 8.8 m/s of airspeed (11 m/s
#: mean at 10 m); at 8 m/s (6.4 m/s at its 2 m working height) it keeps 1.8 m/s^2 to manoeuvre and 2.4 m/s of
#: airspeed for gusts; manufacturers rate airframes of this class at 8-10 m/s.
DEFAULT_MAX_WIND_MPS = 8.0


@dataclass
class WindLimit:
    """Which UAVs the wind grounds now.

    Args:
        limits_mps: each UAV's ``max_wind_mps``.
        reading: the wind now (m/s, mean at 10 m) at mission time ``t_s``; None: unknown (nothing grounded).
        resume_margin_mps: a grounded UAV flies again at or below its limit less this.
    """

    limits_mps: Mapping[str, float]
    reading: Callable[[float], float | None]
    resume_margin_mps: float = 0.5
    grounded: set[str] = field(default_factory=set)
    speed_mps: float | None = None
    version: int = 0

    def __post_init__(self) -> None:
        for name, limit in self.limits_mps.items():
            if not (isinstance(limit, (int, float)) and math.isfinite(limit) and 0.0 < limit <= 30.0):
                raise InputError(f"max_wind_mps of {name}: must be > 0 and at most 30 m/s, got {limit!r}")

    def update(self, now_s: float) -> bool:
        """Read the wind; True when the set of grounded UAVs changed."""
        speed = self.reading(now_s)
        self.speed_mps = speed
        if speed is None:
            now = set()
        else:
            now = {
                name
                for name, limit in self.limits_mps.items()
                if speed > limit or (name in self.grounded and speed > limit - self.resume_margin_mps)
            }
        if now == self.grounded:
            return False
        self.grounded = now
        self.version += 1
        return True

    def allows(self, name: str) -> bool:
        """``name`` may be given a task."""
        return name not in self.grounded


#: A UAV's wind report older than this no longer counts (its heartbeats stopped, or stopped saying it).
HEARD_WIND_FRESH_S = 10.0


@dataclass
class HeardWind:
    """The wind as the UAVs' heartbeats report it (distributed missions: each autopilot's WIND message) and each
    UAV's ``max_wind_mps`` (its uav.yaml): a :class:`WindLimit`'s ``limits_mps`` and ``reading``.

    The reading is the strongest fresh report: the site's wind, as its most exposed UAV feels it.
    """

    limits_mps: dict[str, float] = field(default_factory=dict)
    reports: dict[str, tuple[float, float]] = field(default_factory=dict)  # name -> (heard at s, wind m/s)

    def heard(self, name: str, now_s: float, wind_mps: float | None, max_wind_mps: float | None) -> None:
        if max_wind_mps is not None:
            self.limits_mps[name] = float(max_wind_mps)
        if wind_mps is not None:
            self.reports[name] = (now_s, float(wind_mps))

    def reading(self, now_s: float) -> float | None:
        fresh = [w for t, w in self.reports.values() if now_s - t <= HEARD_WIND_FRESH_S]
        return max(fresh) if fresh else None

    def limit(self) -> WindLimit:
        """The mission's wind limit over these reports (its limits follow them as UAVs report theirs)."""
        return WindLimit(self.limits_mps, self.reading)


class SiteWind(Protocol):
    """A site's wind as the limit reads it (:class:`masonry.sim.wind.WindConfig` in ``masonry sim``)."""

    @property
    def calm(self) -> bool:
        """No wind at all: nothing to limit."""

    def speed_at(self, t_s: float) -> float:
        """The mean wind at 10 m at time ``t_s``, m/s."""


def site_wind_limit(
    site_wind: SiteWind, fleet: Sequence[UavSpec], max_wind_mps: float | Mapping[str, float] | None
) -> WindLimit | None:
    """Mission control's wind limit for a simulated site (None in still air): each UAV's ``max_wind_mps`` (one
    figure for all, or per name; default :data:`DEFAULT_MAX_WIND_MPS`) against the site's mean wind at 10 m."""
    if site_wind.calm:
        return None
    if isinstance(max_wind_mps, Mapping):
        limits = {u.name: float(max_wind_mps.get(u.name, DEFAULT_MAX_WIND_MPS)) for u in fleet}
    else:
        limit = DEFAULT_MAX_WIND_MPS if max_wind_mps is None else float(max_wind_mps)
        limits = {u.name: limit for u in fleet}
    return WindLimit(limits, site_wind.speed_at)
