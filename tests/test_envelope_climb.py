"""Every UAV inside the volumes mission control reserved for it under the columns (issue 27 §4.3; docs/safety.md,
"The envelope excursion"): a sprayer climbs out of its zone inside it, a zone along a bead covers the sprayer's
coast past its end, a pickup's zone covers where the brick may lie off it, a UAV still climbing near its next
site keeps its climb, and a nearer hold point is reserved at the altitude its UAV flies to it."""

from __future__ import annotations

from pathlib import Path

from masonry.blueprint import load_blueprint
from masonry.blueprint_random import LayoutLimits
from masonry.mission.envelope import ALLOWANCE_M
from masonry.mission.simulate import SimulatedMission
from masonry.mission.volumes import ahead_of, flight_volumes

ROOT = Path(__file__).resolve().parents[1]

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


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
