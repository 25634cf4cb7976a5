"""Admission (issue 27 §4, masonry.planner.dispatch_admission): on a wall too compact for its fleet, a UAV is not
given a task where the fleet already queues; it stays on its pad instead."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import UavSpec, load_blueprint
from masonry.mission.simulate import simulate
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_admission import (
    UAVS_PER_SITE,
    Admission,
    coming_alone,
    crowded,
    queued,
    site_width,
)
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

PYRAMID = Path(__file__).resolve().parent.parent / "blueprints" / "pyramid.yaml"


def brick(i: int, x: float) -> BrickTask:
    return BrickTask(f"B{i}", i, False, (x, 0.0, 0.05), 0.0, (x, -2.0, 0.05))


def bricks_in_one_place(n: int) -> Plan:
    """``n`` ready bricks, each conflicting with every other (all within r_c): one site at a time."""
    tasks = tuple(brick(i, 0.3 * i) for i in range(n))
    conflicts = tuple((f"B{a}", f"B{b}") for a in range(n) for b in range(a + 1, n))
    return Plan(tasks, (), conflicts)


def brick_fleet(n: int) -> list[UavSpec]:
    return [UavSpec(f"brick-{k + 1}", "brick", (0.3 * k, -3.0, 0.0)) for k in range(n)]


def test_site_width_counts_the_points_that_can_be_worked_at_once():
    pyramid_course = [(-1.05 + 0.3 * k, 0.0) for k in range(8)]  # 2.1 m wide, r_c 1.5 m: its two ends
    assert site_width(pyramid_course, 1.5) == 2
    assert site_width([(0.3 * k, 0.0) for k in range(41)], 1.5) == 9  # 12 m: every 1.5 m
    assert site_width([], 1.5) == 0


def test_a_task_is_crowded_within_two_conflict_hops_of_a_queued_one():
    neighbours = [[1], [0, 2], [1, 3], [2], []]  # a chain 0-1-2-3, and 4 alone
    none: list[list[int]] = [[] for _ in neighbours]
    assert crowded(0, [2], neighbours, none)  # 0 conflicts with 1, which conflicts with 2
    assert crowded(0, [1], neighbours, none)
    assert not crowded(0, [3], neighbours, none)  # three hops
    assert not crowded(4, [1, 2], neighbours, none)
    assert not crowded(0, [], neighbours, none)
    # 1 waits for 0 (its prerequisite): it never holds 0 back, or it would wait for it until it gave up
    assert not crowded(0, [1], neighbours, [[], [0], [], [], []])
    running = {0, 1, 3}
    assert queued(sorted(running), running.__contains__, lambda j: neighbours[j]) == [0, 1]


def test_on_a_compact_wall_the_fleet_past_the_queue_stays_on_its_pads():
    plan = bricks_in_one_place(3)
    d = Dispatcher(plan, brick_fleet(3), reservation="site")
    d.admission = Admission(width=1, landed=lambda _name: True)
    assert Admission(1, lambda _n: True).applies(3) and UAVS_PER_SITE == 2
    got = d.assign()
    # the first works, the second comes next (it fetches while the site is busy), the third would only queue
    assert [a.uav for a in got] == ["brick-1", "brick-2"]
    assert d.assign() == []
    d.complete(got[0].task_id)
    # the queue is gone (one task runs, nothing waits on it): the UAV now idle is given the last brick
    assert [a.uav for a in d.assign()] == ["brick-1"]


def test_without_the_rule_or_with_room_every_idle_uav_is_given_a_task():
    for admission in (None, Admission(width=2, landed=lambda _name: True)):  # 3 UAVs, 2 sites: room enough
        d = Dispatcher(bricks_in_one_place(3), brick_fleet(3), reservation="site")
        d.admission = admission
        assert len(d.assign()) == 3


def bricks_on_one_bead() -> Plan:
    """Three bricks in one place (all within r_c of each other) on one bead, far from them, still to spray."""
    bead = AdhesionTask("A0", 0, 1, (3.0, 0.0, 0.1), (3.3, 0.0, 0.1), 0.3)
    tasks = (bead, *(brick(i, 0.3 * i) for i in range(3)))
    conflicts = (("B0", "B1"), ("B0", "B2"), ("B1", "B2"))
    return Plan(tasks, tuple((f"B{i}", "A0") for i in range(3)), conflicts)


def test_a_uav_on_its_pad_prefetches_a_brick_only_as_the_one_uav_coming_to_its_site():
    fleet = [*brick_fleet(3), UavSpec("glue-1", "adhesion", (3.0, -3.0, 0.0))]
    got = {}
    for landed in (True, False):
        d = Dispatcher(bricks_on_one_bead(), fleet, reservation="site")
        d.admission = Admission(width=2, landed=lambda _name, on_pad=landed: on_pad)
        got[landed] = sorted(a.uav for a in d.assign())
    # on their pads: one brick UAV works, one comes, the third stays; in the air, every one is given a brick
    assert got[True] == ["brick-1", "brick-2", "glue-1"]
    assert got[False] == ["brick-1", "brick-2", "brick-3", "glue-1"]
    d = Dispatcher(bricks_on_one_bead(), fleet, reservation="site")
    assert len(d.assign()) == 4  # without the rule


def test_coming_alone():
    # 0 - 1 - 2 conflict in a row, 3 conflicts with 0 only
    neighbours = ((1, 2, 3), (0, 2), (0, 1), (0,))
    assert coming_alone(1, lambda k: k == 0, neighbours)  # 0 works, 1 would come
    assert not coming_alone(1, lambda k: k in (0, 2), neighbours)  # two run at its site already
    assert not coming_alone(
        3, lambda k: k in (0, 1), neighbours
    )  # 0 runs, and 1 waits on it: 3 would be second
    assert coming_alone(3, lambda _k: False, neighbours)


def test_a_uav_in_the_air_is_not_held_back_by_the_queue():
    # two bricks (their UAVs in the air) queued at one site; an adhesion UAV in the air is given its
    # (conflicting) segment anyway, one on its pad is not
    tasks = (brick(0, 0.0), brick(1, 0.3), AdhesionTask("A0", 0, 1, (0.6, 0.0, 0.1), (0.9, 0.0, 0.1), 0.3))
    plan = Plan(tasks, (), (("B0", "B1"), ("B1", "A0"), ("B0", "A0")))
    fleet = [*brick_fleet(2), UavSpec("glue-1", "adhesion", (2.0, -3.0, 0.0))]
    in_air = Dispatcher(plan, fleet, reservation="site")
    in_air.admission = Admission(width=1, landed=lambda _name: False)
    assert [a.uav for a in in_air.assign()] == ["brick-1", "brick-2", "glue-1"]
    on_pad = Dispatcher(plan, fleet, reservation="site")
    on_pad.admission = Admission(width=1, landed=lambda name: name == "glue-1")
    assert [a.uav for a in on_pad.assign()] == ["brick-1", "brick-2"]


def test_the_cap_shares_the_uavs_a_wall_keeps_busy_among_the_roles():
    pyramid = Admission(width=2, landed=lambda _name: True)  # 2 UAVs per site that can be worked at once: 4
    assert [(pyramid.cap(b, b + a), pyramid.cap(a, b + a)) for b, a in ((4, 2), (6, 3), (8, 4))] == [
        (3, 1)
    ] * 3
    assert pyramid.cap(3, 5) == 2 and pyramid.cap(2, 5) == 2  # 2.4 and 1.6, rounded
    assert Admission(width=1, landed=lambda _name: True).cap(1, 9) == 1  # every role keeps a UAV it may fly


def test_the_uavs_past_the_cap_stay_on_their_pads_but_one_in_the_air_is_not_held():
    # four bricks far apart (nothing conflicts, nothing queues) on a wall 1 site wide: 2 UAVs may be busy
    plan = Plan(tuple(brick(i, 5.0 * i) for i in range(4)), (), ())
    on_pads = Dispatcher(plan, brick_fleet(3), reservation="site")
    on_pads.admission = Admission(width=1, landed=lambda _name: True)
    got = on_pads.assign()
    assert [a.uav for a in got] == ["brick-1", "brick-2"]
    assert on_pads.assign() == []
    on_pads.complete(got[0].task_id)  # a UAV comes free: one on its pad may go
    assert len(on_pads.assign()) == 1
    in_air = Dispatcher(plan, brick_fleet(3), reservation="site")
    in_air.admission = Admission(width=1, landed=lambda name: name != "brick-3")
    # brick-3, out with no task, is never held back; it counts against the cap (it takes the next task), so of
    # the two on their pads only brick-1 goes (until branch pyr38 both went: three busy past the cap of two)
    assert [a.uav for a in in_air.assign()] == ["brick-1", "brick-3"]


@pytest.mark.slow
def test_the_bundled_pyramid_with_a_large_fleet_completes_apart_with_the_rule_on():
    # the defaults (columns, site, critical-path): 6 + 3 UAVs on a wall 2 sites wide, so the rule applies
    r = simulate(load_blueprint(PYRAMID), brick_uavs=6, adhesion_uavs=3, seed=1, camera="geometric")
    assert r.completed and r.stall is None
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    assert not any("hold_patience_s" in (a.reason or "") for a in r.attempts)
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0


def test_a_uav_out_with_no_task_counts_against_its_roles_cap_but_not_one_flying_home_for_its_swap():
    # a wall 1 site wide, 3 brick UAVs: 2 may be busy. brick-1 is out (in the air) with no task: it takes the
    # next one, so it counts; brick-3, back on its pad, stays there. Sent home for its swap, brick-1 does not
    # count: its place goes to a UAV on its pad.
    plan = Plan(tuple(brick(i, 5.0 * i) for i in range(4)), (), ())
    sent: set[str] = set()
    d = Dispatcher(plan, brick_fleet(3), reservation="site")
    d.admission = Admission(width=1, landed=lambda name: name != "brick-1", swap_sent=sent.__contains__)
    got = d.assign()
    assert [a.uav for a in got] == ["brick-1", "brick-2"]
    d.complete(got[0].task_id)  # brick-1 is out with nothing
    not_brick_1 = "brick-1".__ne__  # mission control gives it nothing now (its swap is due)
    assert d.assign(may_start=not_brick_1) == []
    sent.add("brick-1")
    assert [a.uav for a in d.assign(may_start=not_brick_1)] == ["brick-3"]
    assert not d.capped_alone("brick")  # 2 may be busy


def test_a_role_capped_at_one_busy_uav_is_capped_alone():
    glue = [UavSpec(f"glue-{k}", "adhesion", (2.0 + k, -3.0, 0.0)) for k in (1, 2)]
    fleet = [*brick_fleet(4), *glue]
    d = Dispatcher(bricks_in_one_place(2), fleet, reservation="site")
    assert not d.capped_alone("adhesion")  # no rule
    d.admission = Admission(width=2, landed=lambda _name: True)  # the pyramid at 4 + 2: 3 + 1 busy
    assert d.capped_alone("adhesion") and not d.capped_alone("brick")
    d.admission = Admission(width=3, landed=lambda _name: True)  # 6 UAVs, room for 6: the rule does not apply
    assert not d.capped_alone("adhesion")


def test_the_admission_rule_holds_under_the_table_airspace_too() -> None:
    """Issue 27 (docs/performance/fleet.md, "Why the table is slow on the pyramid"): on the pyramid every site
    interval is the wall's, and under ``--airspace table`` a UAV not held back is granted its whole hop down from
    its pad, so a UAV the columns' admission rule keeps on its pad took tasks from there and held the wall for its
    whole flight in (8 + 4: 68 s; 4,234.8 s against 1,671.3 s with the rule). At 4 + 2 the rule keeps one sprayer
    busy: the second stays on its pad while the first works."""
    r = simulate(
        load_blueprint(PYRAMID),
        brick_uavs=4,
        adhesion_uavs=2,
        seed=1,
        camera="geometric",
        airspace="table",
        max_time_s=120.0,
    )
    sprayers = {t.uav for t in r.tasks if t.kind == "adhesion" and t.start_s is not None}
    assert sprayers == {"glue-1"}, sprayers
    glue2 = next(u for u in r.uavs if u.name == "glue-2")
    assert glue2.busy_s == 0.0 and glue2.distance_m == 0.0
