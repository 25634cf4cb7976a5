"""``--policy schedule`` (masonry.planner.schedule_policy) in model time, and the bound's order on random walls:
cheap terms <= CP-SAT's optimum <= simulated makespans."""

from __future__ import annotations

import heapq
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint_gen import running_bond
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.errors import PlanningError
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.schedule_file import stamp_schedule
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.bound_terms import bound_terms
from masonry.planner.bounds import min_cycles_s, min_durations_s
from masonry.planner.schedule import solve_schedule
from masonry.planner.schedule_policy import ScheduleDispatcher, make_dispatcher
from masonry.planner.schedule_values import OfflineSchedule, ScheduledTask, UavSchedule


@pytest.fixture(scope="module")
def wall():
    bp = running_bond(2, 4)
    bp = with_fleet(bp, fleet_for(bp, 2, 1))
    p = make_plan(bp)
    s = solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=3.0, workers=1)
    return bp, p, s


def run(d, durations, lose=None):
    """Every task takes its planned duration; ``lose``: a UAV removed before the first assignment."""
    if lose:
        d.remove_uav(lose)
    now, events, seq = 0.0, [], 0
    while True:
        for a in d.assign():
            heapq.heappush(events, (now + durations[a.task_id], seq, a.task_id))
            seq += 1
        if not events:
            return now
        now, _, tid = heapq.heappop(events)
        d.complete(tid)


def test_follows_the_schedule_when_nothing_goes_wrong(wall):
    bp, p, s = wall
    planned = {t.id: t.end_s - t.start_s for u in s.uavs for t in u.tasks}
    d = make_dispatcher(p, bp.fleet, "schedule", schedule=s)
    assert isinstance(d, ScheduleDispatcher)
    makespan = run(d, planned)
    assert d.finished and d.followed == len(planned) and d.fallbacks == 0
    # no empty flights in this model run, so it is never later than the plan
    assert makespan <= s.makespan_s + 1e-6


def test_a_lost_uav_and_failures_fall_back(wall):
    bp, p, s = wall
    planned = {t.id: t.end_s - t.start_s for u in s.uavs for t in u.tasks}
    busy = next(u for u in s.uavs if u.role == "brick" and u.tasks)
    d = make_dispatcher(p, bp.fleet, "schedule", schedule=s)
    run(d, planned, lose=busy.name)
    assert d.finished and d.fallbacks >= len(busy.tasks)
    # a failed task goes back to its UAV
    d = make_dispatcher(p, bp.fleet, "schedule", schedule=s)
    first = d.assign()
    a = next(x for x in first if x.uav != "glue-1") if any(x.uav != "glue-1" for x in first) else first[0]
    d.fail(a.task_id)
    again = d.assign()
    assert (a.uav, a.task_id) in {(x.uav, x.task_id) for x in again}


def test_schedule_policy_needs_a_schedule_and_the_plan(wall):
    bp, p, s = wall
    with pytest.raises(PlanningError, match="needs an offline schedule"):
        make_dispatcher(p, bp.fleet, "schedule")
    other = make_plan(running_bond(2, 2))
    with pytest.raises(PlanningError):
        ScheduleDispatcher(other, bp.fleet, s)


@settings(max_examples=4, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1))
def test_bound_below_optimum_below_simulated(seed):
    bp = random_layout(
        random.Random(seed), LayoutLimits(max_courses=2, max_per_course=3, max_uavs_per_role=2)
    )
    fleet = fleet_for(bp)  # the fleet as masonry sim and masonry schedule order it
    bp = with_fleet(bp, fleet) if fleet != bp.fleet else bp
    p = make_plan(bp)
    if not any(not t.done for t in p.tasks):
        return
    s = stamp_schedule(
        solve_schedule(
            p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=2.0, workers=1, seed=1
        ),
        bp,
    )
    md = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
    terms = bound_terms(p, bp.fleet, md, work_s=min_cycles_s(p, bp.fleet, md))
    n = sum(1 for t in p.tasks if not t.done)
    # the model rounds every duration and flight down to a tick: the cheap terms may exceed it by that much
    slack = 2 * n * s.tick_s
    assert terms.value_s <= s.makespan_s + slack, (seed, terms, s.makespan_s)
    assert s.bound_s <= s.makespan_s + slack
    for policy in ("critical-path", "schedule"):
        # the schedule's model is the paper's rule: a ``site`` mission may beat its optimum
        r = simulate(
            bp,
            policy=policy,
            schedule=s if policy == "schedule" else None,
            seed=seed % 1000,
            reservation="task",
        )
        assert r.completed, (seed, policy)
        assert r.lower_bound_s <= r.makespan_s, (seed, policy, r.lower_bound_kind)
        assert s.bound_s <= r.makespan_s, (seed, policy)
        if s.status == "optimal":
            assert s.makespan_s <= r.makespan_s, (seed, policy)


def _hand_schedule(bp, order):
    """An offline schedule of ``bp`` giving each UAV the task ids of ``order`` (name -> ids), in that order."""
    fleet = {u.name: u.role for u in bp.fleet}
    uavs = tuple(
        UavSchedule(
            name, fleet[name], tuple(ScheduledTask(t, float(k), float(k) + 1.0) for k, t in enumerate(ids))
        )
        for name, ids in order.items()
    )
    return OfflineSchedule(
        uavs=uavs,
        makespan_s=float(max(len(ids) for ids in order.values())),
        bound_s=0.0,
        bound_kind="none",
        status="feasible",
        solve_time_s=0.0,
        decomposition="none",
        reservation="site",
        time_limit_s=0.0,
        seed=0,
        tick_s=0.1,
    )


@pytest.fixture(scope="module")
def glued():
    """A running bond of 2 x 4 with its first course placed: the seven segments on it are contiguous (each starts
    where the one before ends) and available from the start."""
    bp = running_bond(2, 4, placed_courses=1)
    return bp, make_plan(bp)


def _sprayed(d, glue):
    """The segments ``glue`` is given, each completed at once, until it has none (the brick UAVs never run)."""
    out = []
    while True:
        mine = [a for a in d.assign() if a.uav == glue]
        if not mine:
            return out
        out.append(mine[0].task_id)
        d.complete(mine[0].task_id)


def test_a_sprayer_chains_into_its_own_next_segment(glued):
    bp, p = glued
    bricks = [u.name for u in bp.fleet if u.role == "brick"]
    glue = next(u.name for u in bp.fleet if u.role == "adhesion")
    planned = ["A0", "A2", "A4", "A6", "A1", "A3", "A5"]
    s = _hand_schedule(bp, {glue: planned, bricks[0]: ["B4", "B5", "B6", "B7"]})
    for chain in (True, False):
        d = make_dispatcher(p, bp.fleet, "schedule", schedule=s, reservation="site")
        d.chain = chain
        d.remove_uav(bricks[0])  # (no brick in progress to block a segment)
        # at the end of A0 the segment starting there (A1, its own, available) comes before A2, and so on
        assert _sprayed(d, glue) == (sorted(planned) if chain else planned)
        assert d.followed == len(planned)


def test_a_uav_with_nothing_of_its_own_takes_a_busy_uavs_task():
    """``steal``: a sprayer whose planned segments are all done takes an available one planned for the sprayer
    busy now, rather than wait for it to come back (off: it waits)."""
    bp = running_bond(2, 12, placed_courses=1)
    bp = with_fleet(bp, fleet_for(bp, 1, 2))
    p = make_plan(bp)
    one, two = (u.name for u in bp.fleet if u.role == "adhesion")
    brick = next(u.name for u in bp.fleet if u.role == "brick")
    segments = [t.id for t in p.tasks if t.id.startswith("A")]
    bricks = [t.id for t in p.tasks if t.id.startswith("B") and not t.done]
    s = _hand_schedule(bp, {one: segments[:-1], two: segments[-1:], brick: bricks})
    for steal in (True, False):
        d = make_dispatcher(p, bp.fleet, "schedule", schedule=s, reservation="site")
        d.steal = steal
        first = {a.uav: a.task_id for a in d.assign()}
        assert first[one] == segments[0] and first[two] == segments[-1]
        d.complete(segments[-1])
        again = {a.uav: a.task_id for a in d.assign()}
        if steal:
            assert again[two] in segments[1:-1] and d.fallbacks == 1, again
        else:
            assert two not in again and d.fallbacks == 0, again
