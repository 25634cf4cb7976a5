"""A hold point may lie by the pad of a landed UAV of the holder's role (issue 27 §4; docs/safety.md, "A hold point
by the pad of a landed UAV of its role"; masonry.mission.airspace_requests.landed_alike): every other pad is kept
clear of hold points as before."""

from __future__ import annotations

import random

from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.airspace import ColumnClearance
from masonry.mission.airspace_requests import landed_alike
from masonry.mission.simulate import simulate

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


def test_only_a_landed_uav_of_the_holders_role_lets_its_pad_be_held_by() -> None:
    homes = {"glue-1": (0.0, 0.0, 0.0), "glue-2": (2.0, 0.0, 0.0), "brick-1": (4.0, 0.0, 0.0)}
    c = ColumnClearance(0.6, 1.0, homes=homes)
    assert not landed_alike(c, "glue-1", "glue-2")  # no roles given: every pad kept clear, as before
    c.roles = {"glue-1": "adhesion", "glue-2": "adhesion", "brick-1": "brick"}
    assert landed_alike(c, "glue-1", "glue-2")  # (every UAV starts landed on its pad)
    assert not landed_alike(c, "glue-1", "brick-1")  # the other role: it may take what glue-1's task waits on
    assert c.take_off("glue-2")
    assert not landed_alike(c, "glue-1", "glue-2")  # out: it needs its pad's column to land


def test_an_idle_second_sprayer_does_not_make_the_compact_layout_slower() -> None:
    # main: seed 2 (a 4-brick running bond, r_c 0.79 m) 1 + 2 98.0 s against 1 + 1 82.6 s: glue-1 never takes a task,
    # but glue-3's hold point kept clear of its pad stood in brick-3's leg to B2, which climbed a layer
    seed = 2
    bp = random_layout(random.Random(seed), COMPACT)
    one = simulate(bp, seed=seed, reservation="site", brick_uavs=1, adhesion_uavs=1)
    two = simulate(bp, seed=seed, reservation="site", brick_uavs=1, adhesion_uavs=2)
    assert one.completed and two.completed
    assert two.conflict_violations == 0 and two.dependency_violations == 0
    assert two.min_separation_m is not None and two.min_separation_m >= 1.0
    assert two.makespan_s <= one.makespan_s, (two.makespan_s, one.makespan_s)
