"""The blockers the airspace names are what its grant waits for (issue 27: "explain every wait").

:meth:`ColumnClearance.blockers` feeds the report's ``waits`` (``airspace`` and who, with what), the stall report and
the wait-for graph of airspace_yield.py; :func:`masonry.mission.airspace_requests.evaluate` decides the grant. The
earlier requests a request waits its turn behind come from one function for both (``queued_near``): before, the
blockers named every earlier waiting request within the wait radius, while the grant skipped those the site gate
held back (the 12 m wall at 4 + 2, seed 1: glue-2's chained A71 reported ``earlier-request`` for 5.9 s while only
brick-4's hold hover held it; docs/performance/fleet.md, ``wall41``). The hover over the climb out of a site's zone,
which the grant checks (``climb_out``), was not named at all.
"""

from __future__ import annotations

import copy
import math

from hypothesis import event, given, settings
from hypothesis import strategies as st

from airspace_rig import HeldGate, apply_step
from masonry.mission.airspace import ColumnClearance, Phase
from masonry.mission.airspace_requests import evaluate
from masonry.mission.wait_causes import airspace_cause
from masonry.mission.waits import WaitCause
from test_airspace_yield import BEAD, PALLET, _stuck_pair

R = 1.5
BASE = 1.35
S = 1.1
BRICK_SITE = (0.0, 0.0, 1.2)


def _granted_without(c: ColumnClearance, uav: str, gone: set[str], now_s: float) -> bool:
    """``uav``'s request is granted once the UAVs in ``gone`` are out of the airspace (on a copy)."""
    c = copy.deepcopy(c)
    for other in gone:
        c.release(other)
    c.touch()
    return evaluate(c, uav, c.records[uav], now_s).granted


def test_an_earlier_request_the_site_gate_holds_back_is_not_named_only_the_hover_that_holds_the_later_one():
    # brick waits for its site (the gate: another brick's visit beside it) at its hold point; glue asks later for
    # a site within the wait radius of brick's, on the far side of brick's hover: the grant skips brick's request
    # (it waits for work, not the airspace) and waits for the hover in the way of glue's flight down
    gate = HeldGate("brick")
    c = ColumnClearance(R, BASE, S, gate=gate)
    hold = c.request("brick", BRICK_SITE, 0.0, (0.0, -6.0, 1.2))
    assert not hold.granted and hold.hold_m is not None and hold.layer_m is not None
    c.progress("brick", (hold.hold_m[0], hold.hold_m[1], hold.layer_m))
    assert c.phase("brick") is Phase.AT_HOLD
    hx, hy = hold.hold_m[0], hold.hold_m[1]
    d = math.hypot(hx, hy)
    ux, uy = hx / d, hy / d
    site = (0.9 * ux, 0.9 * uy, 1.2)  # 0.9 m from brick's site (within the radius), 0.6 m from its hover
    assert math.hypot(site[0], site[1]) < c.wait_radius_m
    assert not c.request("glue", site, 1.0, (site[0] - 4.0 * ux, site[1] - 4.0 * uy, 1.2)).granted
    assert c.blockers("glue") == [("brick", "hover")]  # (before: ("brick", "earlier-request") first)
    assert _granted_without(c, "glue", {"brick"}, 1.5)  # it is brick's hover that holds glue
    # the gate lets brick in (the visit beside it ended): now its turn comes first as well
    gate.held.clear()
    c.touch()
    assert c.blockers("glue") == [("brick", "earlier-request"), ("brick", "hover")]
    granted = c.grant(2.0)
    assert [(g.uav, g.granted) for g in granted] == [("brick", True)]


#: sites on a coarse grid (often within the wait radius of one another), positions anywhere near them
def test_a_hover_over_the_climb_out_of_the_site_s_zone_is_named():
    # glue's hover moved a layer up to let brick climb out of its zone (airspace_yield.py) and stays there (the
    # site gate holds glue back); x then asks for a site just outside the wait radius of glue's, under that hover:
    # x's flight at layer 0 keeps clear of it, but a UAV in x's zone could not climb out through glue's layer, so
    # the grant waits for glue (``climb_out_free``). Before, the blockers named no one: the report said the
    # airspace held x with no UAV in the way.
    c, at = _stuck_pair()
    assert not c.request("brick", PALLET, 10.0, at).granted
    moved = c.grant(10.1)[0]
    assert moved.uav == "glue" and moved.hold_m is not None and moved.layer_m is not None
    c.progress("glue", (moved.hold_m[0], moved.hold_m[1], moved.layer_m))
    c.gate = HeldGate(
        "glue"
    )  # glue's bead waits for work (the gate) from now on: its hover stays where it is
    c.touch()
    assert [g.uav for g in c.grant(20.0) if g.granted] == ["brick"]
    c.release("brick", at)
    c.progress("brick", (PALLET[0], PALLET[1], c.layer_m("brick")))
    c.end_transit("brick")
    hx, hy = moved.hold_m[0], moved.hold_m[1]
    d = math.hypot(hx - BEAD[0], hy - BEAD[1])
    ux, uy = (hx - BEAD[0]) / d, (hy - BEAD[1]) / d
    site = (BEAD[0] + 1.25 * ux, BEAD[1] + 1.25 * uy, 1.2)
    assert c.wait_radius_m < 1.25 and math.hypot(site[0] - hx, site[1] - hy) < c.sep_xy_m
    held = c.request("x", site, 21.0, (site[0] + 3.0 * ux, site[1] + 3.0 * uy, 1.2))
    assert not held.granted and held.hold_m is not None and held.layer_m is not None
    c.progress("x", (held.hold_m[0], held.hold_m[1], held.layer_m))
    assert c.phase("x") is Phase.AT_HOLD and c.grant(22.0) == []
    assert c.blockers("x") == [("glue", "hover")]
    assert _granted_without(c, "x", {"glue"}, 22.5)


SITES = st.tuples(st.sampled_from([-2.0, -1.0, -0.5, 0.0, 0.5, 1.0, 2.0]), st.sampled_from([-1.0, 0.0, 1.0]))
POSITIONS = st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))
UAVS = ("a", "b", "c", "d")
#: requests, arrivals (at a site, at a hold point) and the gate's changes more often than the rest
OPS = ("req", "req", "req", "end", "end", "hold", "hold", "gate", "gate", "away", "move", "lost")


def _check_blockers(c: ColumnClearance, gate: HeldGate, name: str, t: float) -> None:
    """``name`` waits where it is (asking, or at its hold point) and the gate lets it in: the UAVs the airspace
    names are what its grant waits for."""
    w = c.records[name].request
    assert w is not None
    named = c.blockers(name)
    for kind in {k for _n, k in named}:
        event(f"named {kind}")
    if any(
        o.request is not None
        and o.request.seq < w.seq
        and not gate.may_enter(n, o.request.site)
        and math.hypot(o.request.site[0] - w.site[0], o.request.site[1] - w.site[1]) < c.wait_radius_m
        for n, o in c.records.items()
    ):
        event("an earlier request near it the gate holds back (not named)")
    for other, kind in named:
        o = c.records[other]
        assert other != name
        if kind == "earlier-request":  # asked first, near, and its own turn may come (the gate lets it in)
            assert o.request is not None and o.request.seq < w.seq
            assert gate.may_enter(other, o.request.site)
            assert math.hypot(o.request.site[0] - w.site[0], o.request.site[1] - w.site[1]) < c.wait_radius_m
            # first come, first served: with every other blocker gone, this one still holds it
            assert not _granted_without(c, name, {n for n, _k in named if n != other}, t)
        else:
            assert any(q.kind == kind for q in o.volumes)
    # with every UAV named gone (none: as it is), the request is granted
    assert _granted_without(c, name, {n for n, _k in named}, t), (name, named)


@settings(max_examples=300, deadline=None)
@given(
    st.lists(
        st.tuples(st.sampled_from(UAVS), st.sampled_from(OPS), SITES, POSITIONS, st.floats(1.2, 2.4)),
        max_size=30,
    )
)
def test_every_blocker_named_is_waited_for_and_a_request_with_none_is_granted(ops):
    gate = HeldGate()
    c = ColumnClearance(R, BASE, S, gate=gate)
    t = 0.0
    for uav, op, site, pos, top in ops:
        t += 1.0
        apply_step(c, uav, op, site, pos, top, t, gate=gate)
        c.grant(t)
        assert c.conflicts() == []
        for name, u in c.records.items():
            w = u.request
            if w is not None and u.phase in (Phase.ASKING, Phase.AT_HOLD) and gate.may_enter(name, w.site):
                _check_blockers(c, gate, name, t)


def test_a_uav_flying_to_its_hold_point_waits_to_hold_until_it_arrives_then_for_what_is_in_the_way():
    # b is sent to a hold point (a works at the site beside its own); a leaves while b is on its way: nothing is
    # in the way of the rest, but the answer waits for b's arrival (before, the wait named no one: the 12 m
    # wall at 4 + 2, seed 1, 44 task-seconds); e's leg, granted meanwhile, is then what the grant waits for
    tasks = {"a": "A1", "b": "B3", "e": "A9"}
    c = ColumnClearance(R, BASE, S)
    assert c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, 0.0, 1.2)).granted
    c.end_transit("a")
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert not b.granted and b.hold_m is not None and b.layer_m is not None
    assert c.phase("b") is Phase.TO_HOLD
    assert airspace_cause(c, "b", tasks.get, "air") == WaitCause("airspace", "a", "A1", "zone", "b", "air")
    c.release("a")
    assert c.blockers("b") == [] and c.grant(2.0) == []  # nothing in the way: b is not at its hold point yet
    assert airspace_cause(c, "b", tasks.get, "air") == WaitCause(
        "airspace", holds="to-hold", uav="b", where="air"
    )
    assert c.request("e", (-3.0, 0.0, 1.2), 2.5, (3.0, 0.0, 1.2)).granted  # its leg crosses b's way down
    c.progress("b", (b.hold_m[0], b.hold_m[1], b.layer_m))
    assert c.phase("b") is Phase.AT_HOLD and c.grant(3.0) == []
    assert airspace_cause(c, "b", tasks.get, "air") == WaitCause("airspace", "e", "A9", "leg", "b", "air")
    assert _granted_without(c, "b", {"e"}, 3.5)  # it is e's leg that holds b now
    assert c.conflicts() == []
