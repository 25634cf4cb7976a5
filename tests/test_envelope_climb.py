"""Every UAV inside the volumes mission control reserved for it under the columns (issue 27 §4.3; docs/safety.md,
"The envelope excursion"): a sprayer climbs out of its zone inside it, a zone along a bead covers the sprayer's
coast past its end, a pickup's zone covers where the brick may lie off it, a UAV still climbing near its next
site keeps its climb, and a nearer hold point is reserved at the altitude its UAV flies to it."""

from __future__ import annotations

import random
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.airspace import ColumnClearance
from masonry.mission.envelope import ALLOWANCE_M, outside_m
from masonry.mission.simulate import SimulatedMission, simulate
from masonry.mission.volumes import BEAD_COAST_M, PICKUP_OFFSET_M, ahead_of, coasted, flight_volumes

ROOT = Path(__file__).resolve().parents[1]

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


def test_a_zone_along_a_bead_reaches_as_far_past_its_end_as_a_sprayer_coasts() -> None:
    # at compact r_c a zone has no slack of its own: the bead's end moves on by the whole coast
    c = ColumnClearance(0.6, 1.2)
    assert c.zone_slack_m == 0.0
    zone = c.zone_column((0.0, 0.0, 0.5), 1.2, (0.3, 0.0))
    assert zone.a == (0.0, 0.0) and zone.b == pytest.approx((0.3 + BEAD_COAST_M, 0.0))
    assert outside_m((0.3 + BEAD_COAST_M, 0.0, 0.6), [zone]) == 0.0  # coasted on past the end: inside
    assert outside_m((-0.05, 0.0, 0.6), [zone]) == pytest.approx(
        0.05
    )  # (the start, where it came down: no coast)
    # between, the slack covers part of the coast: the end moves on by the rest
    mid = ColumnClearance(1.3, 1.2)
    assert mid.zone_column((0.0, 0.0, 0.5), 1.2, (0.3, 0.0)).b == pytest.approx(
        (0.3 + BEAD_COAST_M - 0.05, 0.0)
    )
    # the flight's column there is the same zone
    flight = c.flight_volumes_at((2.0, 0.0, 0.5), (0.0, 0.0, 0.5), 1.2, 0, None, (0.3, 0.0))
    assert flight[-1].b == zone.b and flight[-1].slack_m == zone.slack_m
    # a zone of 0.15 m slack (r_c 1.5 m) covers the coast already: unchanged, as a zone with no bead
    wide = ColumnClearance(1.5, 1.2)
    assert wide.zone_slack_m == pytest.approx(0.15)
    assert wide.zone_column((0.0, 0.0, 0.5), 1.2, (0.3, 0.0)).b == (0.3, 0.0)
    assert coasted((0.0, 0.0), None, 0.0) is None
    assert coasted((1.0, 1.0), (1.0, 1.0), 0.0) == (1.0, 1.0)


def test_a_pickups_zone_is_as_wide_as_a_brick_may_lie_off_it() -> None:
    # at compact r_c a zone has no slack: a brick UAV aligned over a brick 0.05 m off its approximate pickup and
    # came down 0.12-0.13 m from the zone's axis (bench_layouts --compact seeds 2 and 6, up to 2.6 s)
    c = ColumnClearance(0.6, 1.2)
    c.pickups = [(1.0, 0.0)]
    assert c.zone_column((1.0, 0.0, 0.5), 1.2).slack_m == PICKUP_OFFSET_M
    assert c.zone_column((3.0, 0.0, 0.5), 1.2).slack_m == 0.0  # (a drop-off: as before)
    flight = c.flight_volumes_at((3.0, 0.0, 0.5), (1.0, 0.0, 0.5), 1.2, 0, None)
    assert flight[-1].kind == "zone" and flight[-1].slack_m == PICKUP_OFFSET_M
    wide = ColumnClearance(1.5, 1.2)
    wide.pickups = [(1.0, 0.0)]
    assert wide.zone_column((1.0, 0.0, 0.5), 1.2).slack_m == pytest.approx(0.15)  # (wider already)


def test_a_uav_still_climbing_a_hop_from_its_next_site_keeps_its_climb() -> None:
    # the 200-brick bond on arducopter (seed 1, glue-2 at 2028.5 s): 0.3 m from its next segment's start, climbing
    # at 1.27 m to a leg at 1.55 m, its climb and leg were freed as if it were coming down over the site
    vols = flight_volumes((0.22, 0.0), 1.27, 1.55, (0.525, 0.0, 1.25), 1.55, None, (0.675, 0.0), 0.15)
    assert ahead_of(vols, 0.226, 0.0, 1.27) is None  # nothing freed: it is at its climb, not over its site
    assert ahead_of(vols, 0.52, 0.0, 1.30) == [vols[-1]]  # coming down over the site: the zone alone


def test_a_sprayer_climbs_out_of_its_zone_inside_it_on_the_pyramid() -> None:
    # main: 0.137 m and 1.40 s (glue-1 climbing to the next segment's transit altitude over a zone topped at its
    # own; then a nearer hold point reserved at the risen layer, flown at the old one)
    mission = SimulatedMission.from_blueprint(
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml"), seed=1, vehicle="arducopter"
    )
    r = mission.run()
    assert r.completed and r.conflict_violations == 0
    e = r.envelope_excursion
    assert e is not None and e.m <= ALLOWANCE_M and e.s == 0.0, e
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0


def test_a_sprayer_at_compact_clearance_stays_in_its_zone_past_the_beads_end() -> None:
    # main: 0.132 m and 4.65 s (glue-1 coasting 0.13 m past its bead's end, then climbing beside its column)
    seed = 29
    r = simulate(random_layout(random.Random(seed), COMPACT), seed=seed)
    assert r.completed and r.conflict_violations == 0
    e = r.envelope_excursion
    assert e is not None and e.m <= ALLOWANCE_M and e.s == 0.0, e
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
