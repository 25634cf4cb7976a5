"""Airspace separation (docs/safety.md): site columns and transit layers, from the pure rules to whole missions."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from airspace_rig import apply_step
from fsm_rig import HOME, PICKUP, Rig
from masonry.blueprint_gen import running_bond, towers
from masonry.errors import ProtocolError
from masonry.mission.airspace import ColumnClearance, layer_base_m, transit_layers_m, work_altitude_m
from masonry.mission.messages import MISSION_CONTROL, Clearance, ClearanceRequest, decode, encode
from masonry.mission.simulate import simulate
from masonry.mission.volumes import Volume, volumes_conflict

R = 1.5
BASE = 1.35
S = 1.1

#: The bound every whole-mission simulation must keep between two airborne UAVs (centre to centre).
SEPARATION_BOUND_M = 1.0


def _xy(p):
    return (p[0], p[1])


# -- the pure rules ---------------------------------------------------------------------------------------------
def _working(c, uav, site, t=0.0):
    """``uav`` flies to ``site`` (from above it) and comes down there: it holds the zone."""
    g = c.request(uav, site, t, (site[0], site[1], site[2]))
    assert g.granted, (uav, site)
    c.end_transit(uav)


def test_a_site_near_a_zone_gets_a_hold_flight_and_the_rest_once_the_zone_is_left():
    c = ColumnClearance(R, BASE, S)
    _working(c, "a", (0.0, 0.0, 1.2))
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert not b.granted and b.hold_m is not None and b.layer_m is not None
    assert math.dist(_xy(b.hold_m), (0.0, 0.0)) >= 1.1 * R - 1e-9
    assert c.grant(2.0) == []  # a still works there
    # a sets off for a far site from where it works: its climb there still blocks b's column
    assert c.request("a", (0.0, 8.0, 1.2), 2.5, (0.0, 0.0, 1.2)).granted
    assert c.grant(2.6) == []
    c.release("a", (0.0, 0.0, 1.2))  # a is 1.2 m away: its climb is over...
    c.progress("a", (0.0, 3.0, c.layer_m("a")))  # ... and it reports itself 3 m along its leg
    assert c.grant(2.8) == []  # b is not at its hold point yet: it would not read the answer before
    c.progress("b", (b.hold_m[0], b.hold_m[1], b.layer_m))
    g = c.grant(3.0)
    assert [x.uav for x in g] == ["b"] and g[0].granted and g[0].layer_m is not None
    assert c.max_wait_s == pytest.approx(2.0) and c.held_back == 1
    assert c.conflicts() == []


def test_each_uav_goes_through_the_phases_of_the_transit_protocol():
    from masonry.mission.airspace import Phase

    c = ColumnClearance(R, BASE, S)
    assert c.phase("a") is Phase.PARKED  # holds nothing yet
    _working(c, "a", (0.0, 0.0, 1.2))
    assert c.phase("a") is Phase.PARKED
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert b.hold_m is not None and c.phase("b") is Phase.TO_HOLD
    c.progress("b", (b.hold_m[0], b.hold_m[1], b.layer_m))
    assert c.phase("b") is Phase.AT_HOLD
    far = c.request("d", (9.0, 9.0, 1.2), 1.0, (0.5, -3.0, 1.2))  # far away: its leg passes over b's hover
    assert far.granted and far.layer_m == pytest.approx(BASE + S) and c.phase("d") is Phase.FLYING
    c.release("a")  # a is gone: b's site is free, b may come down
    assert [g.uav for g in c.grant(2.0) if g.granted] == ["b"] and c.phase("b") is Phase.FLYING
    assert c.waiting == ()
    c.end_transit("b")
    assert c.phase("b") is Phase.PARKED and c.held["b"] == ((0.5, 0.0, 1.2),)
    e = c.request("e", (0.6, 0.1, 1.2), 3.0, (0.0, 5.0, 1.2))  # b works there now: e cannot come down
    assert e.hold_m is not None and c.phase("e") is Phase.TO_HOLD and c.waiting == ("e",)
    c.release("e")  # e is out of the mission: its record goes
    assert c.phase("e") is Phase.PARKED and c.volumes("e") == () and c.waiting == ()
    assert c.conflicts() == []


def test_sites_apart_are_both_granted_and_a_repeated_request_gets_the_same_answer():
    c = ColumnClearance(R, BASE, S)
    assert c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -4.0, 1.2)).granted
    assert c.request("b", (R + 0.01, 4.0, 1.2), 0.0, (3.0, -4.0, 1.2)).granted
    again = c.request("a", (0.0, 0.0, 1.2), 1.0, (0.0, -4.0, 1.2))
    assert again.granted and again.layer_m == c.layer_m("a")
    assert set(c.held) == {"a", "b"}


def test_layer_zero_for_a_clear_flight_and_a_higher_one_to_pass_over_a_zone():
    c = ColumnClearance(R, BASE, S)
    _working(c, "a", (0.0, 0.0, 1.2))
    far = c.request("b", (10.0, 5.0, 1.2), 0.0, (10.0, 0.0, 1.2))
    assert far.granted and far.layer_m == pytest.approx(BASE)  # nobody near: layer 0, the work altitude
    c.end_transit("b")
    over = c.request("c", (3.0, 0.6, 1.2), 1.0, (-3.0, 0.3, 1.2))  # passes 0.45 m from a's zone
    # a's zone reaches 1.2 m: layer 0 (1.35 m) is too close above it, layer 1 (2.45 m) is 1.25 m above
    assert over.granted and over.layer_m == pytest.approx(BASE + S)
    d = c.request("d", (0.3, 3.0, 1.2), 2.0, (0.0, -3.0, 1.2))  # over a too, and across c's leg
    assert d.granted and d.layer_m == pytest.approx(BASE + 2 * S)  # above c's layer
    assert c.conflicts() == []


def test_a_higher_work_top_is_kept_clear_of():
    c = ColumnClearance(R, BASE, S)
    c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, 0.0, 1.2), top_m=2.1)  # it may climb to 2.1 m there
    c.end_transit("a")
    over = c.request("c", (3.0, 0.6, 1.2), 1.0, (-3.0, 0.3, 1.2))
    assert over.granted and over.layer_m == pytest.approx(BASE + 2 * S)  # 2.45 m is not 1.1 m above 2.1 m


def test_the_part_of_a_flight_behind_the_uav_is_freed_as_it_reports_where_it_is():
    c = ColumnClearance(R, BASE, S)
    # x is on its way down to (0, 0); b wants to come down right next to it: a hold flight from (6, 0)
    assert c.request("x", (0.0, 0.0, 1.2), 0.0, (-6.0, 0.0, 1.2)).granted
    b = c.request("b", (0.6, 0.0, 1.2), 1.0, (6.0, 0.0, 1.2))
    assert not b.granted and b.hold_m is not None
    # y wants to come down where b set off: not while b may still be climbing there
    y = c.request("y", (6.0, 0.5, 1.2), 1.5, (6.0, 6.0, 1.2))
    assert not y.granted and y.hold_m is not None
    c.progress("y", (y.hold_m[0], y.hold_m[1], y.layer_m))  # y waits at its hold point
    c.progress("b", (6.0, 0.0, 1.2))  # a report from before it set off: ignored
    assert c.grant(1.6) == []
    c.progress("b", (3.5, 0.0, b.layer_m))  # on its leg, 2.5 m along: the climb and the leg behind are free
    assert [(g.uav, g.granted) for g in c.grant(1.7)] == [("y", True)]
    assert c.conflicts() == []


def test_first_come_first_served_near_a_waited_site():
    c = ColumnClearance(R, BASE, S)
    _working(c, "a", (0.0, 0.0, 1.2))
    assert not c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -5.0, 1.2)).granted  # waits for a
    # c asks later for a site near b's (but clear of a): it waits for b to have had its turn
    late = c.request("c", (1.2, 1.3, 1.2), 2.0, (6.0, 6.0, 1.2))
    assert not late.granted
    assert c.waiting == ("b", "c")


def test_a_lost_uav_frees_everything_and_a_given_up_request_stops_waiting():
    c = ColumnClearance(R, BASE, S)
    _working(c, "a", (0.0, 0.0, 1.2))
    hold = c.request("b", (0.3, 0.0, 1.2), 0.0, (0.0, 3.0, 1.2))
    assert c.waiting == ("b",) and hold.hold_m is not None
    c.release("a")  # a is lost
    assert "a" not in c.held and c.volumes("a") == ()
    c.progress("b", (hold.hold_m[0], hold.hold_m[1], hold.layer_m))  # at its hold point
    assert [g.uav for g in c.grant(1.0)] == ["b"]
    c.request("d", (5.0, 5.0, 1.2), 1.0, (0.0, 3.0, 1.2))
    c.release("d", (5.0, 5.0, 1.2))  # d gave up asking (it was sent elsewhere)
    assert "d" not in c.waiting


def test_a_landed_uav_holds_only_its_pad_and_takes_off_when_its_column_is_free():
    homes = {"a": (0.0, -6.0, 0.0), "b": (1.0, -6.0, 0.0), "c": (2.0, -6.0, 0.0)}  # pads 1 m apart
    c = ColumnClearance(R, BASE, S, homes=homes)
    assert [c.phase(u).value for u in homes] == ["landed"] * 3
    assert [v.kind for v in c.volumes("b")] == ["pad"]
    # beside landed neighbours 1 m away, a may take off (the pads keep its airframe clear) ...
    assert c.take_off("a")
    assert c.phase("a").value == "parked" and [v.kind for v in c.volumes("a")] == ["zone"]
    # ... but b, 1 m from a's take-off column, waits for it: neighbouring take-offs are sequenced
    assert not c.can_take_off("b") and not c.take_off("b")
    assert c.phase("b").value == "landed"
    # c, 2 m from a, may go at once
    assert c.take_off("c")
    assert c.conflicts() == []
    # a flight over the landed b's pad at layer 0 (1.35 m up: above any pad) ...
    g = c.request("a", (6.0, -6.0, 1.2), 0.0, (0.0, -6.0, 1.2))
    # ... would pass c's take-off column: it goes a layer higher
    assert g.granted and g.layer_m == pytest.approx(BASE + S)
    assert not c.take_off("b")  # a's climb is still beside b
    c.progress("a", (1.5, -6.0, BASE + S))  # on its leg, 1.5 m from its pad: its climb is behind it
    assert not c.take_off("b")  # c still hovers over its pad 1 m away
    assert c.landed("c", homes["c"])  # it did not fly after all
    assert c.take_off("b")
    assert c.conflicts() == []


def test_a_uav_lands_back_on_its_pad_only_out_of_its_flight_home():
    homes = {"a": (0.0, -6.0, 0.0), "b": (1.0, -6.0, 0.0)}
    c = ColumnClearance(R, BASE, S, homes=homes)
    assert c.take_off("a")
    assert not c.landed("a", (3.0, -6.0, 0.0))  # not on its pad
    g = c.request("a", (4.0, -3.0, 1.2), 0.0, (0.0, -6.0, 1.2))
    assert g.granted
    assert not c.landed("a", (0.0, -6.0, 0.0))  # its flight is to the site, not home
    c.end_transit("a")
    g = c.request("a", homes["a"], 10.0, (4.0, -3.0, 1.2))
    assert g.granted
    home_column = c.volumes("a")[-1]
    assert home_column.kind == "zone" and home_column.slack_m == 0.0  # no work at home: no work slack
    assert c.landed("a", (0.02, -6.01, 0.04))  # down at home (even without its `arrived`)
    assert [v.kind for v in c.volumes("a")] == ["pad"]
    assert c.take_off("b") and c.conflicts() == []


def test_a_silent_uav_keeps_its_way_home_at_its_fallback_layer_and_lands_out_of_what_it_was_seen_in():
    """Cut off past LAST_RESORT_S, a UAV flies home on its own at its fallback layer: mission control keeps that
    way reserved (the climb where it is, the leg at the layer, its pad's column). Heard again on the way, it holds
    the column where it was heard; landed on its pad, it holds only the pad."""
    homes = {"a": (0.0, -6.0, 0.0), "b": (1.0, -6.0, 0.0)}
    c = ColumnClearance(R, BASE, S, homes=homes)
    assert c.take_off("a")
    assert c.request("a", (4.0, -3.0, 1.2), 0.0, (0.0, -6.0, 1.2)).granted
    c.end_transit("a")  # working at the site
    way_m = c.silent("a", (4.0, -3.0, 1.2), 2.45)
    assert way_m == pytest.approx(5.0 + 1.25 + 2.45)
    climb, leg, home = c.volumes("a")[-3:]
    assert (climb.kind, climb.a, climb.z0_m, climb.z1_m) == ("climb", (4.0, -3.0), 1.2, 2.45)
    assert (leg.kind, leg.a, leg.b, leg.z0_m) == ("leg", (4.0, -3.0), (0.0, -6.0), 2.45)
    assert (home.kind, home.a, home.z0_m) == ("zone", (0.0, -6.0), 0.0) and home.z1_m >= 2.45
    # a leg across it at that layer conflicts with it (no grant is ever given against a reservation)
    across = Volume((1.0, -2.0), (3.0, -7.0), 2.45, 2.45)
    assert any(volumes_conflict(across, v, c.sep_xy_m, S - 1e-9) for v in c.volumes("a"))
    assert c.rejoined("a", (2.0, -4.5, 2.45))  # heard again on its way home: the column where it is
    assert [v.kind for v in c.volumes("a")] == ["zone"]
    assert c.landed("a", (0.01, -6.0, 0.03))  # down on its pad: nothing granted in flight, it holds the pad
    assert [v.kind for v in c.volumes("a")] == ["pad"]


SITES = st.tuples(st.floats(-4.0, 4.0), st.floats(-4.0, 4.0))


@settings(max_examples=80, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b", "c", "d"]),
            st.sampled_from(["req", "end", "away", "move", "lost", "tick", "takeoff", "land"]),
            SITES,
            SITES,
            st.floats(1.2, 2.4),
        ),
        max_size=40,
    )
)
def test_reserved_volumes_never_conflict_and_zones_keep_the_radius(ops):
    homes = {"a": (-6.0, -8.0, 0.0), "b": (-5.0, -8.0, 0.0), "c": (-3.0, -8.0, 0.0)}  # a and b 1 m apart
    c = ColumnClearance(R, BASE, S, homes=homes)
    t = 0.0
    for uav, op, site, pos, top in ops:
        t += 1.0
        apply_step(c, uav, op, site, pos, top, t, homes=homes)
        c.grant(t)
        assert c.conflicts() == []
        # work zones (not the columns over pads, where no one works) keep r_c
        zones = [
            (u, v)
            for u in "abcd"
            for v in c.volumes(u)
            if v.kind == "zone" and not (u in homes and _xy(homes[u]) == v.a)
        ]
        for i, (u1, v1) in enumerate(zones):
            for u2, v2 in zones[i + 1 :]:
                if u1 != u2:
                    assert math.dist(v1.a, v2.a) >= R - 1e-9, (u1, v1, u2, v2)


@settings(max_examples=60, deadline=None)
@given(
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, 4)),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, 4)),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, 4)),
    st.tuples(st.floats(-3, 3), st.floats(-3, 3), st.floats(0, 4)),
    st.floats(0, 1),
    st.floats(0, 1),
)
def test_points_in_volumes_that_do_not_conflict_keep_the_separation(p0, p1, q0, q1, s, u):
    from masonry.mission.airspace import Volume, volumes_conflict

    # a lateral leg and a vertical move (the shapes flights are made of)
    leg = Volume((p0[0], p0[1]), (p1[0], p1[1]), p0[2], p0[2])
    climb = Volume((q0[0], q0[1]), (q0[0], q0[1]), min(q0[2], q1[2]), max(q0[2], q1[2]))
    a = (p0[0] + s * (p1[0] - p0[0]), p0[1] + s * (p1[1] - p0[1]), p0[2])
    b = (q0[0], q0[1], climb.z0_m + u * (climb.z1_m - climb.z0_m))
    if not volumes_conflict(leg, climb, 1.2, 1.1):
        assert math.dist(a, b) >= 1.1 - 1e-9


def test_a_uav_reported_off_its_layer_holds_its_climb_from_where_it_is():
    c = ColumnClearance(radius_m=R, base_m=BASE)
    # at rest 0.11 m over layer 0 (it stopped a climb there): not counted at the layer
    c.request("u1", (4.0, 0.0, 0.5), 0.0, (0.0, 0.0, BASE + 0.11))
    climb = c.volumes("u1")[0]
    assert climb.kind == "climb" and climb.z1_m == pytest.approx(BASE + 0.11)
    # a few centimetres off (hover noise) is at the layer
    c.request("u2", (-4.0, 6.0, 0.5), 0.0, (0.0, 6.0, BASE + 0.03))
    assert [v.z1_m for v in c.volumes("u2") if v.kind == "climb"] == [pytest.approx(BASE)]


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
def _rig_with(link_kwargs):
    rig = Rig("brick", clearance=dict(link_kwargs))
    return rig, rig.link


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
    out = [
        p
        for p in track
        if p[4] == "pickup_goto"
        and math.hypot(p[1] - HOME[0], p[2] - HOME[1]) > 0.5
        and math.hypot(p[1] - PICKUP[0], p[2] - PICKUP[1]) > 0.5
    ]
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
    assert waiting and all(
        math.hypot(p[1] - hold[0], p[2] - hold[1]) < 0.15 and abs(p[3] - 2.6) < 0.1 for p in waiting
    )
    # it never went below its layer near the pickup before the grant
    before = [
        p for p in track if p[0] < first + 40.0 and math.hypot(p[1] - PICKUP[0], p[2] - PICKUP[1]) < 1.0
    ]
    assert all(p[3] > 2.4 for p in before)


# -- whole missions ---------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_without_the_airspace_rules_uavs_collide_and_with_them_they_keep_the_bound():
    bp = towers(3, 2, spacing_m=1.6, brick_uavs=2, adhesion_uavs=2)
    # the paper's reservation: conflicting tasks never run at once, so only the airspace keeps the flights apart
    off = simulate(bp, separation=False, reservation="task")
    on = simulate(bp, reservation="task")
    assert off.min_separation_m is not None and off.min_separation_m < 0.8  # the problem this solves
    assert on.completed and on.conflict_violations == 0
    assert on.min_separation_m is not None and on.min_separation_m >= SEPARATION_BOUND_M


def _outside_m(columns, uav, p):
    """How far ``p`` is outside every volume ``uav`` holds (box metric, as the separation rule)."""
    from masonry.mission.airspace import _point_segment_m

    best = math.inf
    for q in columns.volumes(uav):
        h = max(0.0, _point_segment_m((p[0], p[1]), q.a, q.b) - q.slack_m)
        v = max(0.0, q.z0_m - p[2], p[2] - q.z1_m)
        best = min(best, max(h, v))
    return best


#: How far outside its reserved volumes a UAV may be found, per simulated autopilot: tracking error only. The
#: separation rule keeps 0.1 m over the 1.0 m target for it. ``ideal``: 0.02-0.05 m measured since legs feed the
#: acceleration forward and UAVs ask at rest (up to 0.17 m before, 4x25 seed 1). ``arducopter`` (its jerk-limited
#: shaping and delay): 0.28 m before legs were planned within its jerk and acceleration limits and the take-off
#: braked ahead of them, 0.05-0.07 m since (0.10 m with a 0.71 s feed-forward lag): within the rule's allowance
#: (docs/safety.md, "Tracking error on a real autopilot").
OUTSIDE_M = {"ideal": 0.07, "arducopter": 0.10}


@pytest.mark.slow
@pytest.mark.parametrize(
    "courses,per,nb,na,seed,vehicle",
    [
        (3, 12, 4, 2, 0, "arducopter"),
        (4, 8, 3, 2, 5, "arducopter"),
        (2, 20, 4, 2, 11, "ideal"),
        (4, 25, 4, 2, 1, "ideal"),
        (2, 20, 4, 2, 11, "arducopter"),
    ],
)
def test_airborne_uavs_stay_inside_the_volumes_mission_control_reserved_for_them(
    monkeypatch, courses, per, nb, na, seed, vehicle
):
    from masonry.mission.simulate import SimulatedMission

    mission = SimulatedMission.from_blueprint(
        running_bond(courses, per, brick_uavs=nb, adhesion_uavs=na), seed=seed, vehicle=vehicle
    )
    columns = mission.control.columns
    world = mission.world
    worst = {}
    step = world.step

    def spy_step(dt_s):
        step(dt_s)
        for name, u in world.uavs.items():
            v = u.vehicle
            if v.armed and not v.on_ground:
                worst[name] = max(worst.get(name, 0.0), _outside_m(columns, name, v.position_m))

    monkeypatch.setattr(world, "step", spy_step)
    r = mission.run()
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    assert columns.conflicts() == []
    bound = OUTSIDE_M[vehicle]
    assert max(worst.values()) < bound, worst
    # the report's envelope excursion measures the same steps in 3-D (the hypotenuse, at least the box metric's)
    e = r.envelope_excursion
    assert e is not None and max(worst.values()) - 1e-9 <= e.m <= math.sqrt(2.0) * max(worst.values()) + 1e-9
    assert e.s == 0.0, e  # never past the 0.1 m tracking share
    # so two UAVs keep the layer spacing less twice that (0.96-1.02 m on 4x25 before)
    assert r.min_separation_m is None or r.min_separation_m >= S - 2 * bound


@pytest.mark.slow
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
    mc = MissionControl(
        plan(bp),
        fleet,
        bus.endpoint(MISSION_CONTROL),
        column_radius_m=R,
        layer_base_m=BASE,
        startup_timeout_s=100.0,
    )
    where = {u.name: (u.home_m[0], u.home_m[1], 1.2) for u in fleet}
    handlers = {
        u.name: UavHandler(u.name, bus.endpoint(u.name), position=lambda n=u.name: where[n]) for u in fleet
    }
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
    where[a] = site
    handlers[a].request_clearance((5.0, -2.0, 1.2))
    mc.step(0.45)
    assert handlers[b].request_clearance(near).granted is False  # a is still there
    where[a] = (5.0, -2.0, 1.2)
    handlers[a].step(0.5)
    mc.step(0.6)
    assert handlers[b].request_clearance(near).granted is False  # b has not said it is at its hold point
    where[b] = (wait.hold_m[0], wait.hold_m[1], wait.layer_m)
    # a's heartbeat: it is at the end of its leg, which is freed behind it (b waits on its own side of its site
    # since issue 27's hold point on the UAV's side, off a's leg: a flies it at layer 0, over b's site)
    handlers[a].step(1.6)
    handlers[b].step(1.7)  # its heartbeat tells where it is
    mc.step(1.8)
    handlers[b].step(1.9)
    assert handlers[b].request_clearance(near).granted
    assert mc.columns.held == {a: ((5.0, -2.0, 1.2),), b: (near,)}


# -- layers that rise with the wall -----------------------------------------------------------------------------
def test_layer_zero_rises_with_the_wall_and_granted_flights_keep_their_altitude():
    c = ColumnClearance(R, 3.0, S, start_base_m=BASE)
    a = c.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -4.0, 1.2))
    assert a.granted and a.layer_m == pytest.approx(BASE)  # the wall is low yet: layer 0 is low
    c.raise_base(2.0)
    c.raise_base(1.5)  # never down
    b = c.request("b", (6.0, 0.0, 1.2), 1.0, (6.0, -4.0, 1.2))
    assert b.granted and b.layer_m == pytest.approx(2.0)
    again = c.request("a", (0.0, 0.0, 1.2), 2.0, (0.0, -3.0, BASE))
    assert again.granted and again.layer_m == pytest.approx(BASE) and c.layer_m("a") == pytest.approx(BASE)
    c.raise_base(9.0)  # never above the finished wall's work altitude
    assert c.layer_base_m == pytest.approx(3.0)
    assert c.conflicts() == []


def test_a_hold_flight_keeps_its_altitude_when_the_layers_rise():
    c = ColumnClearance(R, 3.0, S, start_base_m=BASE)
    _working(c, "a", (0.0, 0.0, 1.2))
    b = c.request("b", (0.5, 0.0, 1.2), 1.0, (0.0, -4.0, 1.2))
    assert not b.granted and b.hold_m is not None and b.layer_m == pytest.approx(BASE)
    c.raise_base(2.5)
    c.progress("b", (b.hold_m[0], b.hold_m[1], BASE))  # it hovers at its hold point, at the old layer 0
    assert c.request("b", (0.5, 0.0, 1.2), 2.0, (b.hold_m[0], b.hold_m[1], BASE)).layer_m == pytest.approx(
        BASE
    )
    c.request("a", (0.0, 8.0, 1.2), 3.0, (0.0, 0.0, 1.2))
    c.release("a", (0.0, 0.0, 1.2))
    c.progress("a", (0.0, 4.0, c.layer_m("a")))
    g = [x for x in c.grant(4.0) if x.uav == "b"]
    assert g and g[0].granted
    climb = next(v for v in c.volumes("b") if v.kind == "climb")
    assert min(climb.z0_m, climb.z1_m) == pytest.approx(BASE)  # from where it hovers, up to the layer given
    assert max(climb.z0_m, climb.z1_m) == pytest.approx(g[0].layer_m) and g[0].layer_m >= 2.5 - 1e-9
    assert c.conflicts() == []


@settings(max_examples=25, deadline=None)
@given(st.integers(1, 8), st.integers(1, 6), st.sampled_from(["running-bond", "towers", "pyramid"]))
def test_the_work_altitude_of_the_wall_is_the_highest_of_its_tasks(courses, per, kind):
    from masonry.blueprint_gen import pyramid
    from masonry.mission.airspace import task_work_altitude_m
    from masonry.planner import plan

    bp = {
        "running-bond": lambda: running_bond(courses, per),
        "towers": lambda: towers(per, courses),
        "pyramid": lambda: pyramid(courses),
    }[kind]()
    tasks = plan(bp).tasks
    assert max(task_work_altitude_m(t, bp.cruise_altitude_m) for t in tasks) == pytest.approx(
        work_altitude_m(bp)
    )
    for t in tasks:  # a brick task counts its brick's top, which is higher than the surface it rests on
        if t.kind == "adhesion":
            assert task_work_altitude_m(t, bp.cruise_altitude_m) >= bp.cruise_altitude_m


@pytest.mark.slow
def test_with_rising_layers_no_flight_passes_low_over_the_wall_and_the_low_layers_are_used(monkeypatch):
    """A tall wall: the first flights get layers below the finished wall's work altitude, and every lateral
    flight keeps its lowest point (carried brick, rod or nozzle) well above the bricks under it."""
    from masonry.mission import airspace_requests
    from masonry.sim import world

    granted: list[float] = []
    grant = airspace_requests.granted

    def spy_granted(self, *args, **kwargs):
        g = grant(self, *args, **kwargs)
        granted.append(g.layer_m)
        return g

    lowest_gap = {}
    last_xy = {}
    step = world.World.step

    def spy_step(self, dt_s):
        step(self, dt_s)
        for name, u in self.uavs.items():
            v = u.vehicle
            x, y, _z = v.position_m
            prev = last_xy.get(name)
            last_xy[name] = (x, y)
            if (
                not v.armed
                or v.on_ground
                or prev is None
                or math.hypot(x - prev[0], y - prev[1]) < 0.25 * dt_s
            ):
                continue  # only lateral flight: the work at a site comes down to the wall on purpose
            if u.carried_brick is not None:
                brick = self.field.bricks[u.carried_brick]
                gap = brick.bottom_z_m - self.field.support_under(brick.rect(0.0))
            else:
                offset = (
                    self.airframe.effector_offset_m if u.role == "brick" else self.airframe.nozzle_offset_m
                )
                tool = u.tool_point_m(offset)
                gap = tool[2] - self.field.support_at(tool[0], tool[1])
            lowest_gap[name] = min(lowest_gap.get(name, math.inf), gap)

    monkeypatch.setattr(airspace_requests, "granted", spy_granted)
    monkeypatch.setattr(world.World, "step", spy_step)
    bp = running_bond(8, 3, brick_uavs=2, adhesion_uavs=1)
    r = simulate(bp)
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    final = layer_base_m(bp)
    assert min(granted) < final - 0.3  # the low layers were used
    assert max(granted) >= final - 1e-9  # and the layers rose to the finished wall's
    # the work altitude keeps a carried brick 0.3 m over the wall's top: tracking error only eats into that
    assert min(lowest_gap.values()) > 0.15, lowest_gap
    assert r.min_separation_m is None or r.min_separation_m >= SEPARATION_BOUND_M
