"""A UAV waiting at a site in another waiting UAV's way climbs to a hover over it, above every transit layer
(``--airspace table``; docs/safety.md, "The lift spot").

Under the table a UAV whose next hop does not fit now waited where it was: at the site it had just worked (its
work zone, open-ended) or at the pallet with its brick. That stay stood in the descents and climbs of every UAV
working beside it, which then waited for it, and the next ones behind them: on the 12 m wall at 8 + 4, 25 s of
every brick cycle were another UAV's stay, half of them chains of waiting UAVs (docs/performance/fleet.md, "Why
the table is 62.5 % slower"). The columns send such a UAV to a hold point. Now a UAV at rest at a site, told to
wait at least :data:`LIFT_AFTER_S` (or with no end), whose stay the last answer to another UAV's request names in
its way (:func:`masonry.mission.reserved_requests.lift_in_way`, every tick), climbs
straight up to its *lift spot*: a hover over where it is, one layer spacing over the top transit layer
(:func:`lift_spot`), reserved as a parking flight is (climb where it is, hover there, open-ended), when that
flight fits now. Its work zone is free once it has climbed out; from the spot its hop is planned and gated like
any other (from the top layer, its way down to it checked, :func:`masonry.mission.reserved_requests.evaluate`).
A UAV in nobody's way waits where it is: lifting every waiting UAV cost the climb up and down again for nothing
(the bundled pyramid at 2 + 1 +5 %, the 12 m wall at 4 + 2 seed 2 +20 %; docs/performance/fleet.md, "A waiting UAV
in another's way climbs to its lift spot").

The spot is in the way of no hop: every leg, climb and descent of a hop is at or under the top layer, 1.1 m under
it, and the way down from a spot (a parking spot's or a lift spot's) is over the UAV's own pad or its own spot.
It is in the way only of flights to other spots at its altitude and of climbs to a parking spot within the air
separation under it; a UAV waiting there whose wait does not end by itself and that is in a waiting UAV's way is
sent to its parking spot like any other (:func:`masonry.mission.reserved_parts.to_park`). Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission.airspace_state import FlightRequest, Grant, Phase
from masonry.mission.reserved_approach import spot_plan
from masonry.mission.reserved_parts import forced
from masonry.mission.volumes import Vec3

if TYPE_CHECKING:
    from masonry.mission.reserved import TableClearance
    from masonry.mission.reserved_requests import TableUav

__all__ = ["LIFT_AFTER_S", "lift", "lift_spot"]

#: A UAV told to wait at least this long (seconds; or with no end) at a site climbs to its lift spot: a shorter
#: wait ends before the climb up and down again would have paid.
LIFT_AFTER_S = 5.0

#: A UAV this close (horizontally) to its pad waits over it: pads are out of every work zone already.
OVER_PAD_M = 0.3


def lift_spot(c: TableClearance, start: Vec3) -> Vec3:
    """The lift spot of a UAV at ``start``: straight over it, one layer spacing over the top transit layer."""
    return (start[0], start[1], c.airspace.layers_m[-1] + c.spacing_m)


def lift(
    c: TableClearance, uav: str, u: TableUav, w: FlightRequest, start: Vec3, until_s: float, now_s: float
) -> Grant | None:
    """Send ``uav`` (at rest at ``start``, told to wait until ``until_s``) to its lift spot if it waits long enough,
    is low at a site (not over its pad, not at a spot) and its climb there fits now (None: it waits where it is).
    ``c.lifting`` False: never (the parking rule's own scenarios)."""
    if not c.lifting or u.phase is not Phase.ASKING or u.plan is not None or until_s - now_s < LIFT_AFTER_S:
        return None
    spot = lift_spot(c, start)
    home = c.homes.get(uav)
    if start[2] >= c.airspace.layers_m[-1] - 1e-6:
        return None
    if home is not None and math.hypot(start[0] - home[0], start[1] - home[1]) <= OVER_PAD_M:
        return None
    plan = spot_plan(c.guarded_for(uav), uav, start, spot, now_s, c.airspace)
    if plan is None:
        return None
    c.table = forced(c.table.release(uav, now_s), [], plan.reservations)
    u.phase, u.plan, u.spot, u.site, u.approach = Phase.TO_HOLD, plan, spot, w.site, False
    u.flown_on, u.down_to, u.lifted = False, None, True
    c.lifted_count += 1
    c.bump()
    return Grant(uav, w.site, False, spot, spot[2])
