"""A held UAV closes in on its site while the UAV it waits for leaves (issue 27): the hand-over, planned ahead.

Part of :class:`~masonry.mission.airspace.ColumnClearance` (docs/safety.md, "The approach during a hand-over").
A UAV hovering at its hold point (``AT_HOLD``) whose flight does not fit yet is given a nearer hold point on its
straight line to its site, once one is admissible: the hover there and the leg to it clear every other UAV's
volumes (the separation, as every reserved volume), and the point keeps the hold points' distance from every
other UAV's zone, flight site, requested site, hold point, climb and pad (:func:`hold_candidates`' keep-out),
except from the one site it waits for. As the leaving UAV reports progress its volumes shrink behind it, and
the waiting one is let nearer, step by step: when its flight is granted it has less to fly. Only while at most
one other UAV is in the air (the one it waits for: :func:`~masonry.mission.airspace_requests.hold_side`), as the
hold point on the UAV's side. Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.geofence import AIRSPACE_MARGIN_M
from masonry.mission.airspace_state import OFF_LAYER, Grant, HoldFlight, Phase, UavAirspace, hold_keep_out
from masonry.mission.volumes import flight_volumes, point_segment_m

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["APPROACH_GAIN_M", "APPROACH_STEP_M", "approach"]

#: A nearer hold point is given only if it is at least this much nearer the site: each one is a leg flown from
#: rest to rest, and a shorter one costs more time in its start and stop than it saves.
APPROACH_GAIN_M = 0.3

#: The points tried along the line to the site, this far apart (from the site outwards).
APPROACH_STEP_M = 0.1


def approach(c: ColumnClearance, uav: str, u: UavAirspace) -> Grant | None:
    """A hold flight from ``uav``'s hold point to the nearest admissible point on its line to its site, at least
    ``APPROACH_GAIN_M`` nearer (None: none, or more than one other UAV is in the air).

    ``uav`` hovers at its hold point (``AT_HOLD``) and its flight does not fit. The new hold flight is taken as
    any hold flight is (its volumes reserved, ``TO_HOLD``); the UAV flies it from rest at its hold point.
    """
    w, h = u.request, u.hold
    if (
        w is None
        or h is None
        or u.phase is not Phase.AT_HOLD
        or c.layer_base_m is None
        or h.layer == OFF_LAYER
    ):
        return None
    if sum(1 for n, o in c.records.items() if n != uav and o.phase is not Phase.LANDED and o.volumes) > 1:
        return None
    hx, hy = h.point_m[0], h.point_m[1]
    far_m = math.hypot(hx - w.site[0], hy - w.site[1])
    if far_m < APPROACH_GAIN_M + 1e-9:
        return None
    others = [o for n, o in c.records.items() if n != uav]
    pads = [(p[0], p[1]) for n, p in c.homes.items() if n != uav]
    waited = () if c.gate is None else c.gate.waited_on(uav)
    keep_out, spans = hold_keep_out(others, pads, waited)
    r = 1.1 * c.wait_radius_m
    ux, uy = (hx - w.site[0]) / far_m, (hy - w.site[1]) / far_m
    steps = int((far_m - APPROACH_GAIN_M) / APPROACH_STEP_M + 1e-9)
    for i in range(steps + 1):
        d = i * APPROACH_STEP_M
        p = (w.site[0] + d * ux, w.site[1] + d * uy)
        if any(math.hypot(p[0] - k[0], p[1] - k[1]) < r for k in keep_out):
            continue
        if any(point_segment_m(p, a, b) < r for a, b in spans):
            continue
        if c.fence is not None and not c.fence.contains(p[0], p[1], AIRSPACE_MARGIN_M + c.zone_slack_m):
            continue
        # at the altitude it hovers at and is told to fly (``h.layer_m``), not layer ``h.layer``'s now: the layer
        # base may have risen since, and the UAV flew 0.1 m under the leg reserved for it (issue 27 §4.3)
        vols = flight_volumes((hx, hy), h.layer_m, h.layer_m, None, w.top_m, p, None, c.zone_slack_m)
        if c.fits(uav, vols):
            c.take(u, vols)
            u.hold, u.phase = (
                HoldFlight((p[0], p[1], w.site[2]), h.layer, h.layer_m, straight=True),
                Phase.TO_HOLD,
            )
            return Grant(uav, w.site, False, u.hold.point_m, h.layer_m)
    return None
