"""The airspace's request decision: a UAV's flight granted, a hold flight near its site, or "hover where you are".

Part of :class:`~masonry.mission.airspace.ColumnClearance` (its rules: the class docstring and docs/safety.md).
:func:`request` takes a UAV's request into the queue; :func:`evaluate` answers it at the lowest layer that fits,
first come, first served (:func:`queued_before`), else with a hold flight (:func:`hold_flight`: the hold-point
choice), else it hovers where it stopped (:func:`hover_where`). A flight no layer can fly inside the fence is
refused with the reason (:func:`check_fence`). Pure: no I/O, no clock.
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from masonry.geofence import AIRSPACE_MARGIN_M
from masonry.mission.airspace_approach import approach
from masonry.mission.airspace_state import (
    OFF_LAYER,
    FlightRequest,
    Grant,
    GrantedFlight,
    HoldFlight,
    Phase,
    UavAirspace,
    hold_candidates,
    request_geometry,
)
from masonry.mission.airspace_yield import make_way
from masonry.mission.fence import flight_fence_problem
from masonry.mission.linger_airspace import linger_spans, linger_spots
from masonry.mission.sites import enter_ungoverned
from masonry.mission.volumes import (
    Vec3,
    Volume,
    contains,
    flight_volumes,
    leave_from,
    on_leg,
    point_segment_m,
    same_site,
    stopped_at,
    volumes_clear,
)
from masonry.separation import fast_leg_excess_m

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance

__all__ = [
    "LINGER_RING_STEP_M",
    "check_fence",
    "climb_out",
    "evaluate",
    "few_airborne",
    "granted",
    "hold_flight",
    "hold_side",
    "hover_where",
    "landed_alike",
    "landed_covered",
    "off_layer_m",
    "queued_before",
    "queued_near",
    "request",
]


#: The rings of a lingering UAV's spots this far apart (from the wait radius out): the spots must keep 1.1 wait
#: radii from every site still to be worked, so on a wall one site thick the 1.5 m rings around where it
#: stopped held none but 3 m along the wall past its end; 1.75 m off the wall's face is one (issue 27).
LINGER_RING_STEP_M = 0.25


def request(
    c: ColumnClearance,
    uav: str,
    site_m: Vec3,
    now_s: float,
    position_m: Vec3 | None = None,
    top_m: float | None = None,
    to_m: Vec3 | None = None,
) -> Grant:
    """``uav`` (now at ``position_m``) sets off for ``site_m``, where it will work up to ``top_m`` (and along
    to ``to_m``: an adhesion UAV sprays from its site to there).

    (:meth:`ColumnClearance.request`, which says what a repeated or a replaced request gets.)
    """
    site, top, pos = request_geometry(site_m, top_m, position_m)
    if c.base_m is None:  # no airspace rules: only the site gate may hold the flight back
        ok = enter_ungoverned(c.gate, uav, site, now_s)
        c.granted_count += ok
        c.refused += not ok
        return Grant(uav, site, ok)
    u = c.record(uav)
    if pos is not None:  # (a few centimetres past its zone or off its leg: it leaves from there, volumes.py)
        pos = on_leg((*leave_from((pos[0], pos[1]), u.volumes), pos[2]), u.volumes)
    c.handed_task.discard(uav)  # (it asks again: for its task's site, or home if the task was taken back)
    if u.flight is not None:
        if same_site(u.flight.site, site) and (pos is None or contains(u.volumes, *pos)):
            return Grant(uav, site, layer_m=u.flight.layer_m, gentle=u.flight.gentle)
        # turned back for another site, or asks again from outside the flight it was given (a retry after a
        # failsafe flew it off): it keeps the volumes of that flight until a fresh one is granted
        u.flight = None
        u.phase = Phase.PARKED
    if u.phase is Phase.AT_HOLD and pos is not None:
        at_rest_at_hold(c, u)
    w = u.request
    if w is not None and same_site(w.site, site):
        if pos is not None and u.phase is Phase.ASKING and pos != w.position:
            u.request = dataclasses.replace(w, position=pos)
            u.seen_version = -1  # where it asks from changed: look again
        return evaluate(c, uav, u, now_s)
    if pos is not None and u.zone is None:
        hover_where(c, uav, pos)  # it turned back mid-flight: it stays where it is until answered
    to = None
    if to_m is not None and math.hypot(float(to_m[0]) - site[0], float(to_m[1]) - site[1]) > 1e-6:
        to = (float(to_m[0]), float(to_m[1]))
    c.seq += 1
    u.request, u.hold, u.phase = FlightRequest(site, top, pos, now_s, c.seq, to), None, Phase.ASKING
    check_fence(c, uav, u.request)
    u.seen_version, u.answer = -1, None
    c.touch()  # the queue changed: answers of those behind it may change
    return evaluate(c, uav, u, now_s)


def evaluate(c: ColumnClearance, uav: str, u: UavAirspace, now_s: float) -> Grant:
    """Grant ``uav``'s flight if it fits, else a hold flight, else "hover where you are"."""
    w = u.request
    assert w is not None
    if u.seen_version == c.version and u.answer is not None:
        return u.answer
    u.seen_version = c.version
    if uav in c.handed_task and u.hold is not None:
        # handed a task while it waited near the wall: it is about to ask for its site, so its flight home is
        # not granted meanwhile (that flight's volumes, towards its pad, would stay its own until its flight to
        # the site is granted, in the way of the UAVs working near the site: issue 27)
        u.answer = Grant(uav, w.site, False, u.hold.point_m, u.hold.layer_m)
        return u.answer
    refused = c.fence_refusals.get(uav)
    if refused is not None and u.phase is Phase.ASKING:
        c.refused += 1
        u.answer = Grant(uav, w.site, False, refused=refused)
        return u.answer
    lingers = linger_spans(c, uav, w.site) is not None  # its flight home held back: it waits near here
    blocked_site = (
        lingers
        or bool(queued_near(c, w))  # (first come, first served)
        or (c.gate is not None and not c.gate.may_enter(uav, w.site))
    )
    if not blocked_site:
        home = c.is_home(uav, w.site)
        if u.phase is Phase.AT_HOLD or (
            u.phase is Phase.TO_HOLD and u.hold is not None and u.hold.straight and few_airborne(c, uav)
        ):
            # hovering at its hold point (it said so): from there, to the lowest layer that fits now, over to
            # the site and down. Not before: a UAV flies its hold flight to the end before it reads another
            # answer, and one that never saw its hold answer (a later one came first) would fly straight.
            # On its way to a nearer hold point on its line to the site (airspace_approach.py) straight on is
            # that same line: at the same layer, the rest of the flight may be granted before it is there.
            assert u.hold is not None
            hold = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
            layers = range(c.max_layers) if u.phase is Phase.AT_HOLD else (u.hold.layer,)
            for k in layers:
                if u.phase is Phase.TO_HOLD and abs(c.alt(k) - u.hold.layer_m) > 1e-9:
                    break  # (the layer base rose since: the rest would climb at the hold point)
                extra = c.flight_volumes_at(hold, w.site, w.top_m, k, None, w.to, home=home)
                if c.fits(uav, extra) and climb_out_free(c, uav, extra):
                    fast = fast_end(c, uav, extra, home)
                    u.volumes = u.volumes + (fast or extra)
                    c.touch()
                    return granted(c, uav, u, k, now_s, gentle=fast is None)
        elif u.phase is Phase.ASKING:
            start = w.position if w.position is not None else w.site
            for k in range(c.max_layers):
                vols = c.flight_volumes_at(start, w.site, w.top_m, k, None, w.to, home=home)
                if c.fits(uav, vols) and climb_out_free(c, uav, vols):
                    fast = fast_end(c, uav, vols, home)
                    c.take(u, fast or vols)
                    return granted(c, uav, u, k, now_s, gentle=fast is None)
    if u.phase is Phase.ASKING:
        g = hold_flight(c, uav, u)
        if g is None and lingers:  # nowhere to wait near here now: it flies home as it asked
            c.lingering.pop(uav, None)
            c.touch()
            return evaluate(c, uav, u, now_s)
        if g is not None:
            u.answer = g
            c.held_back += 1
            return g
        c.refused += 1
        u.answer = Grant(uav, w.site, False)
        return u.answer
    assert u.hold is not None
    # in the way of a UAV leaving from where it stays: it moves first (airspace_yield.py), else closes in
    nearer = make_way(c, uav, u) or (approach(c, uav, u) if not blocked_site else None)
    u.answer = nearer or Grant(uav, w.site, False, u.hold.point_m, u.hold.layer_m)
    return u.answer


def climb_out_free(c: ColumnClearance, uav: str, vols: list[Volume]) -> bool:
    """The zone a flight ends in has its column clear up through every layer of the other UAVs' hold hovers: a
    UAV there can always climb out. A zone granted under a hover 1.1 m over its top (clear of it) could not be
    left at any layer while that UAV waited for the zone's site (``bench_layouts --large`` seed 3143)."""
    way_up = climb_out(c, uav, vols)
    if way_up is None:
        return True
    up, hovers = way_up
    return volumes_clear([up], [q for _n, q in hovers], c.sep_xy_m, c.spacing_m - 1e-9)


def climb_out(
    c: ColumnClearance, uav: str, vols: list[Volume]
) -> tuple[Volume, list[tuple[str, Volume]]] | None:
    """The column up out of the zone ``vols`` end in, through every layer, and the hovers that may be in its way
    with their UAVs: those of UAVs waiting for a site near the zone (they may wait for this UAV). None: the
    flight ends in no zone. (:func:`climb_out_free`; :func:`masonry.mission.airspace_queries.blockers` names
    those in the way.)"""
    z = vols[-1]
    if z.kind != "zone":
        return None
    up = dataclasses.replace(z, z1_m=max(z.z1_m, c.alt(c.max_layers - 1)))
    near = 1.1 * c.wait_radius_m
    hovers = [
        (n, q)
        for n, o in c.records.items()
        if n != uav and o.request is not None and point_segment_m(o.request.site[:2], z.a, z.b) < near
        for q in o.volumes
        if q.kind == "hover"
    ]
    return up, hovers


def fast_end(c: ColumnClearance, uav: str, vols: list[Volume], home: bool = False) -> list[Volume] | None:
    """``vols`` with their end (the site's column, or the hold hover) widened by a fast leg's overshoot past the
    tracking share, if that still keeps clear of every other UAV's reservation: the UAV may fly its lateral leg
    there at its own limits (``Grant.gentle`` False), and no UAV is granted a volume in the overshoot until it has
    arrived (the end is set anew then). None: something of another UAV's is near that end, the leg is flown
    gently (docs/safety.md, "Tracking error on a real autopilot"). Into its pad's column a UAV always flies gently.
    """
    end = vols[-1]
    excess = fast_leg_excess_m(end.slack_m)
    if home or end.kind not in ("zone", "hover"):
        return None
    if excess <= 0.0 or not any(v.kind == "leg" for v in vols):
        return vols  # (the end's slack covers the overshoot, or there is no lateral leg to overshoot)
    wide = [*vols[:-1], dataclasses.replace(end, slack_m=end.slack_m + excess)]
    return wide if c.fits(uav, wide) else None


def at_rest_at_hold(c: ColumnClearance, u: UavAirspace) -> None:
    """A UAV asks from its hold point (it asks at rest there): a hover widened for a fast leg's overshoot
    (:func:`fast_end`, kept while a heartbeat may have placed it there still moving) is its own width again."""
    if len(u.volumes) == 1 and u.volumes[0].kind == "hover" and u.volumes[0].slack_m > c.zone_slack_m:
        u.volumes = [dataclasses.replace(u.volumes[0], slack_m=c.zone_slack_m)]
        c.touch()


def granted(
    c: ColumnClearance, uav: str, u: UavAirspace, k: int, now_s: float, *, gentle: bool = True
) -> Grant:
    w = u.request
    assert w is not None
    u.flight = GrantedFlight(w.site, k, c.alt(k), w.top_m, w.to, gentle)
    u.request, u.hold, u.phase = None, None, Phase.FLYING
    waited = max(0.0, now_s - w.since_s)
    c.wait_s += waited
    c.max_wait_s = max(c.max_wait_s, waited)
    c.granted_count += 1
    c.layer_counts[k] = c.layer_counts.get(k, 0) + 1
    c.touch()
    if c.gate is not None:
        c.gate.entered(uav, w.site, now_s)
    return Grant(uav, w.site, layer_m=c.alt(k), gentle=gentle)


def hold_flight(c: ColumnClearance, uav: str, u: UavAirspace) -> Grant | None:
    """A flight to a hold point near the site, at the lowest layer that fits (None: none fits now)."""
    w = u.request
    assert w is not None
    start = w.position if w.position is not None else w.site
    others = [o for n, o in c.records.items() if n != uav]
    pads = [
        (h[0], h[1])
        for n, h in c.homes.items()
        if n != uav and not (landed_alike(c, uav, n) or landed_covered(c, uav, n))
    ]
    waited = () if c.gate is None else c.gate.waited_on(uav)
    keep_clear = linger_spans(c, uav, w.site)
    if keep_clear is None:
        candidates = hold_candidates(
            w.site, others, c.wait_radius_m, pads, waited, from_m=hold_side(c, uav, start)
        )
    else:  # waiting for a task near where it is, clear of the work still to do (mission/linger.py)
        candidates = hold_candidates(
            start, others, c.wait_radius_m, pads, (*waited, *keep_clear), ring_step_m=LINGER_RING_STEP_M
        )
        candidates = linger_spots(c, uav, start, candidates, keep_clear)
    if c.fence is not None:  # only hold points inside it (else near an edge all six could be outside)
        need = AIRSPACE_MARGIN_M + c.zone_slack_m
        candidates = [h for h in candidates if c.fence.contains(h[0], h[1], need)]
    for k in range(c.max_layers):
        for hold in candidates[:6]:
            vols = c.flight_volumes_at(start, None, w.top_m, k, (hold[0], hold[1]))
            if c.fits(uav, vols):
                fast = fast_end(c, uav, vols)
                c.take(u, fast or vols)
                straight = (
                    point_segment_m((hold[0], hold[1]), (start[0], start[1]), (w.site[0], w.site[1])) < 0.01
                )
                u.hold, u.phase = HoldFlight(hold, k, c.alt(k), straight), Phase.TO_HOLD
                c.layer_counts[k] = c.layer_counts.get(k, 0) + 1
                return Grant(uav, w.site, False, hold, c.alt(k), gentle=fast is None)
    alt = off_layer_m(c, w)
    if alt is None:
        return None
    for hold in candidates[:6]:  # no layer fits: at the altitude it is at (no climb), if that fits
        vols = flight_volumes(
            (start[0], start[1]), alt, alt, None, w.top_m, (hold[0], hold[1]), None, c.zone_slack_m
        )
        if c.fits(uav, vols):
            c.take(u, vols)
            u.hold, u.phase = HoldFlight(hold, OFF_LAYER, alt), Phase.TO_HOLD
            c.layer_counts[OFF_LAYER] = c.layer_counts.get(OFF_LAYER, 0) + 1
            return Grant(uav, w.site, False, hold, alt)
    return None


def landed_alike(c: ColumnClearance, uav: str, other: str) -> bool:
    """``other`` stands on its pad and is of ``uav``'s role: a hold point of ``uav``'s may lie by that pad (docs/
    safety.md, "A hold point by the pad of a landed UAV of its role"). The hover keeps ``other`` down until it
    leaves, but ``other`` takes none of the tasks ``uav``'s task waits on (a task's prerequisites are of the other
    role), and what ``uav`` waits for is work or flights of UAVs that are out; an idle second sprayer's pad moved
    the first one's hold point into the brick UAV's leg (``bench_layouts.py --compact`` seed 2, 1 + 2: +15.4 s)."""
    o, role = c.records.get(other), c.roles.get(uav)
    return o is not None and o.phase is Phase.LANDED and role is not None and c.roles.get(other) == role


def landed_covered(c: ColumnClearance, uav: str, other: str) -> bool:
    """``other`` stands on its pad, is of the other role than ``uav``'s, and another UAV of ``other``'s role is out
    (not on its pad): a hold point of ``uav``'s may lie by that pad too (docs/safety.md, "A hold point by the pad of
    a landed UAV of its role", issue 27 §4, branch ``compact47``). What ``uav``'s task may wait on from ``other``'s
    role (a prerequisite) is left to the one out, whose pad stays clear; an idle second brick UAV's pad moved the
    sprayer's hold point into the brick UAV's leg to the pallet (``bench_layouts.py --compact`` seed 13, 2 + 1:
    +12.2 s over 1 + 1 with it kept clear)."""
    o, role, theirs = c.records.get(other), c.roles.get(uav), c.roles.get(other)
    if o is None or o.phase is not Phase.LANDED or role is None or theirs is None or theirs == role:
        return False
    return any(
        n != other and r == theirs and (rec := c.records.get(n)) is not None and rec.phase is not Phase.LANDED
        for n, r in c.roles.items()
    )


def off_layer_m(c: ColumnClearance, w: FlightRequest) -> float | None:
    """The altitude a UAV asking from mid-air off the layers (a leg flown at a layer before the layer base rose)
    may fly its hold flight at, if no layer fits: where it is, over layer 0 (so over all that is built), else None.

    It kept its altitude when the base rose, and the UAVs granted since keep their 1.1 m from it: one hovering 1.1 m
    over its leg, a zone whose top is 1.1 m under it, and every layer's climb or descent from there passes one of
    them (``bench_layouts --large`` seed 3275: an adhesion UAV that turned back on its way home, its leg 2.85 m high,
    the base risen from 1.75 to 1.85 m; it waited, holding the leg home over the zone of the brick UAV it waited
    for, whose climb out that leg blocked, 240 s).
    """
    if w.position is None or c.layer_base_m is None:
        return None
    z = w.position[2]
    return z if c.snap(z) == z and z > c.alt(0) else None


def hold_side(c: ColumnClearance, uav: str, start: Vec3) -> Vec3 | None:
    """Where ``uav``'s hold points are ordered from (each ring's nearest to it first), or None (by their angle).

    Nearest ``uav`` first only while at most one other UAV is in the air (issue 27): a hold point round the far
    side of its site made a brick UAV back from the pallet fly past its site and stop there (the pyramid at 1 + 1
    -5.6 %), and the one other UAV in the air is the one it waits for, which leaves. With more in the air a hold
    point on the UAV's side lies where the others fly between their sites and the pallet: the 12 m wall at 4 + 2
    was up to 17 % slower with it, so the points keep their old order there (docs/safety.md).
    """
    return start if few_airborne(c, uav) else None


def few_airborne(c: ColumnClearance, uav: str) -> bool:
    """At most one UAV but ``uav`` is in the air (the one it waits for, at 1 + 1): the rules for the hand-over
    between two UAVs hold (:func:`hold_side`, :func:`masonry.mission.airspace_approach.approach`, a straight hold
    flight's rest granted on the way)."""
    return sum(1 for n, o in c.records.items() if n != uav and o.phase is not Phase.LANDED and o.volumes) <= 1


def hover_where(c: ColumnClearance, uav: str, pos: Vec3) -> None:
    """``uav`` stopped at ``pos`` (it asks from there, hovering): only a small volume there is its now, if
    that fits (it should: it was inside its volumes), else it keeps what it held."""
    u = c.records.get(uav)
    vols = None if u is None else u.volumes
    if not vols or u is None:
        return
    if len(vols) == 1 and vols[0].kind == "hover":
        return
    here = stopped_at((pos[0], pos[1]), c.snap(pos[2]), vols)
    if c.free(uav, here):
        u.volumes = here
        u.origin = None
        c.touch()


def check_fence(c: ColumnClearance, uav: str, w: FlightRequest) -> None:
    """Note why ``uav``'s new request can never be flown inside the fence, if it cannot (at no layer)."""
    c.fence_refusals.pop(uav, None)
    if c.fence is None:
        return
    start = w.position if w.position is not None else w.site
    start = (start[0], start[1], c.snap(start[2]))
    layers = [c.alt(k) for k in range(c.max_layers)]
    problem = flight_fence_problem(c.fence, start, w.site, w.top_m, w.to, layers, c.zone_slack_m)
    if problem is not None:
        c.fence_refusals[uav] = problem


def queued_before(c: ColumnClearance, seq: int) -> list[tuple[str, FlightRequest]]:
    """The requests made before ``seq`` that wait for the airspace, with their UAVs: one the :class:`SiteGate`
    holds back (its site is busy with conflicting work, or its prerequisites are not done) waits for work, not
    for the airspace, and keeps no one else from coming down near its site (else the two could wait for each
    other: an adhesion UAV waiting for the brick under its segment, whose UAV waited for the adhesion UAV's turn)."""
    gate = c.gate
    return [
        (n, u.request)
        for n, u in c.waiting_records()
        if u.request is not None
        and u.request.seq < seq
        and (gate is None or gate.may_enter(n, u.request.site))
        and n not in c.lingering  # (its flight home is held back: it waits for a task, not the airspace)
    ]


def queued_near(c: ColumnClearance, w: FlightRequest) -> list[str]:
    """The UAVs whose turn ``w`` waits for (first come, first served): those of the requests made before it for a
    site within the wait radius of its own that wait for the airspace (:func:`queued_before`). A flight down to
    ``w``'s site is granted only while there are none (:func:`evaluate`); they are the ``earlier-request``
    blockers the reports name (:func:`masonry.mission.airspace_queries.blockers`), so the two cannot disagree
    (a request the site gate held back was named, and held no one: issue 27)."""
    return [
        n
        for n, e in queued_before(c, w.seq)
        if math.hypot(e.site[0] - w.site[0], e.site[1] - w.site[1]) < c.wait_radius_m
    ]
