"""The site's fence as a constraint on the table: a space no flight's legs may leave.

:class:`Fence` wraps the blueprint's :class:`~masonry.geofence.Site`: :func:`masonry.reservation.plan_flight` plans
a flight only at layers whose climb, transit, descent and work keep :data:`~masonry.geofence.AIRSPACE_MARGIN_M`
(plus the volume's radius) inside the boundary and under the altitude limit (:meth:`Fence.admits`), so a flight
with a leg outside is never granted; with no such layer ``decide`` says so (``Wait.outside_fence``). Stays, site
intervals and a lost UAV's volume are where a UAV is or must be, not flown: not checked. Pure: floats in, floats out.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

from masonry.geofence import AIRSPACE_MARGIN_M, Site
from masonry.reservation.space import Volume
from masonry.reservation.table import Reservation
from masonry.segments import XY

#: Where a leg comes in from the edge, its depth inside the boundary is checked this often (metres).
STEP_M = 0.05

#: The purposes of the reservations a UAV flies through (the others are where it is: a stay, a site, a lost UAV).
FLOWN = ("climb", "transit", "descend", "work", "home")


@dataclass(frozen=True)
class Fence:
    """The site's boundary and altitude limit, ``margin_m`` inside them."""

    site: Site
    margin_m: float = AIRSPACE_MARGIN_M

    def admits(self, volume: Volume, purpose: str) -> bool:
        """A reservation of ``purpose`` over ``volume`` keeps inside. A climb is where its UAV already is: only its
        top is checked; a lateral leg (``transit``) that starts less than the margin inside (a UAV the wind pushed
        out) heads in (:func:`heads_in`)."""
        if purpose not in FLOWN:
            return True
        if volume.z1_m > self.site.max_altitude_m - self.margin_m + 1e-9:
            return False
        if purpose == "climb":
            return True
        need = self.margin_m + volume.radius_m
        depth = self.site.inside_m(volume.a[0], volume.a[1])
        if depth >= need:
            return self.site.segment_inside(volume.a, volume.b, need)
        return purpose == "transit" and heads_in(self.site, volume.a, volume.b, depth, need)


def keeps_inside(fence: Fence | None, reservations: Iterable[Reservation]) -> bool:
    """Every reservation of ``reservations`` (a flight planned at a chosen altitude, not by ``plan_flight``: a flight
    to a parking or approach spot) keeps inside ``fence`` (None: no fence, True)."""
    return fence is None or all(fence.admits(r.volume, r.purpose) for r in reservations)


def heads_in(site: Site, a: XY, b: XY, depth_m: float, need_m: float) -> bool:
    """The leg ``a -> b`` (``a`` only ``depth_m`` inside) is ``min(need, depth + s)`` inside at every ``s`` metres
    along it: it heads in and never runs along the boundary."""
    length = math.hypot(b[0] - a[0], b[1] - a[1])
    if length < 1e-9:
        return False
    ux, uy = (b[0] - a[0]) / length, (b[1] - a[1]) / length
    s = 0.0
    while s < length:
        s = min(length, s + STEP_M)
        x, y = a[0] + s * ux, a[1] + s * uy
        d = site.inside_m(x, y)
        if d >= need_m:
            return site.segment_inside((x, y), b, need_m)  # in: the rest of it exactly
        if d < min(need_m, depth_m + s) - STEP_M:
            return False
    return False


__all__ = ["FLOWN", "Fence", "heads_in", "keeps_inside"]
