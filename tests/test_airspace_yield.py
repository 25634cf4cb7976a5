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
