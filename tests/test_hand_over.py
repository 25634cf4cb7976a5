"""The hand-over planned ahead at 1 + 1 (issue 27, docs/safety.md "The hand-over planned ahead"): a held UAV's
hold point on its straight line to its site, a nearer one while the UAV it waits for leaves, and the rest of a
straight hold flight granted on the way; never a volume against another's."""

from __future__ import annotations

import math

from masonry.mission.airspace import ColumnClearance, Phase
from masonry.mission.volumes import point_segment_m

R = 1.5
BASE = 1.35


def _working(c: ColumnClearance, uav: str, site: tuple[float, float, float]) -> None:
    assert c.request(uav, site, 0.0, site).granted
    c.end_transit(uav)


def _held(c: ColumnClearance) -> tuple[float, float, float]:
    """a works at the origin; b, 3 m south, asks for the same site: sent to wait on its line (the 1.5 m ring is
    within 1.1 x the wait radius of a's zone)."""
    _working(c, "a", (0.0, 0.0, 1.2))
    g = c.request("b", (0.0, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert not g.granted and g.hold_m is not None
    return g.hold_m


def test_the_held_uav_waits_on_its_straight_line_to_its_site():
    c = ColumnClearance(R, BASE)
    hold = _held(c)
    assert point_segment_m(hold[:2], (0.0, 0.0), (0.0, -3.0)) < 1e-6, hold  # straight south of its site
    assert math.dist(hold[:2], (0.0, 0.0)) >= 1.1 * c.wait_radius_m - 1e-9
    assert c.records["b"].hold is not None and c.records["b"].hold.straight
    assert c.conflicts() == []


def test_the_rest_of_a_straight_hold_flight_is_granted_on_the_way_once_it_fits():
    c = ColumnClearance(R, BASE)
    hold = _held(c)
    assert c.records["b"].phase is Phase.TO_HOLD
    c.progress("b", (0.0, -2.5, BASE))  # on its way, not at its hold point yet
    assert c.request("a", (6.0, 0.0, 1.2), 2.0, (0.0, 0.0, 1.2)).granted  # a leaves eastwards
    assert not any(g.granted for g in c.grant(2.1))  # a's climb and leg are still in b's column's way
    c.progress("a", (4.0, 0.0, BASE))
    granted = [g for g in c.grant(4.0) if g.uav == "b"]
    assert granted and granted[0].granted
    assert c.records["b"].phase is Phase.FLYING
    assert c.conflicts() == []
    # what is reserved covers the straight line from where b is over its hold point to the site
    legs = [v for v in c.volumes("b") if v.kind == "leg"]
    assert any(point_segment_m(hold[:2], v.a, v.b) < 1e-6 for v in legs)
    assert any(point_segment_m((0.0, 0.0), v.a, v.b) < 1e-6 for v in legs)


def test_a_uav_at_its_hold_point_is_let_nearer_as_the_one_it_waits_for_leaves():
    c = ColumnClearance(R, BASE)
    hold = _held(c)
    c.progress("b", (hold[0], hold[1], BASE))  # at its hold point
    assert c.records["b"].phase is Phase.AT_HOLD
    assert c.request("a", (0.0, 6.0, 1.2), 2.0, (0.0, 0.0, 1.2)).granted  # a leaves northwards
    c.progress("a", (0.0, 0.9, BASE))  # its climb is behind it; its leg still within 1.65 m of b's site
    nearer = [g for g in c.grant(3.0) if g.uav == "b"]
    assert nearer and not nearer[0].granted and nearer[0].hold_m is not None
    d_before = math.dist(hold[:2], (0.0, 0.0))
    d_after = math.dist(nearer[0].hold_m[:2], (0.0, 0.0))
    assert d_after <= d_before - 0.3 + 1e-9, (d_before, d_after)
    assert point_segment_m(nearer[0].hold_m[:2], (0.0, 0.0), hold[:2]) < 1e-6  # on its line
    assert c.conflicts() == []


def test_with_a_third_uav_in_the_air_no_nearer_hold_point():
    c = ColumnClearance(R, BASE)
    _working(c, "c", (8.0, 8.0, 1.2))
    _working(c, "a", (0.0, 0.0, 1.2))
    g = c.request("b", (0.0, 0.0, 1.2), 1.0, (0.0, -3.0, 1.2))
    assert g.hold_m is not None
    c.progress("b", (g.hold_m[0], g.hold_m[1], BASE))
    assert c.request("a", (0.0, 6.0, 1.2), 2.0, (0.0, 0.0, 1.2)).granted
    c.progress("a", (0.0, 0.9, BASE))
    assert not [x for x in c.grant(3.0) if x.uav == "b"]  # it waits where it is, as before
    assert c.conflicts() == []
