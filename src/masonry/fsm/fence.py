"""The site's geofence on the UAV: setpoints clamped inside it, and a UAV blown out of it stopped (pure).

The navigator keeps every target and reference position ``SETPOINT_MARGIN_M`` inside the fence
(:func:`clamp_reference`); the model keeps a :class:`FenceWatch` on the telemetry, and its watchdog
(:func:`masonry.fsm.watchdogs.fence_watch`) reacts: a UAV seen more than ``BREACH_MARGIN_M`` outside gives its
task up with the reason (the attempt counts), hovers where the clamped setpoint holds it (inside) and flies home
from there; one still outside ``UavConfig.fence_return_s`` later lands where it is (docs/state-machines.md, "The site's fence").
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from masonry.geofence import BREACH_MARGIN_M, SETPOINT_MARGIN_M, Site


def clamp_reference(site: Site | None, p_m: Any) -> tuple[Any, bool]:
    """``p_m`` moved ``SETPOINT_MARGIN_M`` inside the fence (a float tuple), and whether it had to be."""
    if site is None:
        return p_m, False
    x, y, z = float(p_m[0]), float(p_m[1]), float(p_m[2])
    c = site.clamp_m((x, y, z), SETPOINT_MARGIN_M)
    if c == (x, y, z):
        return p_m, False
    return c, True


class FenceWatch:
    """Whether, and since when, a UAV is outside its fence by more than ``breach_margin_m``.

    Attributes:
        outside_m: how far outside it was at the last look (0 or less: inside).
        since_s: since when it has been outside beyond the margin (None: it is not).
    """

    def __init__(self, site: Site, breach_margin_m: float = BREACH_MARGIN_M) -> None:
        self.site = site
        self.breach_margin_m = float(breach_margin_m)
        self.outside_m = 0.0
        self.since_s: float | None = None

    def observe(self, now_s: float, position_m: Sequence[float]) -> bool:
        """Look at the UAV at ``position_m``: True while it is outside beyond the margin."""
        self.outside_m = self.site.outside_by_m(position_m)
        if self.outside_m <= self.breach_margin_m:
            self.since_s = None
            return False
        if self.since_s is None:
            self.since_s = float(now_s)
        return True

    def out_for_s(self, now_s: float) -> float:
        """How long it has been outside beyond the margin (0: it is not)."""
        return 0.0 if self.since_s is None else float(now_s) - self.since_s


__all__ = ["FenceWatch", "clamp_reference"]
