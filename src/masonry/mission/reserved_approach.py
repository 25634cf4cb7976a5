"""A UAV held back from its task's site waits at an *approach spot* over it, not where it asked from
(``--airspace table``; docs/safety.md, "The approach spot").

A site interval (the paper's conflict rule kept on the time a UAV works at its site, :mod:`masonry.mission.sites`)
starts when the flight down to the site is granted. A UAV the site gate holds back (a conflicting task's UAV is at
its site, or a task it waits on is not done) waited where it asked, at the pallet with its brick or on its pad,
or was sent to its parking spot 6 m over its pad when it was in another waiting UAV's way; once the site freed, the
flight from there (25-40 s) was part of its site interval, and every conflicting task waited through it. Now a UAV
held back farther than :data:`APPROACH_FROM_M` from its site, or about to be sent to its parking spot, first flies
to a hover :data:`APPROACH_OFF_M` from its site towards it, at the top transit layer (:func:`approach_spot`),
reserved as a parking flight is (climb or come down where it is, fly at the spot's altitude, hover there,
open-ended), without the site gate; from there its hop down is planned and gated as any other, and its site
interval starts then.

The spot is beside the site, out of the climbs of the UAV leaving it (a hover over the site was in them: the two
waited for each other until one was sent to its parking spot). It is in the way only of legs at the top layer and
of climbs through it within the air separation of the spot: a UAV waiting
there whose wait does not end by itself and that is in a waiting UAV's way is sent to its parking spot like any
other (:func:`masonry.mission.reserved_parts.to_park`), and is not sent to an approach spot again for that
request. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission.airspace_state import FlightRequest, Grant, Phase
from masonry.mission.reserved_parts import forced
from masonry.mission.volumes import Vec3
from masonry.reservation import (
    Airspace,
    FlightPlan,
    Place,
    Request,
    Reservation,
    Table,
    column,
    earliest_start,
    flight_reservations,
    keeps_inside,
)

if TYPE_CHECKING:
    from masonry.mission.reserved import TableClearance
    from masonry.mission.reserved_requests import TableUav

__all__ = ["APPROACH_FROM_M", "APPROACH_OFF_M", "approach", "approach_spot", "spot_plan", "wants_approach"]

#: A UAV held back from its task's site farther than this (horizontally) waits at the approach spot near it.
APPROACH_FROM_M = 2.0

#: The approach spot is this far from the site (horizontally), towards where the UAV comes from: out of the column
#: over the site and its neighbours' by more than the air separation (1.2 m), so a UAV leaving there climbs past it
#: (docs/safety.md, "The approach spot"; docs/performance/fleet.md, "The approach spot beside the site").
APPROACH_OFF_M = 1.5


def approach_spot(c: TableClearance, site_m: Vec3, start: Vec3) -> Vec3:
    """The approach spot of ``site_m`` for a UAV at ``start``: :data:`APPROACH_OFF_M` from the site towards the
    UAV (horizontally; over the site when the UAV is there), at the top transit layer."""
    dx, dy = start[0] - site_m[0], start[1] - site_m[1]
    d = math.hypot(dx, dy)
    k = APPROACH_OFF_M / d if d > 1e-9 else 0.0
    return (site_m[0] + k * dx, site_m[1] + k * dy, c.airspace.layers_m[-1])


def wants_approach(c: TableClearance, uav: str, u: TableUav, w: FlightRequest, start: Vec3) -> bool:
    """``uav`` (at ``start``) may fly to the approach spot of ``w``'s site: the rule is on, the site is its task's,
    it is far, and it is not at (or sent away from) an approach spot for this request."""
    if c.work_site is None or u.plan is not None or u.approached == w.seq:
        return False
    if u.phase is not Phase.ASKING and not (u.phase is Phase.AT_HOLD and not u.approach):
        return False
    if math.hypot(start[0] - w.site[0], start[1] - w.site[1]) <= APPROACH_FROM_M:
        return False
    return c.work_site(uav, w.site)


def spot_plan(
    table: Table, uav: str, start: Vec3, spot: Vec3, now_s: float, airspace: Airspace
) -> FlightPlan | None:
    """The flight from ``start`` to ``spot`` (up or down to its altitude where the UAV is, over at that altitude),
    ending in a hover there, open-ended, if it fits now (None: not now)."""
    air = Airspace((spot[2],), airspace.cruise_mps, airspace.vertical_mps, airspace.margin_s, 0.0)
    here = Place((start[0], start[1]), start[2], "site")
    there = Place((spot[0], spot[1]), spot[2], "site")
    rs = list(flight_reservations(Request(uav, here, None, there), now_s, spot[2], air))
    rs[-1] = Reservation(uav, column(there.xy, spot[2], spot[2]), rs[-1].t0_s, math.inf, "stay")
    start_s, _ = earliest_start(table, uav, [(r.volume, r.t0_s - now_s, r.t1_s - now_s) for r in rs], now_s)
    inside = keeps_inside(airspace.fence, rs)  # (a spot whose flight leaves the fence is not flown to)
    return FlightPlan(uav, now_s, spot[2], tuple(rs)) if start_s <= now_s and inside else None


def approach(
    c: TableClearance, uav: str, u: TableUav, w: FlightRequest, start: Vec3, now_s: float
) -> Grant | None:
    """Send ``uav`` to the approach spot of ``w``'s site if its flight there fits now (None: it does not, or the
    rule does not apply: the request is planned as before)."""
    if not wants_approach(c, uav, u, w, start):
        return None
    spot = approach_spot(c, w.site, start)
    plan = spot_plan(c.guarded_for(uav), uav, start, spot, now_s, c.airspace)
    if plan is None:
        return None
    c.table = forced(c.table.release(uav, now_s), [], plan.reservations)
    u.phase, u.plan, u.spot, u.site, u.approach, u.approached = Phase.TO_HOLD, plan, spot, w.site, True, w.seq
    u.flown_on, u.down_to, u.lifted = False, None, False
    u.blocked_by = (("-", "approach"),)  # (what it waits for while it flies there: its flight to the spot)
    c.approached_count += 1
    c.bump()
    return Grant(uav, w.site, False, spot, spot[2])
