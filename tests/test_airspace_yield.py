"""A UAV at its hold point yields to the UAV it waits for (issue 27): the cycle of the towers, seed 10, 4 m/s.

Scenario over the pure model (:class:`ColumnClearance`): a brick UAV works at its drop-off; an adhesion UAV asks for
its bead's start beside it and is sent to a hold point 1.1 wait radii from the zone. The brick UAV, placed on the
wall's frame (GNSS wander, wall alignment), asks to leave from 0.24 m outside its zone, farther than ``leave_from``
snaps: its climb from there reaches within the separation of the adhesion UAV's hover at every layer (the hover is
at layer 0, the climb starts under it). The adhesion UAV waits for the zone, the brick UAV for the hover: before the
fix neither was ever granted, and hold patience gave the adhesion task up three times.
"""

from __future__ import annotations

import math

from masonry.mission.airspace import ColumnClearance, Phase

R = 1.0  # the towers' clearance r_c (zones with no slack: 1.0 m is under the 1.2 m separation)
BASE = 1.2
S = 1.1
ZONE = (-0.87, -0.5, 1.2)  # B0's drop-off
BEAD = (-1.0, -0.57, 1.2)  # A0's start, 0.15 m from it
PALLET = (1.04, -1.8, 1.2)


def _stuck_pair() -> tuple[ColumnClearance, tuple[float, float, float]]:
    c = ColumnClearance(R, BASE, S)
    assert c.request("brick", ZONE, 0.0, ZONE).granted
    c.end_transit("brick")
    g = c.request("glue", BEAD, 1.0, (2.67, -2.93, 1.2))
    assert not g.granted and g.hold_m is not None and g.layer_m is not None
    c.progress("glue", (g.hold_m[0], g.hold_m[1], g.layer_m))
    assert c.phase("glue") is Phase.AT_HOLD
    hx, hy = g.hold_m[0], g.hold_m[1]
    d = math.hypot(hx - ZONE[0], hy - ZONE[1])
    assert d >= 1.1 * c.wait_radius_m - 1e-9  # the hold point keeps clear of the zone ...
    off = 0.24
    at = (ZONE[0] + off * (hx - ZONE[0]) / d, ZONE[1] + off * (hy - ZONE[1]) / d, 1.16)
    assert math.hypot(hx - at[0], hy - at[1]) < c.sep_xy_m  # ... not of where its UAV reports itself
    return c, at


def test_a_hover_in_the_way_out_of_the_zone_its_uav_waits_for_moves_and_both_are_granted():
    c, at = _stuck_pair()
    first = c.request("brick", PALLET, 10.0, at)
    assert not first.granted  # the hover is in the way of its climb at every layer
    moved = c.grant(10.1)
    assert [g.uav for g in moved] == ["glue"] and not moved[
        0
    ].granted  # a new hold flight, clear of brick's way
    assert c.conflicts() == []
    g = moved[0]
    assert g.hold_m is not None and g.layer_m is not None
    c.progress("glue", (g.hold_m[0], g.hold_m[1], g.layer_m))
    assert c.phase("glue") is Phase.AT_HOLD
    out = c.grant(20.0)
    assert [x.uav for x in out if x.granted] == ["brick"]
    assert c.conflicts() == []
    # brick leaves: its climb and leg are freed behind it, its flight ends at the pallet
    c.release("brick", at)
    c.progress("brick", (PALLET[0], PALLET[1], c.layer_m("brick")))
    c.end_transit("brick")
    last = c.grant(40.0)
    assert [x.uav for x in last if x.granted] == ["glue"]
    assert c.conflicts() == []


def test_a_hover_clear_of_the_way_out_stays_where_it_is():
    c, _at = _stuck_pair()
    # asked from inside its zone: the hover keeps the separation from its climb, nothing moves
    assert c.request("brick", PALLET, 10.0, ZONE).granted
    assert all(g.uav != "glue" for g in c.grant(10.1))


def test_a_hover_in_the_way_of_a_uav_it_does_not_wait_for_stays():
    # the adhesion UAV waits for a zone of a third UAV; a brick UAV working beside its hold point asks to leave
    # from 0.24 m outside its zone, towards the hover: in its way at every layer, but not a cycle (the hovering UAV
    # waits for the third, which works and then leaves), so the hover stays and the brick UAV waits
    c = ColumnClearance(R, BASE, S)
    third = (5.0, 0.0, 1.2)
    assert c.request("third", third, 0.0, third).granted
    c.end_transit("third")
    g = c.request("glue", (5.15, 0.0, 1.2), 1.0, (8.0, -3.0, 1.2))
    assert not g.granted and g.hold_m is not None and g.layer_m is not None
    c.progress("glue", (g.hold_m[0], g.hold_m[1], g.layer_m))
    hx, hy = g.hold_m[0], g.hold_m[1]
    d = math.hypot(hx - third[0], hy - third[1])
    ux, uy = (hx - third[0]) / d, (hy - third[1]) / d
    zone = (hx + 1.33 * ux, hy + 1.33 * uy, 1.2)  # beside the hover, on the far side from the third's zone
    assert c.request("brick", zone, 2.0, zone).granted
    c.end_transit("brick")
    at = (zone[0] - 0.24 * ux, zone[1] - 0.24 * uy, 1.16)
    far = (zone[0] + 4.0 * ux, zone[1] + 4.0 * uy, 1.2)
    assert not c.request("brick", far, 10.0, at).granted
    assert [b for b, _kind in c.blockers("brick")] == ["glue"]
    assert "brick" not in {b for b, _kind in c.blockers("glue")}
    assert c.grant(10.1) == [] and c.phase("glue") is Phase.AT_HOLD
    assert c.volumes("glue")[0].a == (hx, hy)
    c.release(
        "third"
    )  # the third leaves (out of the mission): the adhesion UAV is granted, then the brick UAV
    assert [x.uav for x in c.grant(11.0) if x.granted] == ["glue"]
    assert c.conflicts() == []
