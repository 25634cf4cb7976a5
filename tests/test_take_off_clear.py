"""A take-off does not wait in the air for the work beside it (issue 27 §4; masonry.mission.dispatch_chain
.ChainThrough._clear_of_work): where the airspace keeps work zones farther apart than the conflict radius r_c, a UAV
on its pad, while another UAV of its role is out, is not sent to an available task within that separation of a task
in progress; it takes the policy's best available task clear of them, or stays on its pad until the next event."""

from __future__ import annotations

import random

from masonry.blueprint import UavSpec
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.simulate import simulate
from masonry.planner.dispatch_admission import Admission
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.separation import SEPARATION_XY_M

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


def placed_course(*, far: bool) -> Plan:
    """Bricks placed at x = 0 and 0.9 m (and 5 m with ``far``), a segment on each: A0 and A1 are 0.6 m apart, under
    the 1.2 m separation but over r_c (no conflict between them); B9 goes on A0 (so A0 comes first)."""
    xs = (0.0, 0.9, 5.0) if far else (0.0, 0.9)
    bricks = tuple(
        BrickTask(f"B{k}", k, True, (x, 0.0, 0.05), 0.0, (x, -2.0, 0.05)) for k, x in enumerate(xs)
    )
    segments = tuple(
        AdhesionTask(f"A{k}", k, 9, (x - 0.15, 0.0, 0.1), (x + 0.15, 0.0, 0.1), 0.3) for k, x in enumerate(xs)
    )
    above = BrickTask("B9", 9, False, (0.0, 0.0, 0.15), 0.0, (0.0, -2.0, 0.05))
    return Plan((*bricks, *segments, above), (("B9", "A0"),), ())


#: a core of 4 + 2 (two brick UAVs per sprayer): neither sprayer is a spare
FLEET = [
    *(UavSpec(f"brick-{k}", "brick", (2.0 * k, -3.0, 0.0)) for k in range(1, 5)),
    UavSpec("glue-1", "adhesion", (-0.5, -3.0, 0.0)),
    UavSpec("glue-2", "adhesion", (1.5, -3.0, 0.0)),
]


def first_round(plan: Plan, apart_m: float | None) -> dict[str, str]:
    """glue-1 is out (it takes A0, the one with a brick waiting on it), glue-2 stands on its pad."""
    d = ChainThrough(plan, FLEET, reservation="site")
    d.admission = Admission(6, lambda name: name == "glue-2")  # six sites, six UAVs: the cap does not apply
    d.apart_m = apart_m
    return {a.uav: a.task_id for a in d.assign() if a.uav.startswith("glue")}


def test_a_uav_on_its_pad_takes_the_segment_clear_of_the_work_in_progress() -> None:
    assert first_round(placed_course(far=True), SEPARATION_XY_M) == {"glue-1": "A0", "glue-2": "A2"}
    # the rule off (r_c at least the separation, or the table): the nearest segment, beside A0
    assert first_round(placed_course(far=True), None) == {"glue-1": "A0", "glue-2": "A1"}


def test_with_none_clear_it_stays_on_its_pad() -> None:
    assert first_round(placed_course(far=False), SEPARATION_XY_M) == {"glue-1": "A0"}


def test_a_second_sprayer_does_not_make_the_compact_layout_slower() -> None:
    # main: seed 9 (4 towers, r_c 0.64 m) 3 + 2 158.7 s against 3 + 1 149.5 s: glue-2 left its pad for A1 beside B1
    # and A0 in progress and held 37 s for their zones, while glue-1 would have taken it after A0; now 140.3 s
    seed = 9
    bp = random_layout(random.Random(seed), COMPACT)
    one = simulate(bp, seed=seed, reservation="site", brick_uavs=3, adhesion_uavs=1)
    two = simulate(bp, seed=seed, reservation="site", brick_uavs=3, adhesion_uavs=2)
    assert one.completed and two.completed
    assert two.conflict_violations == 0 and two.dependency_violations == 0
    assert two.makespan_s <= one.makespan_s, (two.makespan_s, one.makespan_s)
