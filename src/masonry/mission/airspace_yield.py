"""A UAV at its hold point yields to a UAV whose way out it is in (issue 27): the hover moves, not the wait.

Part of :class:`~masonry.mission.airspace.ColumnClearance` (docs/safety.md, "A hover yields the way out"). Hold
points keep 1.1 wait radii from every zone's *site*, but a UAV asks to leave from where it reports itself, and a
brick UAV placed on the wall's frame (GNSS wander, the wall alignment) reports itself up to a few decimetres off
its drop-off, farther than ``leave_from`` snaps. Its climb from there can reach within the separation of a hover
granted beside the zone, at every layer (the hover at layer 0, the climb starting under it); the hovering UAV
waits for that very zone: a cycle of two, which only hold patience broke (the towers, px4, seed 10 in 4 m/s wind:
the adhesion task A0 given up three times). Here a hovering UAV whose hover (with the other hovers) is in the
way, at every layer, of the climb out of an asking UAV it waits for (directly or through other waiting UAVs) is
given a hold flight to a point whose hover clears that climb (the same point a layer up, first); once it is there
the asking UAV climbs out. Only to break such a cycle: a hover in the way of a UAV it does not wait for stays
(that UAV waits for flights and work, which end), and hovers move only for a UAV that asks from where it stays
(``ASKING``), never for another hovering UAV, so no two hovers chase each other. Pure: no I/O, no clock.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from masonry.geofence import AIRSPACE_MARGIN_M
from masonry.mission.airspace_state import OFF_LAYER, Grant, HoldFlight, Phase, UavAirspace, hold_candidates
from masonry.mission.volumes import Volume, volumes_clear

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["WAITING", "make_way", "waits_on", "way_out"]

#: The phases of a UAV that waits where it is for its flight (a link in a wait-for cycle; one flying ends its flight).
WAITING = (Phase.ASKING, Phase.AT_HOLD)


def way_out(c: ColumnClearance, asker: str, o: UavAirspace) -> list[Volume] | None:
    """``asker``'s climb out of where it waits (its zone, where it stopped), up to the lowest layer at which only
    hovers of UAVs waiting at their hold points are in its way, if they are in its way at every layer (None: it can
    climb out at some layer, to its flight or to a hold point: the liveness argument holds as it is)."""
    w = o.request
    if w is None or o.phase is not Phase.ASKING or c.layer_base_m is None:
        return None
    start = w.position if w.position is not None else w.site
    climbs = [
        [v for v in c.flight_volumes_at(start, None, w.top_m, k, (start[0], start[1])) if v.kind == "climb"]
        for k in range(c.max_layers)
    ]
    every = [q for n, r in c.records.items() if n != asker for q in r.volumes]
    if any(volumes_clear(climb, every, c.sep_xy_m, c.spacing_m - 1e-9) for climb in climbs):
        return None
    settled = [
        q
        for n, r in c.records.items()
        if n != asker
        and not (r.phase is Phase.AT_HOLD and len(r.volumes) == 1 and r.volumes[0].kind == "hover")
        for q in r.volumes
    ]
    return next(
        (climb for climb in climbs if volumes_clear(climb, settled, c.sep_xy_m, c.spacing_m - 1e-9)), None
    )


def make_way(c: ColumnClearance, uav: str, u: UavAirspace) -> Grant | None:
    """``uav`` hovers at its hold point in the way of the climb out of an asking UAV it waits for (:func:`way_out`,
    :func:`waits_on`): a hold flight to a hold point (the same one higher up, or another near its site) whose hover
    clears that climb, the whole hold flight clear of every volume of the others, taken as any hold flight is
    (None: it is in no one's way, or nowhere fits). Its climb and leg are freed behind it as it flies
    (``progress``); at the new point only its hover is its own, clear of the climb it made way for."""
    w, h = u.request, u.hold
    if w is None or h is None or u.phase is not Phase.AT_HOLD or h.layer == OFF_LAYER or len(u.volumes) != 1:
        return None
    hover = u.volumes[0]
    ways = []
    for n, o in c.records.items():
        if n == uav:
            continue
        vols = way_out(c, n, o)
        if (
            vols is not None
            and not volumes_clear([hover], vols, c.sep_xy_m, c.spacing_m - 1e-9)
            and waits_on(c, uav, n)
        ):
            ways.extend(vols)
    if not ways:
        return None
    others = [o for n, o in c.records.items() if n != uav]
    pads = [(p[0], p[1]) for n, p in c.homes.items() if n != uav]
    waited = () if c.gate is None else c.gate.waited_on(uav)
    points = [h.point_m, *hold_candidates(w.site, others, c.wait_radius_m, pads, waited)[:6]]
    if c.fence is not None:
        need = AIRSPACE_MARGIN_M + c.zone_slack_m
        points = [p for p in points if c.fence.contains(p[0], p[1], need)]
    start = (h.point_m[0], h.point_m[1], h.layer_m)
    for k in range(c.max_layers):
        for p in points:
            if k == h.layer and (p[0], p[1]) == (h.point_m[0], h.point_m[1]):
                continue
            vols = c.flight_volumes_at(start, None, w.top_m, k, (p[0], p[1]))
            if c.fits(uav, vols) and volumes_clear(vols[-1:], ways, c.sep_xy_m, c.spacing_m - 1e-9):
                c.take(u, vols)
                u.hold, u.phase = HoldFlight(p, k, c.alt(k)), Phase.TO_HOLD
                c.held_back += 1
                c.layer_counts[k] = c.layer_counts.get(k, 0) + 1
                return Grant(uav, w.site, False, p, c.alt(k))
    return None


def waits_on(c: ColumnClearance, uav: str, other: str) -> bool:
    """``uav`` waits, directly or through other waiting UAVs, for ``other``: ``other`` is reachable from ``uav`` in
    the wait-for graph of :meth:`ColumnClearance.blockers` (who is in the way of whose flight) through UAVs that
    wait where they are (``ASKING``, ``AT_HOLD``). A hover moves only to break such a cycle: one in the way of a
    UAV it does not wait for stays, and that UAV waits for flights in progress and work, which end."""
    seen, todo = {uav}, [uav]
    while todo:
        for n, _kind in c.blockers(todo.pop()):
            if n == other:
                return True
            o = c.records.get(n)
            if o is not None and o.request is not None and o.phase in WAITING and n not in seen:
                seen.add(n)
                todo.append(n)
    return False
