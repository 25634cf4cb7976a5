"""The reservation table's request decision: a UAV's hop granted, or "wait where you stay".

Part of :class:`~masonry.mission.reserved.TableClearance` (``--airspace table``; docs/safety.md, "The table at run
time"), as :mod:`masonry.mission.airspace_requests` is of the columns: :func:`request` takes a UAV's request (a
UAV that turned back mid-flight stops where it is, :func:`stop_where`; a flight that no layer can fly inside the
fence is refused, :func:`check_fence`), :func:`evaluate` plans its hop in the table (:func:`hop_request`) and grants it if
it fits now, else tells it to wait where it stays (held back by the site gate far from its site: at its approach
spot, :mod:`masonry.mission.reserved_approach`). Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

from masonry.mission.airspace_ground import ON_PAD_XY_M
from masonry.mission.airspace_state import FlightRequest, Grant, Phase, request_geometry
from masonry.mission.fence import flight_fence_problem
from masonry.mission.reserved_approach import approach
from masonry.mission.reserved_lift import lift
from masonry.mission.reserved_parts import ON_LEG_M, forced, legs_under_way, level_of, on_ahead
from masonry.mission.sites import enter_ungoverned
from masonry.mission.table_holds import fence_refusal, held_cause
from masonry.mission.volumes import Vec3, same_site
from masonry.ports import PlanProgress
from masonry.reservation import FlightPlan, Place, Request, Reservation, Wait, Work, column, decide

if TYPE_CHECKING:
    from masonry.mission.reserved import TableClearance

__all__ = ["TableUav", "check_fence", "evaluate", "fly_on", "hop_request", "request", "stop_where"]

#: The radius of the hover a UAV that stopped is reserved (its tracking error, and more).
HOVER_R_M = 0.3

_PLAN_END = ("work", "site", "home")


@dataclass
class TableUav:
    """One UAV's part in the protocol: its phase, its pending request, its granted plan."""

    phase: Phase = Phase.PARKED
    request: FlightRequest | None = None
    plan: FlightPlan | None = None
    site: Vec3 | None = None  # where its plan (or its last one) goes
    position: Vec3 | None = None
    seen_version: int = -1  # table version at its request's last evaluation
    retry_s: float = math.inf  # its wait ends then at the latest (a window ends)
    blocked_by: tuple[tuple[str, str], ...] = ()
    spot: Vec3 | None = None  # its parking spot, while it flies there or waits there
    approach: bool = (
        False  # its spot is the approach spot by its site (:mod:`~masonry.mission.reserved_approach`)
    )
    approached: int = -1  # the request (seq) it was sent to an approach spot for: only once
    flown_on: bool = False  # its spot is where it flew on to along its plan, turned back (:func:`fly_on`)
    #: where it flies on down to once at its spot over its plan's stay (:func:`fly_on`'s second hold flight)
    down_to: Vec3 | None = None
    #: the number mission control's answer gave its plan, with that plan (:mod:`masonry.mission.plan_reading`)
    numbered: tuple[int, FlightPlan] | None = None
    grants: int = 0  # its plans numbered so far
    #: its last report's ``plan_progress`` (None: none, or a report without one came since)
    reported: PlanProgress | None = None
    #: its spot is its lift spot over the site it waited at (:mod:`~masonry.mission.reserved_lift`)
    lifted: bool = False

    @property
    def hovering(self) -> bool:
        """Its spot is a hover it waits at (approach, flown on to, lift), not its parking spot."""
        return self.approach or self.flown_on or self.lifted


def request(
    c: TableClearance,
    uav: str,
    site_m: Vec3,
    now_s: float,
    position_m: Vec3 | None = None,
    top_m: float | None = None,
    to_m: Vec3 | None = None,
) -> Grant:
    """``uav`` (at ``position_m``) sets off for ``site_m``, to work there up to ``top_m`` (along to ``to_m``):
    its hop is granted if it fits now, else it waits where it is (its stay)."""
    c.tick(now_s)
    site, top, pos = request_geometry(site_m, top_m, position_m)
    if c.base_m is None:  # no airspace rules: only the site gate may hold the flight back
        granted = enter_ungoverned(c.gate, uav, site, now_s)
        c.granted_count += granted
        c.refused += not granted
        return Grant(uav, site, granted)
    u = c.record(uav)
    if pos is not None:
        u.position = pos
    if (
        u.phase in (Phase.TO_HOLD, Phase.AT_HOLD)
        and u.request is not None
        and same_site(u.request.site, site)
    ):
        c.at_spot(uav, u)
        if u.phase is Phase.TO_HOLD and u.spot is not None:
            return Grant(uav, site, False, u.spot, u.spot[2])  # on its way there: the same answer
    elif u.plan is not None and u.site is not None and same_site(u.site, site):
        return Grant(uav, site, layer_m=u.plan.layer_m)  # said again: the same flight
    if u.plan is not None and u.phase in (Phase.FLYING, Phase.TO_HOLD):
        # it turned back mid-flight (a failsafe, a recall): it stops where it is, which is its stay now
        stop_where(c, uav, u, pos)
    w = u.request
    if w is not None and same_site(w.site, site):
        if pos is not None and (w.position is None or math.dist(pos, w.position) > 0.05):
            u.request = replace(w, position=pos)
            u.seen_version = -1
        return evaluate(c, uav, u, now_s)
    to = None
    if to_m is not None and math.hypot(float(to_m[0]) - site[0], float(to_m[1]) - site[1]) > 1e-6:
        to = (float(to_m[0]), float(to_m[1]))
    if c.gate is not None and u.site is not None and not same_site(u.site, site):
        c.gate.left(uav, now_s)  # it moves on: its site interval is over, however close the next site is
    c.seq += 1
    u.request = FlightRequest(site, top, pos, now_s, c.seq, to)
    u.phase, u.seen_version, u.retry_s = Phase.ASKING, -1, math.inf
    check_fence(c, uav, u.request)
    g = evaluate(c, uav, u, now_s)
    return g if g.granted or g.hold_m is not None else fly_on(c, uav, u, g)


def fly_on(c: TableClearance, uav: str, u: TableUav, g: Grant) -> Grant:
    """``uav`` turned back where no hover fits and keeps its plan (:func:`stop_where`); its new flight waits. It
    flies its plan on (a hold flight, on the plan's windows) to the stay the plan ends in if one hold flight gets it
    there, else to the nearest place along it where a hover fits (:func:`~masonry.mission.reserved_parts.on_ahead`),
    and waits there, holding only that stay, from which the parking rule may send it on (``flown_on``). Where it
    stopped, its plan's windows were extended while it waited (a UAV waiting on them waited for a volume held by a
    UAV that waited: seed 70 of ``bench_layouts.py --compact --airspace table``), or ended by time, and the flights
    granted after them came down where it hovered (seed 206: 0.66 m). Where no hover fits and its last lateral leg
    ends over the stay the plan ends in (a flight to a site, turned back on its leg), it flies on over the stay at
    its layer, then down its own descent into it (``down_to``: the second hold flight), and holds that stay only.
    Else ``g``: it waits where it stopped (no such place along its plan: not met)."""
    where = None if u.request is None else (u.request.position or u.position)
    if u.plan is None or u.request is None or where is None or u.phase is not Phase.ASKING:
        return g
    mine = c.table.of(uav)
    points, stay = on_ahead(mine, where, c.now_s, u.plan.layer_m)
    legs = legs_under_way(mine, c.now_s)
    spot = None if stay is None else (stay.volume.a[0], stay.volume.a[1], stay.volume.z1_m)
    for q, i in points if stay is None else ():
        hover = Reservation(uav, column(q[:2], q[2], q[2], HOVER_R_M), c.now_s, math.inf, "stay")
        if not c.table.clashes(hover):  # (the rest of its plan, from the leg that ends there on, is free)
            rest = [r for r in mine if r.purpose in _PLAN_END or r.open_ended]
            c.table, spot = forced(c.table, [*legs[i + 1 :], *rest], [hover]), q
            break
    down = None
    if spot is None and points:  # its last lateral leg ends over its plan's stay: over it, then down into it
        q, _i = points[-1]
        end = next((r for r in reversed(mine) if r.open_ended and r.purpose == "stay"), None)
        if end is not None and end.volume.a == end.volume.b and math.dist(end.volume.a, q[:2]) < 1e-6:
            spot, down = q, (q[0], q[1], end.volume.z1_m)
    if spot is None:
        return g
    u.phase, u.spot, u.approach, u.flown_on, u.down_to = Phase.TO_HOLD, spot, False, True, down
    u.lifted = False
    c.bump()
    return Grant(uav, u.request.site, False, spot, spot[2])


def evaluate(c: TableClearance, uav: str, u: TableUav, now_s: float) -> Grant:
    """Grant ``uav``'s hop if it fits now, else tell it to wait where it is."""
    w = u.request
    assert w is not None
    u.seen_version, u.retry_s = c.version, math.inf
    refused = c.fence_refusals.get(uav)
    if refused is not None:
        c.refused += 1
        return Grant(uav, w.site, False, refused=refused)
    if c.table.stay_of(uav) is None:  # (heard again with nothing held: where it is now)
        where = u.position if u.position is not None else w.site
        c.set_stay(uav, column((where[0], where[1]), 0.0, where[2]), u.phase)
    guarded, hop = c.guarded_for(uav), hop_request(c, uav, u, w)
    if c.gate is not None and not c.gate.may_enter(uav, w.site):
        sent = approach(c, uav, u, w, (*hop.start.xy, hop.start.z_m), now_s)
        if sent is not None:  # far from its task's site: it waits over it, not where it is
            return sent
        u.blocked_by = (("-", "site-rule"),)
        c.refused += 1
        return Grant(uav, w.site, False)
    if u.plan is not None:  # it turned back and holds its old plan: its new one starts where it is, now
        here = column(hop.start.xy, hop.start.z_m, hop.start.z_m)
        guarded = forced(guarded, guarded.of(uav), [Reservation(uav, here, now_s, math.inf, "stay")])
    top = c.airspace.layers_m[-1]
    high = hop.start.z_m > top  # from its parking spot, over every layer: planned from the top one
    # (the layer that arrives first only for a UAV at rest where it stays: one that turned back mid-flight takes
    # the first layer free now)
    air = (
        c.airspace if u.plan is None and u.phase is Phase.ASKING else replace(c.airspace, first_arrival=False)
    )
    decision = decide(guarded, replace(hop, start=replace(hop.start, z_m=top)) if high else hop, now_s, air)
    if high and not isinstance(decision, Wait):
        first = decision.plan.reservations[0]  # its climb (a descent here) reaches up to where it is
        down = replace(first, volume=column(hop.start.xy, first.volume.z0_m, hop.start.z_m))
        if guarded.clashes(down):
            decision = Wait(uav, now_s + 1.0, guarded.clashes(down))
        else:
            plan = decision.plan
            decision = replace(decision, plan=replace(plan, reservations=(down, *plan.reservations[1:])))
    if isinstance(decision, Wait):
        if decision.outside_fence:  # (no layer keeps its legs inside the fence: never granted)
            return fence_refusal(c, uav, w)
        u.retry_s = decision.until_s
        u.blocked_by = held_cause(decision) or tuple(
            sorted({(r.uav, r.purpose) for r in decision.blocked_by})
        )
        c.refused += 1
        return _hold_on(uav, u, w)
    left = c.table.release(uav, decision.plan.start_s)  # its stay (or old plan) ends as it sets off
    c.table, u.plan, u.site = forced(left, [], decision.plan.reservations), decision.plan, w.site
    u.request, u.phase, u.blocked_by, u.spot, u.approach = None, Phase.FLYING, (), None, False
    u.flown_on, u.down_to, u.lifted = False, None, False
    c.granted_count += 1
    if c.gate is not None:
        c.gate.entered(uav, w.site, now_s)
    c.bump()
    return Grant(uav, w.site, layer_m=decision.plan.layer_m)


def lift_in_way(c: TableClearance, uavs: Mapping[str, TableUav], now_s: float) -> list[Grant]:
    """The UAVs waiting at rest at a site whose stay the last answer to another UAV's request names in its way
    (that UAV waiting where it is, at a spot, or on its way to one), each sent to its lift spot if its climb there
    fits now (:func:`~masonry.mission.reserved_lift.lift`)."""
    named = {o for u in uavs.values() if u.request is not None for o, p in u.blocked_by if p == "stay"}
    out = []
    for uav in sorted(named):
        u = uavs.get(uav)
        if u is None or u.request is None or u.phase is not Phase.ASKING or u.plan is not None:
            continue
        hop = hop_request(c, uav, u, u.request)
        g = lift(c, uav, u, u.request, (*hop.start.xy, hop.start.z_m), u.retry_s, now_s)
        if g is not None:
            out.append(g)
    return out


def _hold_on(uav: str, u: TableUav, w: FlightRequest) -> Grant:
    """Not yet: wait where you are (at the spot you hover at, if any)."""
    if u.phase is Phase.AT_HOLD and u.spot is not None:
        return Grant(uav, w.site, False, u.spot, u.spot[2])
    return Grant(uav, w.site, False)


def hop_request(c: TableClearance, uav: str, u: TableUav, w: FlightRequest) -> Request:
    """The request of ``w``'s hop: from where the UAV is (its site when unknown), to stay at the target."""
    start = w.position if w.position is not None else (u.position or w.site)
    if u.phase in (Phase.TO_HOLD, Phase.AT_HOLD) and u.spot is not None:
        start = u.spot  # it waits at its parking spot, wherever it asked from
    stay = c.table.stay_of(uav)
    if stay is not None and stay.volume.a == stay.volume.b and math.dist(stay.volume.a, start[:2]) < ON_LEG_M:
        v = stay.volume  # where it stays, give or take its tracking error (a hover: at its altitude)
        start = (*v.a, v.z1_m if v.z0_m == v.z1_m and abs(start[2] - v.z1_m) < ON_LEG_M else start[2])
    home = c.homes.get(uav)
    radius = 0.0 if home is not None and same_site(home, w.site) else c.zone_r_m
    # over its pad it climbs in the pad's column, as it took off: a zone's slack there (r_c > 1.2 m) came within the
    # pad separation of the pads 1 m beside it, and it waited for good for its landed neighbours
    on_pad = home is not None and math.hypot(start[0] - home[0], start[1] - home[1]) <= ON_PAD_XY_M
    here = Place((start[0], start[1]), start[2], "site", 0.0 if on_pad else radius)
    work = Work((w.site[0], w.site[1]), w.top_m, 0.0, w.to, radius, 0.0)
    return Request(uav, here, work, None)


def check_fence(c: TableClearance, uav: str, w: FlightRequest) -> None:
    c.fence_refusals.pop(uav, None)
    if c.fence is None:
        return
    start = w.position if w.position is not None else w.site
    problem = flight_fence_problem(c.fence, start, w.site, w.top_m, w.to, c.airspace.layers_m, c.zone_r_m)
    if problem is not None:
        c.fence_refusals[uav] = problem


def stop_where(c: TableClearance, uav: str, u: TableUav, pos: Vec3 | None) -> None:
    """``uav`` stopped its plan where it is (``pos``), turned back for another site: a hover there is its stay
    from now if that clashes with nobody, else it keeps its plan (extended while it is late) until granted. A UAV
    within :data:`~masonry.mission.reserved_parts.ON_LAYER_M` under or over a level leg of its plan hovers at
    the leg's altitude (:func:`~masonry.mission.reserved_parts.level_of`)."""
    where = pos if pos is not None else u.position
    if where is None:
        return
    z = level_of(c.table.of(uav), where, c.now_s)  # (a few centimetres under its layer: on it)
    hover = Reservation(uav, column((where[0], where[1]), z, z, HOVER_R_M), c.now_s, math.inf, "stay")
    if not c.table.clashes(hover):
        c.set_stay(uav, hover.volume, Phase.PARKED)
