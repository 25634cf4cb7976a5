"""The pieces of :mod:`masonry.mission.reserved` that need no state: forced changes, where a UAV is on its plan,
parking spots and who should move to one (pure: no I/O, no clock).

A *parking spot* is a hover over the UAV's own pad, above every transit layer: there it is in nobody's way (legs
fly lower, pads keep out of work zones, neighbouring pads park a layer apart). A UAV waiting at a site for a
stay that will not end by itself (another waiting UAV's, or one the site rule holds back) and itself in the way
of a waiting UAV is sent there: that breaks every cycle of UAVs waiting at sites for each other.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import replace

from masonry.errors import PlanningError
from masonry.geofence import SETPOINT_MARGIN_M, Site
from masonry.mission.volumes import Vec3
from masonry.reservation import (
    Airspace,
    Fence,
    FlightPlan,
    Place,
    Request,
    Reservation,
    Separation,
    Table,
    Volume,
    clash,
    column,
    earliest_start,
    extend,
    flight_reservations,
    keeps_inside,
    way_home,
)
from masonry.segments import point_segment_m
from masonry.timing import TaskTiming

#: How far (horizontally and vertically) a reported position may be off a leg's volume and still be in it.
ON_LEG_M = 0.3

#: A UAV stopped this far under or over a level leg of its plan (its tracking error) is on it: its hover there is
#: reserved at the leg's altitude (:func:`level_of`).
ON_LAYER_M = 0.1

#: A UAV this close (horizontally) to its parking spot, within ``AT_SPOT_Z_M`` of its altitude, is there.
AT_SPOT_M = 0.15
AT_SPOT_Z_M = 0.15


def arrived(p: Vec3 | None, spot: Vec3 | None) -> bool:
    """Is a UAV at ``p`` at its ``spot`` (within :data:`AT_SPOT_M` beside it, :data:`AT_SPOT_Z_M` under or over)?"""
    if p is None or spot is None:
        return False
    return math.hypot(p[0] - spot[0], p[1] - spot[1]) < AT_SPOT_M and abs(p[2] - spot[2]) < AT_SPOT_Z_M


_LEG_PURPOSES = ("climb", "transit", "descend")


def legs_under_way(rs: Iterable[Reservation], now_s: float) -> list[Reservation]:
    """The legs of ``rs`` (climb, transit, descend) whose window has not ended at ``now_s``, in their order."""
    return [r for r in rs if r.purpose in _LEG_PURPOSES and r.t1_s > now_s]


def leg_now(legs: Sequence[Reservation], p: Vec3 | None, now_s: float) -> int | None:
    """The index of the leg of ``legs`` a UAV at ``p`` flies at ``now_s`` (:func:`leg_index`), or None: one also in
    the legs after it whose windows have begun is in the last of them (at the top of its climb, on its transit)."""
    at = leg_index(legs, p)
    return None if at is None else on_from(legs, at, p, now_s)


def on_from(legs: Sequence[Reservation], at: int, p: Vec3 | None, now_s: float) -> int:
    """``at``, or the last of the legs after it whose windows have begun at ``now_s`` that ``p`` is also in, one
    after the other (at the end of a leg, a UAV is at the start of the next: the top of its climb is on its
    transit)."""
    while at + 1 < len(legs) and legs[at + 1].t0_s <= now_s:
        if leg_index(legs[at + 1 : at + 2], p) is None:
            break
        at += 1
    return at


def cut_behind(
    rs: Sequence[Reservation], p: Vec3 | None, now_s: float, at: int | None = None
) -> list[Reservation] | None:
    """A UAV's reservations ``rs`` with the legs behind it at ``p`` ended at ``now_s`` and the transit it flies
    holding only what lies ahead of it (:func:`ahead_of`), or None: nothing it has flown out of. The leg it flies
    is the first ``p`` is in (:func:`leg_index`), or, if it reported one (``at``, an index of its legs under way),
    the reported one where ``p`` is in none (off its track by more than ``ON_LEG_M``) or in a later one: a leg
    it is still in never ends by its word alone."""
    legs = legs_under_way(rs, now_s)
    pos = leg_index(legs, p)
    at = pos if at is None or (pos is not None and pos < at) else at
    if at is None or p is None:
        return None
    behind = [r for r in legs[:at] if r.t0_s < now_s]
    on = legs[at]
    ahead = ahead_of(on, p) if on.t0_s < now_s and on.purpose == "transit" else on
    if not behind and ahead == on:
        return None
    left = [ahead if r == on else r for r in rs if r not in behind]
    return [*left, *(r.until(now_s) for r in behind)]


def forced(table: Table, drop: Iterable[Reservation], add: Iterable[Reservation]) -> Table:
    """``table`` without ``drop`` and with ``add``, not checked (what a UAV physically holds, or is late in)."""
    out = table.without(list(drop))
    return replace(out, reservations=(*out.reservations, *add))


def guarded(table: Table, uav: str, now_s: float, guard_s: float, stopped: Iterable[str]) -> Table:
    """The table ``uav``'s flight is planned in: the other UAVs' windows ``guard_s`` longer, so that one of them
    running late can be extended without a clash; a UAV in ``stopped`` (it turned back and waits for its new
    flight) may stay where it stopped: its windows under way are open-ended."""
    stopped = set(stopped)
    return replace(
        table,
        reservations=tuple(
            r
            if r.uav == uav or r.open_ended
            else r.until(math.inf if r.uav in stopped and r.t0_s <= now_s else r.t1_s + guard_s)
            for r in table.reservations
        ),
    )


def leg_index(legs: Sequence[Reservation], p: Vec3 | None) -> int | None:
    """The index of the first leg of ``legs`` (in plan order) ``p`` is in (within ``ON_LEG_M``), or None: the
    legs before it are behind the UAV (it flies them in order; a short hop's descent may hold its start too)."""
    if p is None:
        return None
    for i, r in enumerate(legs):
        v = r.volume
        inside_z = v.z0_m - ON_LEG_M <= p[2] <= v.z1_m + ON_LEG_M
        if inside_z and point_segment_m((p[0], p[1]), v.a, v.b) <= v.radius_m + ON_LEG_M:
            return i
    return None


def level_of(rs: Iterable[Reservation], p: Vec3, now_s: float) -> float:
    """The altitude ``p`` is at, as the table reads it: that of a level leg of ``rs`` (one UAV's reservations,
    windows not over at ``now_s``) within :data:`ON_LEG_M` of ``p`` horizontally and :data:`ON_LAYER_M`
    vertically, else ``p``'s own. A UAV that turned back in its climb 6 cm under its layer, over a stay 1.1 m
    under the layer beside it, hovers on the layer, not 1.04 m over the stay (issue 27's random layouts)."""
    for r in rs:
        v = r.volume
        if r.purpose not in _LEG_PURPOSES or r.t1_s <= now_s or v.z0_m != v.z1_m:
            continue
        if (
            abs(p[2] - v.z0_m) <= ON_LAYER_M
            and point_segment_m((p[0], p[1]), v.a, v.b) <= v.radius_m + ON_LEG_M
        ):
            return v.z0_m
    return p[2]


def ahead_of(r: Reservation, p: Vec3) -> Reservation:
    """``r``, a lateral leg the UAV at ``p`` flies, from ``ON_LEG_M`` behind the UAV on: the air it has flown out
    of is free before the leg's window ends (a column, or a UAV not yet ``ON_LEG_M`` along, keeps all of ``r``)."""
    v = r.volume
    length_m = math.hypot(v.b[0] - v.a[0], v.b[1] - v.a[1])
    if length_m <= 1e-9:
        return r
    along_m = ((p[0] - v.a[0]) * (v.b[0] - v.a[0]) + (p[1] - v.a[1]) * (v.b[1] - v.a[1])) / length_m
    f = (min(along_m, length_m) - ON_LEG_M) / length_m
    if f <= 1e-6:
        return r
    a = (v.a[0] + (v.b[0] - v.a[0]) * f, v.a[1] + (v.b[1] - v.a[1]) * f)
    return replace(r, volume=replace(v, a=a))


def hover_start(stay: Reservation | None, start: Vec3) -> Vec3:
    """Where a UAV at ``start`` leaves from if ``stay`` (its own) is a hover within :data:`ON_LEG_M` of it (it
    turned back and hovers where it stopped, perhaps on the layer just over it: :func:`level_of`): the hover."""
    if stay is None:
        return start
    v = stay.volume
    if (
        v.a != v.b
        or v.z0_m != v.z1_m
        or math.dist(v.a, start[:2]) >= ON_LEG_M
        or abs(start[2] - v.z1_m) >= ON_LEG_M
    ):
        return start
    return (v.a[0], v.a[1], v.z1_m)


def on_ahead(
    rs: Sequence[Reservation], p: Vec3, now_s: float, layer_m: float
) -> tuple[list[tuple[Vec3, int]], Reservation | None]:
    """Where a UAV at ``p``, turned back in its plan (``rs``: its reservations, in plan order; lateral legs at
    ``layer_m``), could hover further on along it, each reachable by a hold flight (up or down where it is, then
    over at one altitude): the top of the climb it is in, then the end of every lateral leg ahead, nearest first,
    each with the index (among the plan's legs under way) of the leg it ends; and the stay the plan ends in, if it
    reaches it so (it is in the plan's last column, or the stay's top is the layer's end), else None."""
    legs = legs_under_way(rs, now_s)
    at = leg_index(legs, p)
    if at is None:
        return [], None
    out: list[tuple[Vec3, int]] = []
    for i in range(at, len(legs)):
        v = legs[i].volume
        if v.a != v.b:
            out.append(((v.b[0], v.b[1], v.z1_m), i))
        elif i == at and legs[i].purpose == "climb":
            out.append(((v.a[0], v.a[1], layer_m), i))
    stay = next((r for r in reversed(rs) if r.open_ended and r.purpose == "stay"), None)
    if stay is None or stay.volume.a != stay.volume.b:
        return out, None
    xy, top = stay.volume.a, stay.volume.z1_m
    now = legs[at]
    in_last = at == len(legs) - 1 and now.purpose == "descend" and now.volume.a == xy
    ends = [r.volume for r in legs[at:] if r.volume.a != r.volume.b]
    at_layer_end = bool(ends) and ends[-1].b == xy and abs(ends[-1].z1_m - top) <= 1e-6
    return out, stay if in_last or at_layer_end else None


def park_levels(homes: Mapping[str, Vec3], separation_m: float) -> dict[str, int]:
    """Each UAV's parking level (0, 1, ...): two pads closer than ``separation_m`` never share one (greedy)."""
    out: dict[str, int] = {}
    for uav in sorted(homes):
        h = homes[uav]
        near = {out[o] for o in out if math.hypot(homes[o][0] - h[0], homes[o][1] - h[1]) < separation_m}
        out[uav] = next(k for k in range(len(homes) + 1) if k not in near)
    return out


def park_spots(
    home: Vec3, base_m: float, max_layers: int, spacing_m: float, levels: Mapping[str, int], uav: str
) -> list[Vec3]:
    """``uav``'s parking spots over its ``home``, best first: at its level over every transit layer however high
    the wall's rise takes them (``base_m``: the finished wall's), then one tier of levels higher. The flight to a
    spot flies at its altitude: where another UAV's spot at that level is in its way (held for good), the higher
    tier, whose column down over the pad passes only the spots of its pad-neighbours, gets it there."""
    tiers = (0, 1 + max(levels.values(), default=0))
    zs = [base_m + (max_layers + levels.get(uav, 0) + t) * spacing_m for t in tiers]
    return [(home[0], home[1], z) for z in zs]


def parked_ways(
    uav: str, spot: Vec3, top_m: float, parked: Mapping[str, Vec3], separation: Separation
) -> tuple[bool, bool]:
    """Is ``uav``'s parking ``spot`` in the way down of a UAV at (or flying to) its parking spot (``parked``: UAV ->
    spot), and is one of those spots in ``uav``'s way down from ``spot``? Each way is the column over the spot down
    to ``top_m`` (the top transit layer, where a hop from a parking spot starts). Pads 1 m apart park a level apart,
    and the way down from the higher spot passes the lower one 1 m beside it: a UAV parked under a neighbour
    parked before it waited for nothing that ends, the neighbour for it (issue 27's random layouts)."""

    def way(o: str, s: Vec3) -> Reservation:
        return Reservation(o, column(s[:2], min(top_m, s[2]), s[2]), 0.0, math.inf, "stay")

    def hover(o: str, s: Vec3) -> Reservation:
        return Reservation(o, column(s[:2], s[2], s[2]), 0.0, math.inf, "stay")

    others = [(o, s) for o, s in parked.items() if o != uav]
    in_theirs = any(clash(hover(uav, spot), way(o, s), separation) for o, s in others)
    in_mine = any(clash(way(uav, spot), hover(o, s), separation) for o, s in others)
    return in_theirs, in_mine


def parking_order(
    uav: str, spots: Sequence[Vec3], top_m: float, parked: Mapping[str, Vec3], separation: Separation
) -> list[Vec3]:
    """``spots`` (best first) ``uav`` may be sent to: none in the way down of a UAV parked before it, those whose
    own way down passes no parked UAV first (:func:`parked_ways`). Over a neighbour parked before it, it waits for
    that one to come down first, which waits for no parked UAV."""
    ways = {s: parked_ways(uav, s, top_m, parked, separation) for s in spots}
    return sorted((s for s in spots if not ways[s][0]), key=lambda s: ways[s][1])


def park_plan(
    table: Table, uav: str, start: Vec3, spot: Vec3, now_s: float, airspace: Airspace
) -> FlightPlan | None:
    """The flight from ``start`` to the parking ``spot`` (climb to its altitude, fly over), ending in a hover
    there, open-ended, if it fits now (None: not now)."""
    air = Airspace((spot[2],), airspace.cruise_mps, airspace.vertical_mps, airspace.margin_s, 0.0)
    here = Place((start[0], start[1]), min(start[2], spot[2]), "site")
    there = Place((spot[0], spot[1]), spot[2], "site")
    rs = list(flight_reservations(Request(uav, here, None, there), now_s, spot[2], air))
    rs[-1] = Reservation(uav, column(there.xy, spot[2], spot[2]), rs[-1].t0_s, math.inf, "stay")
    parts = [(r.volume, r.t0_s - now_s, r.t1_s - now_s) for r in rs]
    start_s, _ = earliest_start(table, uav, parts, now_s)
    if start_s > now_s or not keeps_inside(airspace.fence, rs):  # (nor one whose flight leaves the fence)
        return None
    return FlightPlan(uav, now_s, spot[2], tuple(rs))


def to_park(
    waits: Mapping[str, tuple[tuple[str, str], ...]], endless: Iterable[str], order: Mapping[str, int]
) -> list[str]:
    """The waiting UAVs that should go to their parking spots, best first: those in the way of a waiting UAV
    (``waits``: UAV -> (other, purpose) in its way) whose own wait does not end by itself (``endless``: only
    stays, of waiting UAVs, or the site rule), the latest request (``order``) first."""
    endless = set(endless)
    blocking = {other for ws in waits.values() for other, purpose in ws if purpose == "stay"}
    out = []
    for uav in endless & blocking:
        ws = waits.get(uav, ())
        if any(o in waits or p == "site-rule" for o, p in ws):
            out.append(uav)
    return sorted(out, key=lambda u: -order.get(u, 0))


def silent_way(
    table: Table,
    uav: str,
    position_m: Vec3,
    layer_m: float | None,
    via_m: Vec3 | None,
    home_m: Vec3,
    now_s: float,
    timing: TaskTiming,
    fence: Site | None = None,
) -> tuple[Table, float]:
    """``table`` with a silent ``uav``'s reservations open-ended and its way home from ``position_m`` at its
    fallback ``layer_m`` (through ``via_m``'s column, a brick put back first, to over ``home_m``) reserved
    open-ended too (:func:`~masonry.reservation.way_home`, or forced where plans under way are in its way: it
    flies it anyway); and the way's length in metres. Under ``fence``'s ceiling: at most its setpoint margin
    under it, where the UAV's clamped setpoints fly it (docs/state-machines.md, "The site's fence"), so the way
    keeps inside where a layer can; a leg across the boundary is reserved as it is (it flies home all the same,
    along the boundary)."""
    held = [r.until(math.inf) for r in table.of(uav) if r.t1_s > now_s]
    x, y, z = (float(v) for v in position_m)
    alt = float(layer_m) if layer_m is not None else z
    if fence is not None:
        alt = min(alt, fence.max_altitude_m - SETPOINT_MARGIN_M)
    alt = max(alt, z, home_m[2])
    within = None if fence is None else Fence(fence)
    air = Airspace((alt,), timing.cruise_speed_mps, timing.vertical_speed_mps, 0.0, 0.0, fence=within)
    via = None if via_m is None else (float(via_m[0]), float(via_m[1]), float(via_m[2]))
    stops = [(x, y, z), *([] if via is None else [via]), home_m]
    way: list[Reservation] = []
    length_m = 0.0
    for a, b in itertools.pairwise(stops):
        length_m += math.hypot(b[0] - a[0], b[1] - a[1]) + abs(alt - a[2]) + abs(alt - b[2])
        start, end = Place((a[0], a[1]), a[2], "site"), Place((b[0], b[1]), b[2], "site")
        try:  # reserved from now at its fallback layer; plans not started in its way move
            table, plan, _moves = way_home(table, uav, now_s, start, end, air)
            way.extend(plan.reservations)
        except PlanningError:
            way.extend(flight_reservations(Request(uav, start, None, end), now_s, alt, air))
    # all of it until mission control releases it (heard again, or the way home's time is over)
    return forced(table, table.of(uav), [*held, *(r.until(math.inf) for r in way)]), length_m


def extend_or_force(table: Table, uav: str, now_s: float, margin_s: float) -> tuple[Table, bool]:
    """``uav``'s windows from ``now_s`` on extended by ``margin_s`` (:func:`~masonry.reservation.extend`: the plans
    of others in the way move), or, when no move makes room, extended all the same (True: forced, a clash)."""
    try:
        return extend(table, uav, now_s, margin_s)[0], False
    except PlanningError:
        mine = [r for r in table.of(uav) if r.t1_s > now_s and not (r.open_ended and r.t0_s <= now_s)]
        moved = [r.until(r.t1_s + margin_s) if r.t0_s <= now_s else r.shifted(margin_s) for r in mine]
        return forced(table, mine, moved), True


def end_flight(rs: Sequence[Reservation], now_s: float, flight: Sequence[str]) -> list[Reservation]:
    """``rs`` (one UAV's) once it is where its flight ends: the flight's windows end now, its stay starts now."""
    out = []
    for r in rs:
        if r.purpose in flight and r.t1_s > now_s:
            if r.t0_s < now_s:
                out.append(r.until(now_s))
        elif r.open_ended and r.t0_s > now_s:
            out.append(Reservation(r.uav, r.volume, now_s, math.inf, r.purpose, r.task))
        else:
            out.append(r)
    return out


__all__ = [
    "AT_SPOT_M",
    "AT_SPOT_Z_M",
    "ON_LAYER_M",
    "ON_LEG_M",
    "Volume",
    "ahead_of",
    "arrived",
    "cut_behind",
    "end_flight",
    "extend_or_force",
    "forced",
    "guarded",
    "hover_start",
    "leg_index",
    "leg_now",
    "legs_under_way",
    "level_of",
    "on_ahead",
    "on_from",
    "park_levels",
    "park_plan",
    "park_spots",
    "parked_ways",
    "parking_order",
    "silent_way",
    "to_park",
]
