"""What the airspace holds, for the reports and the stall watchdog, and a silent UAV's own way home.

Part of :class:`~masonry.mission.airspace.ColumnClearance`: read-only views of its records (the sites held, the
layers flown, conflicts, who blocks whom) and the volumes of the flight home a UAV flies without an airspace.
Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from masonry.mission.airspace_requests import climb_out, queued_near
from masonry.mission.airspace_state import Phase
from masonry.mission.volumes import Vec3, Volume, flight_volumes, volumes_conflict

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = ["blockers", "conflicting_pairs", "flight_layers", "held_sites", "way_home"]


def held_sites(c: ColumnClearance) -> dict[str, tuple[Vec3, ...]]:
    """UAV -> the site it holds: the one it flies to, or the one it works at."""
    out: dict[str, tuple[Vec3, ...]] = {}
    for uav, u in c.records.items():
        if u.flight is not None:
            out[uav] = (u.flight.site,)
        elif u.zone is not None and u.zone != c.homes.get(uav):
            out[uav] = (u.zone,)
    return out


def flight_layers(c: ColumnClearance) -> dict[str, int]:
    """UAV -> layer index of its flight in progress (granted, or to its hold point)."""
    return {
        uav: u.flight.layer if u.flight is not None else u.hold.layer  # type: ignore[union-attr]
        for uav, u in c.records.items()
        if u.flight is not None or u.hold is not None
    }


def conflicting_pairs(c: ColumnClearance) -> list[tuple[str, str]]:
    """Pairs of UAVs whose volumes conflict now: always empty (the invariant the tests check)."""
    names = list(c.records)
    out = []
    for i, u in enumerate(names):
        for w in names[i + 1 :]:
            if any(
                volumes_conflict(p, q, c.sep_xy_m, c.spacing_m - 1e-9)
                for p in c.records[u].volumes
                for q in c.records[w].volumes
            ):
                out.append((u, w))
    return out


# -- the protocol -----------------------------------------------------------------------------------------


def blockers(c: ColumnClearance, uav: str) -> list[tuple[str, str]]:
    """Who is in the way of what ``uav`` waits for, and with what: ``(other, "earlier-request")`` for every UAV
    whose turn its request waits for (:func:`~masonry.mission.airspace_requests.queued_near`, what the grant
    itself asks: not one the site gate holds back), then ``(other UAV, volume kind)`` for every other UAV whose
    volumes conflict with its flight at the lowest layer (or, landed, with its take-off column), then ``(other,
    "hover")`` for a hold hover in the way of the climb out of its site's zone
    (:func:`~masonry.mission.airspace_requests.climb_out`). Empty: nothing blocks it (it is not waiting, or its
    answer is on the way). For the reports (``waits``, the stall) and the wait-for graph (airspace_yield.py)."""
    u = c.records.get(uav)
    if c.base_m is None or u is None:
        return []
    out: list[tuple[str, str]] = []
    up: Volume | None = None
    hovers: list[tuple[str, Volume]] = []
    if u.phase is Phase.LANDED:
        wanted = [c.home_column(uav)]
    elif u.request is not None:
        w = u.request
        out = [(other, "earlier-request") for other in queued_near(c, w)]
        if u.phase is Phase.AT_HOLD and u.hold is not None:
            start = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
        else:
            start = w.position if w.position is not None else w.site
        home = c.is_home(uav, w.site)
        wanted = c.flight_volumes_at(start, w.site, w.top_m, 0, None, w.to, home=home)
        up, hovers = climb_out(c, uav, wanted) or (None, [])
    else:
        return []
    for other, o in c.records.items():
        if other == uav:
            continue
        kind = next((q.kind for q in o.volumes for v in wanted if c.conflict(v, q)), None)
        if kind is not None:
            out.append((other, kind))
    named = {other for other, kind in out if kind != "earlier-request"}
    for other, q in hovers:
        if other not in named and up is not None and c.conflict(up, q):
            named.add(other)
            out.append((other, "hover"))
    return out


def way_home(
    c: ColumnClearance, uav: str, position_m: Vec3, layer_m: float | None, via_m: Vec3 | None
) -> tuple[list[Volume], float]:
    """The volumes of the flight home without an airspace (see :meth:`silent`), and its length."""
    home = c.homes[uav]
    x, y, z = float(position_m[0]), float(position_m[1]), float(position_m[2])
    alt = float(layer_m) if layer_m is not None else z
    top = c.home_top_m()
    if via_m is None:
        way = flight_volumes((x, y), z, alt, home, top, None, None, 0.0)
        return way, math.hypot(home[0] - x, home[1] - y) + abs(alt - z) + abs(alt - home[2])
    via = (float(via_m[0]), float(via_m[1]), float(via_m[2]))
    first = flight_volumes((x, y), z, alt, via, top, None, None, 0.0)
    then = flight_volumes((via[0], via[1]), via[2], alt, home, top, None, None, 0.0)
    length_m = (
        math.hypot(via[0] - x, via[1] - y)
        + math.hypot(home[0] - via[0], home[1] - via[1])
        + abs(alt - z)
        + 2.0 * abs(alt - via[2])
        + abs(alt - home[2])
    )
    return [*first, *then], length_m
