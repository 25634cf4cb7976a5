"""``--airspace table``: a UAV's windows end once it has passed them (issue 27 §1, branch ``table49``): a flight to a
parking or approach spot gives up its climb over the site it left as one to a site does, and the lateral leg a UAV
flies holds only what lies ahead of it (:func:`masonry.mission.reserved_parts.ahead_of`)."""

from __future__ import annotations

import math

import pytest

from airspace_rig import table_pair, table_pair_waiting_for_each_others_site
from masonry.mission.airspace_state import Phase
from masonry.mission.reserved import TableClearance
from masonry.mission.reserved_parts import ON_LEG_M, ahead_of
from masonry.reservation import Reservation, column, leg


def _b_sent_to_its_spot() -> tuple[TableClearance, tuple[float, float, float]]:
    """Two UAVs each waiting for the other's site: b is sent to its parking spot (a cycle of stays broken)."""
    air = table_pair_waiting_for_each_others_site()
    for k in range(62, 80):
        for g in air.grant(k / 2.0):
            if g.hold_m is not None:
                return air, g.hold_m
    raise AssertionError("b was not sent to its parking spot")


def test_a_uav_on_its_way_to_a_parking_spot_no_longer_holds_its_climb_over_the_site_it_left():
    air, spot = _b_sent_to_its_spot()
    assert air.phase("b") is Phase.TO_HOLD
    climbs = [r for r in air.table.of("b") if r.purpose == "climb"]
    assert climbs and climbs[0].volume.a == pytest.approx((3.0, 0.0))  # over b's site
    air.tick(41.0)
    air.progress("b", (3.0, -2.5, spot[2]))  # up at its spot's altitude, on its way over
    assert [r for r in air.table.of("b") if r.purpose == "climb" and r.t1_s > 41.0] == []
    assert air.conflicts() == []


def test_a_leg_under_way_holds_only_what_lies_ahead_of_the_uav():
    r = Reservation("a", leg((0.0, 0.0), (4.0, 0.0), 3.0), 0.0, 10.0, "transit")
    assert ahead_of(r, (0.1, 0.2, 3.0)) == r  # not yet ON_LEG_M along: all of it
    v = ahead_of(r, (2.0, 0.1, 3.0)).volume
    assert v.a == pytest.approx((2.0 - ON_LEG_M, 0.0)) and v.b == (4.0, 0.0) and v.z0_m == 3.0
    assert ahead_of(r, (9.0, 0.0, 3.0)).volume.a == pytest.approx((4.0 - ON_LEG_M, 0.0))  # past its end
    up = Reservation("a", column((0.0, 0.0), 1.0, 3.0), 0.0, 10.0, "climb")
    assert ahead_of(up, (0.0, 0.0, 2.0)) == up  # a column keeps all of it


def test_a_flight_under_way_frees_the_air_behind_the_uav_on_its_leg():
    air = table_pair()
    air.take_off("a")
    assert air.request("a", (6.0, -5.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    layer = next(r.volume.z0_m for r in air.table.of("a") if r.purpose == "transit")
    air.tick(6.0)
    air.progress("a", (3.0, -5.0, layer))  # half way along at its layer
    starts = [r.volume.a[0] for r in air.table.of("a") if r.purpose == "transit" and r.t1_s > 6.0]
    assert starts and min(starts) == pytest.approx(3.0 - ON_LEG_M)
    assert all(not (r.purpose == "climb" and r.t1_s > 6.0) for r in air.table.of("a"))
    assert not math.isnan(layer) and air.conflicts() == []
