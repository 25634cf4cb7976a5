"""A take-off does not cut ahead of the other role's next task (issue 27 §4; masonry.planner.dispatch_admission
.cuts_ahead, masonry.mission.dispatch_chain.ChainThrough): a UAV on its pad, while another UAV of its role holds a
task, is given the policy's best available task of its role that is not within r_c of a task of the other role
ready now or when a task in progress ends, where there is one; else the task the dispatcher chose (never held back
by this rule)."""

from __future__ import annotations

import random

from masonry.blueprint import UavSpec
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.simulate import simulate
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_admission import Admission, cuts_ahead
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

#: bench_layouts.py --compact's limits (issue 27's layouts)
COMPACT = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))


def test_a_task_cuts_ahead_of_the_other_roles_task_ready_now_or_when_a_task_in_progress_ends() -> None:
    # 0 a brick; 1 a segment within r_c of it on brick 2; 3 a brick within r_c of 0 (its own role)
    roles = ["brick", "adhesion", "brick", "brick"]
    neighbours = [[1, 3], [0], [], [0]]
    prerequisites: list[list[int]] = [[], [2], [], []]

    def ahead(running: set[int], done: set[int]) -> bool:
        return cuts_ahead(0, roles, running.__contains__, done.__contains__, neighbours, prerequisites)

    assert ahead(running={2}, done=set())  # 1 becomes ready when 2, in progress, ends
    assert ahead(running=set(), done={2})  # 1 is ready
    assert not ahead(running=set(), done=set())  # 2 not even started: 1 is further off than one task
    assert not ahead(running={1, 2}, done=set())  # 1 in progress: a conflicting task, the site rule's queue
    assert not ahead(running=set(), done={1, 2})  # 1 done
    assert not ahead(running={3}, done=set())  # its own role's task: the dispatcher's conflicts already


def one_course() -> Plan:
    """B0 and B1 side by side, A0 sprayed on B0 (within r_c of B1), B2 far off."""
    tasks = (
        BrickTask("B0", 0, False, (0.0, 0.0, 0.05), 0.0, (0.0, -2.0, 0.05)),
        BrickTask("B1", 1, False, (0.3, 0.0, 0.05), 0.0, (0.3, -2.0, 0.05)),
        BrickTask("B2", 2, False, (3.0, 0.0, 0.05), 0.0, (3.0, -2.0, 0.05)),
        AdhesionTask("A0", 0, 3, (-0.15, 0.0, 0.1), (0.15, 0.0, 0.1), 0.3),
    )
    return Plan(tasks, (("A0", "B0"),), (("B1", "A0"),))


FLEET = [
    UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)),
    UavSpec("brick-2", "brick", (0.3, -3.0, 0.0)),
    UavSpec("glue-1", "adhesion", (-2.0, -3.0, 0.0)),
]


def first_round(d: Dispatcher, *, landed: bool) -> dict[str, str]:
    d.admission = Admission(3, lambda _name: landed)  # three sites, three UAVs: the cap does not apply
    return {a.uav: a.task_id for a in d.assign()}


def test_a_second_brick_uav_on_its_pad_takes_the_brick_apart_from_the_sprayers_next_segment() -> None:
    # brick-1 takes B0 (A0 waits on it); B1, nearest to brick-2, is within r_c of A0: A0 is ready when B0 is placed
    assert first_round(ChainThrough(one_course(), FLEET, reservation="site"), landed=True) == {
        "brick-1": "B0",
        "brick-2": "B2",
    }
    # the plain dispatcher, or a UAV in the air (never held back), takes B1
    assert first_round(Dispatcher(one_course(), FLEET, reservation="site"), landed=True)["brick-2"] == "B1"
    assert first_round(ChainThrough(one_course(), FLEET, reservation="site"), landed=False)["brick-2"] == "B1"


def test_with_nothing_apart_it_takes_the_dispatchers_choice_it_is_never_held_on_its_pad() -> None:
    plan = one_course()
    no_b2 = Plan(tuple(t for t in plan.tasks if t.id != "B2"), plan.dependencies, plan.conflicts)
    assert first_round(ChainThrough(no_b2, FLEET, reservation="site"), landed=True) == {
        "brick-1": "B0",
        "brick-2": "B1",
    }


def test_the_first_uav_of_its_role_out_is_never_held() -> None:
    # B0 placed already, A0 on it ready: B1 is within r_c of A0, and brick-1, the one brick UAV out, still takes it
    plan = one_course()
    b0 = plan.tasks[0]
    assert isinstance(b0, BrickTask)
    placed = Plan(
        (BrickTask("B0", 0, True, b0.position_m, 0.0, b0.pickup_m), *plan.tasks[1:]), (), plan.conflicts
    )
    d = ChainThrough(placed, FLEET, reservation="site")
    # (brick-2, with brick-1 out, takes B2; glue-1 queues for A0 behind B1, the site rule's)
    assert first_round(d, landed=True) == {"brick-1": "B1", "brick-2": "B2", "glue-1": "A0"}


def test_a_second_brick_uav_does_not_make_the_compact_layout_slower() -> None:
    # main: seed 7 (a 12-brick running bond, r_c 0.60 m) 2 + 1 500.2 s against 1 + 1 459.2 s, its second brick UAV
    # taking B2 beside A0 (ready when B0 is placed) at 6.4 s and breaking the sprayer's runs; now 428.7 s
    seed = 7
    bp = random_layout(random.Random(seed), COMPACT)
    one = simulate(bp, seed=seed, reservation="site", brick_uavs=1, adhesion_uavs=1)
    two = simulate(bp, seed=seed, reservation="site", brick_uavs=2, adhesion_uavs=1)
    assert one.completed and two.completed
    assert two.conflict_violations == 0 and two.dependency_violations == 0
    assert two.makespan_s <= one.makespan_s, (two.makespan_s, one.makespan_s)


def test_not_with_several_uavs_of_the_other_role() -> None:
    # two sprayers: either may take A0 where it is; brick-2 takes the brick the dispatcher chose, B1
    fleet = [*FLEET, UavSpec("glue-2", "adhesion", (-3.0, -3.0, 0.0))]
    assert first_round(ChainThrough(one_course(), fleet, reservation="site"), landed=True)["brick-2"] == "B1"
