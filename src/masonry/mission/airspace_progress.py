"""A granted flight shrinks as it is flown: the climb freed, the part behind left, the hold point reached, the
zone at the site once down.

Part of :class:`~masonry.mission.airspace.ColumnClearance` (its methods of these names call these): a UAV holds
the whole of a flight when it is granted; its reports give back what lies behind it (docs/safety.md). Pure: no
I/O, no clock.
"""

from __future__ import annotations

import math

from masonry.mission.airspace_records import SNAP_M, AirspaceRecords
from masonry.mission.airspace_state import Phase, UavAirspace
from masonry.mission.volumes import Vec3, Volume, ahead_of, same_site

__all__ = ["AT_HOLD_M", "arrive_at_hold", "end_transit", "progress", "release"]

#: A UAV within this of its hold point (horizontally) hovers there: the state machines count a leg as done
#: within 0.08 m (``UavConfig.arrive_tolerance_m``), and only then read the rest of their flight.
AT_HOLD_M = 0.1


def end_transit(c: AirspaceRecords, uav: str) -> None:
    """``uav``'s flight came down at its site: it holds the zone there now."""
    u = c.records.get(uav)
    if u is None or u.flight is None:
        return
    f = u.flight
    u.flight, u.origin, u.phase = None, None, Phase.PARKED
    c.set_zone(uav, f.site, f.top_m, f.to)


def release(c: AirspaceRecords, uav: str, site_m: Vec3 | None = None) -> None:
    """``uav`` is ``release_radius_m`` away from where it was at ``site_m`` (its climb there is over), or gave
    up asking for it; None: it is out of the mission (on the ground or fallen): everything is freed."""
    if site_m is None:
        c.records.pop(uav, None)
        c.touch()
        return
    u = c.records.get(uav)
    if u is None:
        return
    if u.request is not None and same_site(u.request.site, site_m) and u.phase is Phase.ASKING:
        u.request, u.phase = None, Phase.PARKED  # given up before anything was granted
        c.touch()
        return
    if u.origin is not None and same_site(u.origin, site_m):
        u.origin = None
        kept = [v for v in u.volumes if v.kind != "climb"]
        if len(kept) != len(u.volumes):
            u.volumes = kept
            c.touch()


def progress(c: AirspaceRecords, uav: str, position_m: Vec3) -> None:
    """``uav`` reports where it is: the part of its flight behind it is freed.

    Only a position on the flight's lateral leg (at its layer, within ``TRACK_M`` of the leg) or in the
    descent over its site counts; anything else (a report sent before the flight was granted, say) is ignored.
    A UAV flies its legs forward from rest to rest, so what lies more than ``TRACK_M`` behind it is left.
    """
    u = c.records.get(uav)
    vols = None if u is None else u.volumes
    if not vols or u is None or c.base_m is None:
        return
    x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
    h = u.hold
    if (
        u.phase is Phase.TO_HOLD
        and h is not None
        and math.hypot(x - h.point_m[0], y - h.point_m[1]) < AT_HOLD_M
        and abs(z - h.layer_m) < SNAP_M  # at the layer: it may still be coming down to it from above
    ):
        arrive_at_hold(c, u)  # it hovers at its hold point
        return
    kept = ahead_of(vols, x, y, z)
    if kept is None:
        return
    if len(kept) != len(vols) or any(k is not v for k, v in zip(kept, vols)):
        u.volumes = kept
        c.touch()


def arrive_at_hold(c: AirspaceRecords, u: UavAirspace) -> None:
    """It hovers at its hold point: only the hover is its now."""
    assert u.hold is not None
    u.phase = Phase.AT_HOLD
    u.origin = None
    hxy = (u.hold.point_m[0], u.hold.point_m[1])
    alt = u.hold.layer_m
    # (a hover widened for a fast leg there stays so: a heartbeat may say it is there before it overshoots)
    end = u.volumes[-1] if u.volumes else None
    slack = end.slack_m if end is not None and end.kind == "hover" else c.zone_slack_m
    u.volumes = [Volume(hxy, hxy, alt, alt, max(slack, c.zone_slack_m), "hover")]
    c.touch()
