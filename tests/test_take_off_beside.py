"""A take-off does not cut ahead of the other role's work beside it (issue 27 §4; masonry.mission.dispatch_chain
.ChainThrough._not_ahead): where the airspace keeps work zones farther apart than the conflict radius r_c, a UAV on
its pad, while another UAV of its role holds a task, is not sent to a task within that separation of a task of the
other role that is ready, or becomes ready when a task in progress ends, whatever that role's count; it takes the
policy's best available task that is not, or stays on its pad until the next event. And a hold point may lie by the
pad of a landed UAV of the other role while another UAV of that role is out (masonry.mission.airspace_requests
.landed_covered)."""

from __future__ import annotations

import random

from masonry.blueprint import UavSpec
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.airspace import ColumnClearance
from masonry.mission.airspace_requests import landed_covered
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.simulate import simulate
from masonry.planner.dispatch_admission import Admission
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.separation import SEPARATION_XY_M

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


def course(*, far: bool) -> Plan:
    """B0 placed at x = 0 with A0 on it, ready, and B9 on A0; B1 at x = 0.9 m, 0.75 m from A0's line: under the
    1.2 m separation, in conflict with nothing (r_c smaller); B3 at x = 10 m; B2 at 5 m with ``far``."""
    xs = {0: 0.0, 1: 0.9, 2: 5.0, 3: 10.0} if far else {0: 0.0, 1: 0.9, 3: 10.0}
    bricks = tuple(BrickTask(f"B{k}", k, k == 0, (x, 0.0, 0.05), 0.0, (x, -2.0, 0.05)) for k, x in xs.items())
    a0 = AdhesionTask("A0", 0, 9, (-0.15, 0.0, 0.1), (0.15, 0.0, 0.1), 0.3)
    above = BrickTask("B9", 9, False, (0.0, 0.0, 0.15), 0.0, (0.0, -2.0, 0.05))
    return Plan((*bricks, a0, above), (("A0", "B0"), ("B9", "A0")), ())


def fleet(sprayers: int) -> list[UavSpec]:
    """brick-1 by B3, brick-2 by B1 (its nearest brick), the sprayers far off."""
    return [
        UavSpec("brick-1", "brick", (10.0, -3.0, 0.0)),
        UavSpec("brick-2", "brick", (0.9, -3.0, 0.0)),
        *(UavSpec(f"glue-{k}", "adhesion", (-3.0 * k, -3.0, 0.0)) for k in range(1, sprayers + 1)),
    ]


def first_round(plan: Plan, apart_m: float | None, sprayers: int = 1) -> dict[str, str]:
    """brick-1 is out and takes B3 (no work in progress near B1 then); brick-2 stands on its pad."""
    d = ChainThrough(plan, fleet(sprayers), reservation="site")
    d.admission = Admission(6, lambda name: name == "brick-2")  # six sites: the cap does not apply
    d.apart_m = apart_m
    return {a.uav: a.task_id for a in d.assign() if a.uav.startswith("brick")}


def test_a_uav_on_its_pad_takes_the_task_apart_from_the_other_roles_next_work() -> None:
    assert first_round(course(far=True), SEPARATION_XY_M) == {"brick-1": "B3", "brick-2": "B2"}
    # with two sprayers too: beside a compact wall's work, another sprayer cannot take A0 elsewhere
    assert first_round(course(far=True), SEPARATION_XY_M, sprayers=2) == {"brick-1": "B3", "brick-2": "B2"}
    # the rule off (r_c at least the separation, or the table): B1, in conflict with nothing
    assert first_round(course(far=True), None) == {"brick-1": "B3", "brick-2": "B1"}


def test_with_none_apart_it_stays_on_its_pad() -> None:
    assert first_round(course(far=False), SEPARATION_XY_M) == {"brick-1": "B3"}
    assert first_round(course(far=False), None) == {"brick-1": "B3", "brick-2": "B1"}


def test_a_landed_uav_of_the_other_role_lets_its_pad_be_held_by_while_another_of_its_role_is_out() -> None:
    homes = {"glue-1": (0.0, 0.0, 0.0), "brick-1": (2.0, 0.0, 0.0), "brick-2": (4.0, 0.0, 0.0)}
    c = ColumnClearance(0.6, 1.0, homes=homes)
    c.roles = {"glue-1": "adhesion", "brick-1": "brick", "brick-2": "brick"}
    assert not landed_covered(c, "glue-1", "brick-2")  # both brick UAVs on their pads: either may be needed
    assert c.take_off("brick-1")
    assert landed_covered(c, "glue-1", "brick-2")  # brick-1 is out: it takes what glue-1's task waits on
    assert not landed_covered(c, "glue-1", "brick-1")  # out: it needs its pad's column to land
    assert not landed_covered(c, "brick-2", "glue-1")  # no other sprayer out
    c.roles = {}
    assert not landed_covered(c, "glue-1", "brick-2")  # no roles given: every pad kept clear, as before


def fly(seed: int, brick_uavs: int, adhesion_uavs: int) -> float:
    bp = random_layout(random.Random(seed), COMPACT)
    r = simulate(bp, seed=seed, reservation="site", brick_uavs=brick_uavs, adhesion_uavs=adhesion_uavs)
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
    return r.makespan_s


def test_a_second_brick_uav_does_not_make_seed_14_slower() -> None:
    # main: seed 14 (a 10-brick pyramid, r_c 0.53 m, 1.2 m wide) 2 + 1 400.2 s against 1 + 1 386.8 s: brick-2 left its
    # pad for B3 beside A4, ready, and its visit went before the sprayer's A1, which B0 waited on
    one, two = fly(14, 1, 1), fly(14, 2, 1)
    assert two <= one, (two, one)


def test_an_idle_second_brick_uav_does_not_make_seed_13_slower() -> None:
    # main: seed 13 2 + 1 389.1 s against 1 + 1 370.4 s; with the dispatch rule alone 382.6 s, brick-3 on its pad all
    # the mission, but the pad kept the sprayer's hold point off it, into brick-2's leg to the pallet (a climb)
    one, two = fly(13, 1, 1), fly(13, 2, 1)
    assert two <= one, (two, one)
