"""Airspace separation (docs/safety.md): site columns and transit layers, from the pure rules to whole missions."""

from __future__ import annotations

import math
from dataclasses import dataclass

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fsm_rig import HOME, PICKUP, Rig
from masonry.blueprint_gen import running_bond, towers
from masonry.errors import ProtocolError
from masonry.fakes import QueueMissionLink
from masonry.mission.airspace import ColumnClearance, layer_base_m, transit_layers_m, work_altitude_m
from masonry.mission.messages import MISSION_CONTROL, Clearance, ClearanceRequest, decode, encode
from masonry.mission.simulate import simulate

R = 1.5
BASE = 1.35
S = 1.1

#: The bound every whole-mission simulation must keep between two airborne UAVs (centre to centre).
SEPARATION_BOUND_M = 1.0


def _xy(p):
    return (p[0], p[1])


# -- the pure rules ---------------------------------------------------------------------------------------------
def test_a_column_within_the_radius_waits_at_a_hold_point_outside_every_column():
    c = ColumnClearance(R, BASE, S)
    a = c.request("a", (0.0, 0.0, 1.2), 0.0, (5.0, 0.0, 1.2))
    assert a.granted
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert not b.granted and b.hold_m is not None
    assert math.dist(_xy(b.hold_m), (0.0, 0.0)) >= 1.1 * R - 1e-9
    assert c.grant(2.0) == []  # still held
    c.end_transit("a")  # a is down at its site...
    assert c.grant(2.5) == []
    c.release("a", (0.0, 0.0, 1.2))  # ... and has left it
    g = c.grant(3.0)
    assert [x.uav for x in g] == ["b"] and g[0].granted
    assert c.max_wait_s == pytest.approx(2.0) and c.held_back == 1


def test_columns_apart_are_both_granted_and_a_repeated_request_gets_the_same_answer():
    c = ColumnClearance(R, BASE, S)
    assert c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -4.0, 1.2)).granted
    assert c.request("b", (R + 0.01, 0.0, 1.2), 0.0, (3.0, -4.0, 1.2)).granted
    again = c.request("a", (0.0, 0.0, 1.2), 1.0, (0.0, -4.0, 1.2))
    assert again.granted and again.layer_m == c.layer_m("a")
    assert set(c.held) == {"a", "b"}


def test_layer_zero_only_for_a_path_clear_of_other_columns_else_the_uavs_own_layer():
    c = ColumnClearance(R, BASE, S)
    assert c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, 0.0, 1.2)).granted
    c.end_transit("a")  # a works in its column at (0, 0)
    far = c.request("b", (10.0, 5.0, 1.2), 0.0, (10.0, 0.0, 1.2))
    assert far.granted and far.layer_m == pytest.approx(BASE)  # nobody near: layer 0, just above the work altitude
    c.end_transit("b")
    over = c.request("c", (3.0, 0.6, 1.2), 1.0, (-3.0, 0.3, 1.2))  # passes 0.45 m from a's column
    assert over.granted and over.layer_m >= BASE + S - 1e-9
    d = c.request("d", (0.3, 3.0, 1.2), 2.0, (0.0, -3.0, 1.2))  # over a too, and across c (not near its ends)
    assert d.granted and d.layer_m >= BASE + S - 1e-9
    assert abs(d.layer_m - over.layer_m) >= S - 1e-9  # two UAVs above layer 0: never the same layer


def _crossing_setup(c):
    assert c.request("x", (0.0, 0.0, 1.2), 0.0, (0.0, 0.0, 1.2)).granted
    c.end_transit("x")  # x works in its column at (0, 0)
    a = c.request("a", (3.0, 0.6, 1.2), 0.0, (-3.0, 0.3, 1.2))  # passes x: not layer 0
    assert a.granted and a.layer_m == pytest.approx(BASE + S)


def test_a_flight_takes_the_lowest_layer_on_which_it_crosses_nobody():
    c = ColumnClearance(R, BASE, S)
    _crossing_setup(c)
    # b sets off from (0, 0.9), right under a's path: on layer 2 it would climb through a's layer 1 there, and
    # layer 1 is a's: not now
    b = c.request("b", (0.0, 4.0, 1.2), 1.0, (0.0, 0.9, 1.2))
    assert not b.granted and b.hold_m is None and b.layer_m is None and c.refused == 1
    c.end_transit("a")  # a is down at its site
    b = c.request("b", (0.0, 4.0, 1.2), 2.0, (0.0, 0.9, 1.2))
    assert b.granted and b.layer_m == pytest.approx(BASE + S)
    # a flight that passes over b's climb point takes a layer above b's
    d = c.request("d", (5.0, 1.2, 1.2), 3.0, (-5.0, 1.0, 1.2))
    assert d.granted and d.layer_m == pytest.approx(BASE + 2 * S)


def test_a_uav_held_back_is_kept_clear_of_and_flies_anyway_after_the_limit():
    c = ColumnClearance(R, BASE, S)
    c.max_refusal_s = 5.0
    _crossing_setup(c)
    assert not c.request("b", (0.0, 4.0, 1.2), 1.0, (0.0, 0.9, 1.2)).granted
    # while b hovers at (0, 0.9) a layer-0 flight may not pass there
    e = c.request("e", (2.0, 2.0, 1.2), 2.0, (-2.0, 2.0, 1.2))
    assert e.granted and e.layer_m > BASE + 1e-9
    assert c.request("b", (0.0, 4.0, 1.2), 6.5, (0.0, 0.9, 1.2)).granted
    assert c.forced == 1


def test_a_lost_uav_frees_everything_and_a_given_up_request_stops_blocking():
    c = ColumnClearance(R, BASE, S)
    c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -3.0, 1.2))
    hold = c.request("b", (0.3, 0.0, 1.2), 0.0, (0.0, 3.0, 1.2)).hold_m
    assert hold is not None
    c.release("b", (0.3, 0.0, 1.2))  # b gave up (it was sent elsewhere)
    assert c.waiting == ()
    c.release("a")  # a is lost
    assert c.held == {} and c.layers == {}
    assert c.request("c", (0.2, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2)).granted


SITES = st.tuples(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0))


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.sampled_from(["a", "b", "c", "d"]), st.sampled_from(["req", "rel", "end", "tick"]),
                          SITES, SITES), max_size=40))
def test_columns_never_overlap_and_layers_above_zero_are_never_shared(ops):
    c = ColumnClearance(R, BASE, S)
    t = 0.0
    for uav, op, site, pos in ops:
        t += 1.0
        if op == "req":
            c.request(uav, (*site, 1.2), t, (*pos, 1.2))
        elif op == "rel":
            for h in c.held.get(uav, ()):
                c.release(uav, h)
        elif op == "end":
            c.end_transit(uav)
        c.grant(t)
        cols = [(u, h) for u, hs in c.held.items() for h in hs]
        for i, (u1, h1) in enumerate(cols):
            for u2, h2 in cols[i + 1:]:
                if u1 != u2:
                    assert math.dist(_xy(h1), _xy(h2)) >= R - 1e-9, (u1, h1, u2, h2)
        high = [k for k in c.layers.values() if k > 0]
        assert len(high) == len(set(high))


def test_layers_start_at_the_highest_work_altitude():
    bp = running_bond(3, 4, brick_uavs=2, adhesion_uavs=1)
    base = layer_base_m(bp)
    assert base >= work_altitude_m(bp) >= bp.cruise_altitude_m
    fixed = transit_layers_m(bp)
    assert sorted(fixed.values()) == pytest.approx([base + (k + 1) * 1.1 for k in range(len(bp.fleet))])


# -- the protocol -----------------------------------------------------------------------------------------------
def test_clearance_messages_round_trip_and_only_mission_control_grants():
    fleet = {"brick-1"}
    msgs = [
        ClearanceRequest("brick-1", (1.0, 2.0, 1.2), 3.5, (0.0, 0.0, 1.3)),
        ClearanceRequest("brick-1", (1.0, 2.0, 1.2), 4.0, release=True),
        ClearanceRequest("brick-1", (1.0, 2.0, 1.2), 4.5, arrived=True),
        Clearance(MISSION_CONTROL, "brick-1", (1.0, 2.0, 1.2), 1.5, 3.6, True, None, 2.45),
        Clearance(MISSION_CONTROL, "brick-1", (1.0, 2.0, 1.2), 1.5, 3.6, False, (4.0, 2.0, 1.2), 2.45),
    ]
    for m in msgs:
        assert decode(encode(m), fleet) == m
    with pytest.raises(ProtocolError, match="only 'mission-control'"):
        decode(encode(Clearance("brick-1", "brick-1", (0.0, 0.0, 0.0), 1.5, 0.0)), fleet)
    with pytest.raises(ProtocolError, match="not a UAV"):
        decode(encode(ClearanceRequest("intruder", (0.0, 0.0, 0.0), 0.0)), fleet)


# -- the state machine ------------------------------------------------------------------------------------------
@dataclass
class _Answer:
    granted: bool
    layer_m: float | None
    hold_m: tuple[float, float, float] | None = None


class ClearanceLink(QueueMissionLink):
    """A link whose mission control answers after ``answer_after_s`` and grants the column at ``grant_after_s``."""

    def __init__(self, tasks, clock, *, layer_m=2.6, answer_after_s=0.0, grant_after_s=0.0, hold_m=None):
        super().__init__(tasks)
        self.clock = clock
        self.layer_m = layer_m
        self.answer_after_s = answer_after_s
        self.grant_after_s = grant_after_s
        self.hold_m = hold_m
        self.asked: dict[tuple[float, float, float], float] = {}
        self.arrived: list[tuple[float, float, float]] = []

    def request_clearance(self, site_m):
        first = self.asked.setdefault(tuple(site_m), self.clock.now_s())
        waited = self.clock.now_s() - first
        if waited < self.answer_after_s:
            return None
        if waited < self.grant_after_s:
            return _Answer(False, self.layer_m, self.hold_m)
        return _Answer(True, self.layer_m)

    def end_transit(self, site_m):
        self.arrived.append(tuple(site_m))


def _rig_with(link_kwargs):
    rig = Rig("brick")
    link = ClearanceLink([rig.link.poll_task()], rig.clock, **link_kwargs)
    rig.link = rig.uav.link = link
    rig.uav._request_clearance = link.request_clearance
    return rig, link


def test_lateral_legs_fly_at_the_given_layer_and_wait_for_the_answer_where_they_are():
    rig, link = _rig_with({"layer_m": 2.6, "answer_after_s": 3.0})
    track = []
    rig.run(max_s=400.0, on_tick=lambda r: track.append((r.clock.now_s(), *r.fc.position_m, r.uav.state)))
    assert [x.status for x in link.results] == ["done"]
    # before mission control answers, the UAV does not leave: it hovers over home
    asked = min(link.asked.values())
    early = [p for p in track if asked <= p[0] < asked + 2.9]
    assert early and all(math.hypot(p[1] - HOME[0], p[2] - HOME[1]) < 0.1 for p in early)
    # every lateral move (more than 0.5 m from both home and the pickup, on the way out) is at the layer
    out = [p for p in track if p[4] == "pickup_goto" and math.hypot(p[1] - HOME[0], p[2] - HOME[1]) > 0.5
           and math.hypot(p[1] - PICKUP[0], p[2] - PICKUP[1]) > 0.5]
    assert out and all(abs(p[3] - 2.6) < 0.1 for p in out)
    assert PICKUP[:2] in [s[:2] for s in link.arrived]  # it said when it was down at the pickup


def test_a_uav_without_the_column_waits_at_its_layer_over_the_hold_point():
    hold = (1.0, -1.0, 1.2)
    rig, link = _rig_with({"layer_m": 2.6, "grant_after_s": 40.0, "hold_m": hold})
    track = []
    rig.run(max_s=400.0, on_tick=lambda r: track.append((r.clock.now_s(), *r.fc.position_m, r.uav.state)))
    assert [x.status for x in link.results] == ["done"]
    first = min(link.asked.values())
    waiting = [p for p in track if first + 20.0 <= p[0] < first + 39.0]
    assert waiting and all(math.hypot(p[1] - hold[0], p[2] - hold[1]) < 0.15 and abs(p[3] - 2.6) < 0.1
                           for p in waiting)
    # it never went below its layer near the pickup before the grant
    before = [p for p in track if p[0] < first + 40.0 and math.hypot(p[1] - PICKUP[0], p[2] - PICKUP[1]) < 1.0]
    assert all(p[3] > 2.4 for p in before)


# -- whole missions ---------------------------------------------------------------------------------------------
def test_without_the_airspace_rules_uavs_collide_and_with_them_they_keep_the_bound():
    bp = towers(3, 2, spacing_m=1.6, brick_uavs=2, adhesion_uavs=2)
    off = simulate(bp, separation=False)
    on = simulate(bp)
    assert off.min_separation_m is not None and off.min_separation_m < 0.8  # the problem this solves
    assert on.completed and on.conflict_violations == 0
    assert on.min_separation_m is not None and on.min_separation_m >= SEPARATION_BOUND_M


@settings(max_examples=10, deadline=None)
@given(
    kind=st.sampled_from(["towers", "bond"]),
    size=st.integers(2, 3),
    nb=st.integers(1, 3),
    na=st.integers(1, 2),
    seed=st.integers(0, 1000),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
)
def test_min_separation_keeps_the_bound_over_random_walls_fleets_and_seeds(kind, size, nb, na, seed, policy):
    if kind == "towers":
        bp = towers(2, size, spacing_m=1.8, brick_uavs=nb, adhesion_uavs=na)
    else:
        bp = running_bond(2, size + 1, brick_uavs=nb, adhesion_uavs=na)
    r = simulate(bp, policy=policy, seed=seed)
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    if r.min_separation_m is not None:  # two UAVs were airborne together
        assert r.min_separation_m >= SEPARATION_BOUND_M, r.min_separation_m


def test_mission_control_and_a_handler_exchange_clearances_over_the_transport():
    from masonry.mission.control import MissionControl
    from masonry.mission.handler import UavHandler
    from masonry.mission.inproc import InprocBus
    from masonry.planner import plan

    bp = running_bond(1, 2, brick_uavs=2, adhesion_uavs=1)
    fleet = bp.fleet
    bus = InprocBus()
    mc = MissionControl(plan(bp), fleet, bus.endpoint(MISSION_CONTROL), column_radius_m=R, layer_base_m=BASE,
                        startup_timeout_s=100.0)
    where = {u.name: (u.home_m[0], u.home_m[1], 1.2) for u in fleet}
    handlers = {u.name: UavHandler(u.name, bus.endpoint(u.name), position=lambda n=u.name: where[n])
                for u in fleet}
    a, b = [u.name for u in fleet][:2]
    for h in handlers.values():
        h.step(0.0)
    mc.step(0.0)
    for h in handlers.values():
        h.step(0.1)  # mission control heard
    site = (0.0, -2.0, 1.2)
    assert handlers[a].request_clearance(site) is None  # asked; the answer comes with mission control's tick
    mc.step(0.2)
    ans = handlers[a].request_clearance(site)
    assert ans is not None and ans.granted and ans.layer_m is not None
    assert handlers[a].columns == (site,)
    near = (0.5, -2.0, 1.2)
    handlers[b].request_clearance(near)
    mc.step(0.3)
    wait = handlers[b].request_clearance(near)
    assert wait is not None and not wait.granted and wait.hold_m is not None
    # a comes down, works, sets off for its next site and flies away: its handler frees the column, b gets it
    handlers[a].end_transit(site)
    handlers[a].request_clearance((5.0, -2.0, 1.2))
    mc.step(0.45)
    assert handlers[b].request_clearance(near).granted is False  # a is still there
    where[a] = (5.0, -2.0, 1.2)
    handlers[a].step(0.5)
    mc.step(0.6)
    handlers[b].step(0.7)
    assert handlers[b].request_clearance(near).granted
    assert mc.columns.held == {a: ((5.0, -2.0, 1.2),), b: (near,)}
