"""The ``site`` reservation (masonry.mission.sites): conflicting tasks may run at once, their UAVs never work at
their sites at once."""

from __future__ import annotations

import pytest

from masonry.blueprint import UavSpec
from masonry.blueprint_gen import running_bond
from masonry.errors import InputError, PlanningError
from masonry.mission.simulate import simulate
from masonry.mission.sites import SiteIntervals
from masonry.planner import plan as make_plan
from masonry.planner.dispatch import Dispatcher
from masonry.planner.tasks import BrickTask, Plan

B0 = BrickTask("B0", 0, False, (0.0, 0.0, 0.15), 0.0, (0.0, -3.0, 0.05))
B1 = BrickTask("B1", 1, False, (0.3, 0.0, 0.15), 0.0, (0.5, -3.0, 0.05))
B2 = BrickTask("B2", 2, False, (6.0, 0.0, 0.15), 0.0, (6.0, -3.0, 0.05))
PLAN = Plan((B0, B1, B2), (), (("B0", "B1"),))


def test_a_site_is_entered_only_while_no_conflicting_task_works_at_its_own():
    tasks = {"a": "B0", "b": "B1", "c": "B2"}
    s = SiteIntervals(PLAN, tasks.get, exclusive=True)
    assert s.may_enter("a", (0.0, -3.0, 1.2))  # a's pickup: not a site interval
    assert s.may_enter("a", (0.0, 0.0, 1.2))
    s.entered("a", (0.0, 0.0, 1.2), 10.0)
    assert not s.may_enter("b", (0.3, 0.0, 1.2))  # B1 conflicts with B0, whose UAV works at its site
    assert s.may_enter("c", (6.0, 0.0, 1.2))
    assert not s.leaving("a", (0.0, 0.0, 1.3), 11.0)  # the same site: still there
    assert s.leaving("a", (0.0, -3.0, 1.2), 20.0)  # off to the pallet: the site is free
    assert s.may_enter("b", (0.3, 0.0, 1.2))
    s.entered("b", (0.3, 0.0, 1.2), 21.0)
    assert s.released("b", (0.3, 0.0, 0.0), 30.0)  # out of the column over it
    assert [(v.task_id, v.uav, v.start_s, v.end_s) for v in s.visits] == [
        ("B0", "a", 10.0, 20.0),
        ("B1", "b", 21.0, 30.0),
    ]
    # the paper's reservation records the visits and lets every flight go
    assert SiteIntervals(PLAN, tasks.get, exclusive=False).may_enter("b", (0.3, 0.0, 1.2))


def test_with_the_site_reservation_an_idle_uav_takes_a_conflicting_task_only_when_nothing_else_is_left():
    fleet = [UavSpec(n, "brick", (3.0 * k, -6.0, 0.0)) for k, n in enumerate("abc")]
    two = fleet[:2]
    # the paper: B0 and B1 conflict, so a third UAV stays idle
    assert len(Dispatcher(PLAN, fleet, reservation="task").assign()) == 2
    # site: the first two UAVs get non-conflicting tasks, the third the conflicting one (it fetches its brick)
    got = [x.task_id for x in Dispatcher(PLAN, fleet, reservation="site").assign()]
    assert len(got) == 3 and "B2" in got[:2] and {got[0], got[1]} != {"B0", "B1"}
    # with two UAVs, both get non-conflicting tasks: the conflicting pair is not preferred
    assert sorted(x.task_id for x in Dispatcher(PLAN, two, reservation="site").assign()) in (
        ["B0", "B2"],
        ["B1", "B2"],
    )
    with pytest.raises(PlanningError, match="unknown reservation"):
        Dispatcher(PLAN, fleet, reservation="nope")
    with pytest.raises(InputError, match="`reservation` must be one of"):
        simulate(running_bond(1, 2), reservation="nope")


def _overlap(a, b):
    return max(a[0], b[0]) < min(a[1], b[1])


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2])
def test_conflicting_tasks_run_at_once_but_never_work_at_their_sites_at_once(seed):
    bp = running_bond(3, 12, placed_courses=1, brick_uavs=4, adhesion_uavs=2)
    r = simulate(bp, seed=seed, reservation="site")
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
    p = make_plan(bp)
    tasks = {t.id: t for t in r.tasks}
    runs, sites = 0, 0
    for a, b in p.conflicts:
        ta, tb = tasks.get(a), tasks.get(b)
        if ta is None or tb is None:
            continue
        assert ta.site_start_s is not None and tb.site_start_s is not None
        runs += _overlap((ta.start_s, ta.end_s), (tb.start_s, tb.end_s))
        sites += _overlap((ta.site_start_s, ta.site_end_s), (tb.site_start_s, tb.site_end_s))
    assert runs > 0  # the reservation lets conflicting tasks run at once ...
    assert sites == 0  # ... and keeps their work at their sites apart, measured from the report
    deps = {}
    for u, v in p.dependencies:
        deps.setdefault(u, []).append(v)
    prefetched = 0
    for tid, t in tasks.items():
        for v in deps.get(tid, ()):
            if v in tasks:
                assert tasks[v].end_s <= t.site_start_s  # a site interval starts after its prerequisites
        prefetched += any(v in tasks and tasks[v].end_s > t.start_s for v in deps.get(tid, ()))
    assert prefetched > 0  # bricks were fetched while the glue under them was still being sprayed


@pytest.mark.slow
def test_the_paper_reservation_keeps_conflicting_tasks_apart_for_their_whole_duration():
    bp = running_bond(3, 12, placed_courses=1, brick_uavs=4, adhesion_uavs=2)
    r = simulate(bp, seed=1, reservation="task")
    assert r.completed and r.conflict_violations == 0
    tasks = {t.id: t for t in r.tasks}
    for a, b in make_plan(bp).conflicts:
        if a in tasks and b in tasks:
            ta, tb = tasks[a], tasks[b]
            assert not _overlap((ta.start_s, ta.end_s), (tb.start_s, tb.end_s))


def test_a_uav_waiting_for_a_bead_holds_clear_of_it():
    """A brick UAV that waits for the bead under its brick does not hold over that bead, whose sprayer had not
    asked yet (it did, on the 12 m wall at 300 s of open time, until hold patience broke the wait)."""
    from masonry.mission.airspace_state import hold_candidates
    from masonry.planner.tasks import AdhesionTask
    from masonry.segments import point_segment_m

    a0 = AdhesionTask("A0", 9, 1, (0.9, 0.0, 0.15), (1.6, 0.0, 0.15), 0.7)
    b1 = BrickTask("B1", 1, False, (1.2, 0.3, 0.3), 0.0, (0.5, -3.0, 0.05))
    plan = Plan((a0, b1), (("B1", "A0"),), ())
    done: set[str] = set()
    s = SiteIntervals(plan, {"brick": "B1", "glue": "A0"}.get, exclusive=True, is_done=done.__contains__)
    assert s.waited_on("brick") == (((0.9, 0.0), (1.6, 0.0)),)
    assert s.waited_on("glue") == () and s.waited_on("idle") == ()
    site = b1.position_m
    free = hold_candidates(site, (), 0.8)
    clear = hold_candidates(site, (), 0.8, waited_on=s.waited_on("brick"))

    def over_bead(p: tuple[float, float, float]) -> bool:
        return point_segment_m((p[0], p[1]), (0.9, 0.0), (1.6, 0.0)) < 1.1 * 0.8

    assert any(over_bead(p) for p in free), "without the rule some hold points lie over the bead"
    assert clear and not any(over_bead(p) for p in clear)
    done.add("A0")  # sprayed: nothing to wait for
    assert s.waited_on("brick") == ()
