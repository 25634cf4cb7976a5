"""A UAV waiting at a site in another waiting UAV's way climbs to its lift spot over it, out of the way
(``--airspace table``; docs/safety.md, "The lift spot"; :mod:`masonry.mission.reserved_lift`)."""

from __future__ import annotations

import pytest

from masonry.mission.airspace_state import Phase
from masonry.mission.reserved import TableClearance

HOMES = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0), "c": (6.0, -5.0, 0.0)}
S_A, S_B, S_C = (0.0, 0.0, 1.2), (0.5, 0.0, 1.2), (4.0, 0.0, 1.2)
BESIDE_C = (4.3, 0.0, 1.2)  # a's next site, 0.3 m from c's: c's stay is in its way for good


def _at(air: TableClearance, uav: str, site: tuple[float, float, float], t: float) -> None:
    """``uav`` takes off, is granted its flight to ``site`` at ``t`` and is down there."""
    air.take_off(uav)
    assert air.request(uav, site, t, (*HOMES[uav][:2], 1.2)).granted
    air.progress(uav, site)
    air.end_transit(uav)


def _a_waits_for_cs_stay() -> TableClearance:
    """c stays at its site; a, at its site 4 m from c's, asks for the site beside c's: told to wait (no end) where
    it is, in nobody's way yet."""
    air = TableClearance(0.8, 2.0, homes=HOMES, start_base_m=1.2)
    _at(air, "c", S_C, 0.0)
    _at(air, "a", S_A, 1.0)
    g = air.request("a", BESIDE_C, 30.0, S_A)
    assert not g.granted and g.hold_m is None and air.blockers("a") == [("c", "stay")]
    assert air.grant(30.5) == [] and air.lifted_count == 0  # in nobody's way: it waits where it is
    return air


def test_a_waiting_uav_in_a_waiting_uavs_way_climbs_to_its_lift_spot_and_is_out_of_its_way():
    # a waits for c's stay, which has no end. Before, a waited at its site holding its work zone, open-ended, and b,
    # given the site 0.5 m beside it, waited for a's stay for as long as a waited (a chain of waiting UAVs: 25 s of
    # every brick cycle on the 12 m wall at 8 + 4). Now a, in b's way, climbs straight up to its lift spot over
    # every layer, and b comes down beside a's site once a is up; from its spot a is granted its flight down once c
    # has moved on
    air = _a_waits_for_cs_stay()
    air.take_off("b")
    assert not air.request("b", S_B, 31.0, (3.0, -5.0, 1.2)).granted
    assert air.blockers("b") == [("a", "stay")]
    lifted = [g for g in air.grant(31.5) if g.uav == "a"]
    spot = (S_A[0], S_A[1], air.airspace.layers_m[-1] + air.spacing_m)  # straight over it, over every layer
    assert [(g.granted, g.hold_m) for g in lifted] == [(False, pytest.approx(spot))]
    assert air.phase("a") is Phase.TO_HOLD and air.lifted_count == 1
    granted: list[tuple[str, float]] = []
    for t in range(32, 120):
        if t == 40:
            air.progress("a", spot)  # a is at its spot: its climb's window ends
            assert air.phase("a") is Phase.AT_HOLD
        if t == 70:
            air.request("c", (*HOMES["c"][:2], 1.2), 70.0, S_C)  # c flies home: its stay moves
        granted += [(g.uav, float(t)) for g in air.grant(float(t)) if g.granted]
    assert granted and granted[0] == ("b", 40.0)  # b comes down as soon as a is up
    assert "a" in [u for u, t in granted if t >= 70.0]  # from its spot, once c's stay has moved
    down = next(r.volume for r in air.table.of("a") if r.purpose == "climb")  # (its way down from the spot)
    assert down.a == pytest.approx(S_A[:2]) and down.z1_m == pytest.approx(spot[2])
    assert air.forced == 0 and air.conflicts() == []


def test_two_uavs_waiting_for_each_others_site_climb_to_their_lift_spots_not_to_their_parking_spots():
    # a at (0, 0) asks for b's site, b at (3, 0) for a's: a cycle of stays. Each is in the other's way and climbs
    # straight up to its lift spot (before, the parking rule sent one of them 6 m up over its pad, 5 m away, and
    # back); once both are up, each comes down to the other's site from its spot
    air = TableClearance(0.8, 2.0, homes=HOMES, start_base_m=1.2)
    s1, s2 = (0.0, 0.0, 1.2), (3.0, 0.0, 1.2)
    _at(air, "a", s1, 0.0)
    _at(air, "b", s2, 0.0)
    assert not air.request("a", s2, 30.0, s1).granted
    assert not air.request("b", s1, 30.5, s2).granted
    top = air.airspace.layers_m[-1] + air.spacing_m
    spots = {"a": (s1[0], s1[1], top), "b": (s2[0], s2[1], top)}
    granted: list[str] = []
    for k in range(62, 240):
        t = k / 2.0
        for g in air.grant(t):
            assert g.granted or g.hold_m == pytest.approx(spots[g.uav])  # lifts, and no parking flight
            granted += [g.uav] if g.granted else []
        if t == 40.0:
            air.progress("a", spots["a"])  # both are up
            air.progress("b", spots["b"])
        if len(granted) == 2:
            break
    assert sorted(granted) == ["a", "b"] and air.lifted_count == 2 and air.held_back == 0
    assert air.forced == 0 and air.conflicts() == []
