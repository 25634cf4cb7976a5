"""The end of the wall's prefetch (issue 27, branches ``pyr40``, ``pyr41``; docs/safety.md, "Site reservation").

Under the ``site`` reservation a brick UAV with nothing else to take fetches a brick whose every segment under it is
done or in progress (:func:`masonry.planner.dispatch_graphs.prefetchable`). For the wall's last
:data:`~masonry.planner.dispatch.END_BRICKS` bricks to give, one segment under the brick may instead be only
*ready* (pending, its own prerequisites done): the pyramid's second-last brick is fetched while the lone sprayer
finishes the segment before its last one (4 + 2 seeds 1 / 3: 1,201 -> 1,184 / 1,183 s)."""

from __future__ import annotations

import random

from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.planner.dispatch import END_BRICKS, Dispatcher
from masonry.planner.dispatch_graphs import Adjacency, prefetchable
from masonry.planner.dispatch_values import DONE, PENDING, RUNNING, STUCK
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

BRICK, GLUE = "brick", "adhesion"


def graphs(prerequisites: list[list[int]]) -> Adjacency:
    """The adjacency of a plan given by each task's prerequisites (no conflicts)."""
    dependents: list[list[int]] = [[] for _ in prerequisites]
    for i, pre in enumerate(prerequisites):
        for p in pre:
            dependents[p].append(i)
    return Adjacency(dependents, prerequisites, [[] for _ in prerequisites])


# tasks 0-3 adhesion, 4 a brick under segment 3, 5 a brick on segments 0, 1 and 2, 6 the brick on 3 and 4
ROLES = [GLUE, GLUE, GLUE, GLUE, BRICK, BRICK, BRICK]
PRE = graphs([[], [], [], [4], [], [0, 1, 2], [3, 4]])


def test_one_ready_segment_is_accepted_only_with_ready_left() -> None:
    status = [RUNNING, PENDING, DONE, PENDING, DONE, PENDING, PENDING]  # 1 ready: B5 on A0 (running) and A1
    assert prefetchable(BRICK, [0], status, ROLES, PRE) == []
    assert prefetchable(BRICK, [0], status, ROLES, PRE, ready_left=1) == [5]


def test_two_ready_segments_are_rejected_with_ready_left_one() -> None:
    status = [RUNNING, PENDING, PENDING, PENDING, DONE, PENDING, PENDING]  # A1 and A2 both only ready
    assert prefetchable(BRICK, [0], status, ROLES, PRE, ready_left=1) == []
    assert prefetchable(BRICK, [0], status, ROLES, PRE, ready_left=2) == [5]


def test_a_segment_whose_own_prerequisites_are_not_done_is_rejected() -> None:
    # B6 on A3 and B4: B4 is running, A3 is pending but waits for B4 (not ready): not prefetched
    status = [DONE, DONE, DONE, PENDING, RUNNING, DONE, PENDING]
    assert prefetchable(BRICK, [4], status, ROLES, PRE, ready_left=1) == []
    # A3 in progress instead (B4 done): prefetched as before, whatever ready_left
    status = [DONE, DONE, DONE, RUNNING, DONE, DONE, PENDING]
    assert prefetchable(BRICK, [3], status, ROLES, PRE) == [6]


def test_a_ready_brick_under_it_is_never_left_for_later() -> None:
    # B6 on A3 (running) and B4, a brick, ready: B4 would need a brick UAV too, so B6 is not fetched
    status = [DONE, DONE, DONE, RUNNING, PENDING, DONE, PENDING]
    assert prefetchable(BRICK, [3], status, ROLES, PRE, ready_left=1) == []


def test_a_stuck_segment_is_never_taken_for_ready() -> None:
    status = [RUNNING, STUCK, DONE, PENDING, DONE, PENDING, PENDING]
    assert prefetchable(BRICK, [0], status, ROLES, PRE, ready_left=1) == []


# ---------------------------------------------------------------- the dispatcher


def fleet(bricks: int) -> list[UavSpec]:
    out = [UavSpec(f"brick-{k + 1}", "brick", (3.0 * k, -5.0, 0.0)) for k in range(bricks)]
    return [*out, UavSpec("glue-1", "adhesion", (-3.0, -5.0, 0.0))]


def bricks_on_two_segments(n: int, done: int) -> Plan:
    """B<k> on A<2k> and A<2k+1> (k < n), a run of two segments, 3 m apart along x; the first ``done`` bricks
    and their glue placed."""
    tasks: list[AdhesionTask | BrickTask] = []
    deps: list[tuple[str, str]] = []
    conflicts: list[tuple[str, str]] = []
    for k in range(n):
        x = 3.0 * k
        a, b = f"A{2 * k}", f"A{2 * k + 1}"
        tasks.append(AdhesionTask(a, 0, 1, (x - 0.3, 0.0, 0.1), (x, 0.0, 0.1), 0.3, done=k < done))
        tasks.append(AdhesionTask(b, 0, 1, (x, 0.0, 0.1), (x + 0.3, 0.0, 0.1), 0.3, done=k < done))
        tasks.append(BrickTask(f"B{k}", k, k < done, (x, 0.0, 0.15), 0.0, (x, -2.0, 0.05)))
        deps += [(f"B{k}", a), (f"B{k}", b)]
        conflicts.append((a, b))  # (a brick does not conflict with the glue under it: a prerequisite)
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts))


def test_the_last_two_bricks_are_fetched_with_one_segment_under_them_only_ready_and_earlier_ones_are_not() -> (
    None
):
    d = Dispatcher(bricks_on_two_segments(3, 0), fleet(2), reservation="site")
    d.assign()
    assert d.in_progress == {"A0": "glue-1"}  # three bricks to give: B0 waits, A1 is only ready
    d.complete("A0")
    d.assign()
    assert d.in_progress == {"A1": "glue-1", "B0": "brick-1"}  # every segment under B0 done or sprayed
    d.complete("A1")
    d.assign()
    # B1 and B2 the last two to give: B1 fetched with A2 sprayed and A3 only ready
    assert d.in_progress == {"B0": "brick-1", "A2": "glue-1", "B1": "brick-2"}
    d.complete("B0")
    d.complete("A2")
    d.assign()
    assert d.in_progress == {
        "B1": "brick-2",
        "A3": "glue-1",
    }  # the sprayer goes on to the segment B1 waits for
    d.complete("A3")
    d.assign()
    assert d.in_progress == {"B1": "brick-2", "A4": "glue-1", "B2": "brick-1"}  # the last brick: the same


def test_the_rule_is_the_site_reservations_alone() -> None:
    d = Dispatcher(bricks_on_two_segments(2, 0), fleet(2), reservation="task")
    d.assign()
    assert list(d.in_progress.values()) == ["glue-1"]


# ---------------------------------------------------------------- property: random small plans


@st.composite
def small_plans(draw: st.DrawFn) -> Plan:
    """A random DAG: bricks and segments at random places, each task after some earlier ones, random conflicts."""
    n = draw(st.integers(2, 16))
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    tasks: list[AdhesionTask | BrickTask] = []
    for i in range(n):
        x, y = rng.uniform(0, 4), rng.uniform(0, 4)
        if rng.random() < 0.5:
            tasks.append(BrickTask(f"B{i}", i, rng.random() < 0.1, (x, y, 0.15), 0.0, (x, y - 2.0, 0.05)))
        else:
            tasks.append(AdhesionTask(f"A{i}", i, i + 1, (x, y, 0.1), (x + 0.3, y, 0.1), 0.3))
    p_dep, p_conf = rng.uniform(0.1, 0.5), rng.uniform(0, 0.4)
    deps = [(tasks[j].id, tasks[i].id) for j in range(n) for i in range(j) if rng.random() < p_dep]
    conflicts = [(tasks[i].id, tasks[j].id) for j in range(n) for i in range(j) if rng.random() < p_conf]
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts))


@settings(max_examples=150)
@given(plan=small_plans(), bricks=st.integers(1, 3), glues=st.integers(1, 2), seed=st.integers(0, 10**6))
def test_a_prefetched_brick_never_has_more_non_running_segments_under_it_than_ready_left(
    plan: Plan, bricks: int, glues: int, seed: int
) -> None:
    rng = random.Random(seed)
    uavs = fleet(bricks)[:-1] + [
        UavSpec(f"glue-{k + 1}", "adhesion", (-3.0, -5.0 - k, 0.0)) for k in range(glues)
    ]
    d = Dispatcher(plan, uavs, reservation="site")
    prereqs = {t.id: {v for u, v in plan.dependencies if u == t.id} for t in plan.tasks}
    kind = {t.id: t.kind for t in plan.tasks}
    for _ in range(4 * len(plan.tasks) + 10):
        done, stuck = set(d.done), set(d.stuck)
        running = set(d.in_progress)
        for a in d.assign():
            left = prereqs[a.task_id] - done - running
            if kind[a.task_id] == "brick" and left:
                to_give = sum(1 for t, k in kind.items() if k == "brick" and t not in done | running | stuck)
                ready_left = 1 if to_give <= END_BRICKS else 0
                assert len(left) <= ready_left, f"{a.task_id}: {sorted(left)} neither done nor in progress"
                assert prereqs[a.task_id] & running, f"{a.task_id}: nothing under it in progress"
                for p in left:  # only ready: its own prerequisites done
                    assert p not in stuck and prereqs[p] <= done, f"{a.task_id}: {p} is not ready"
                    assert kind[p] == "adhesion", f"{a.task_id}: {p}, a brick, is left under it"
            else:
                assert not left, f"{a.task_id} given before its prerequisites"
            running.add(a.task_id)
        if not d.in_progress:
            assert d.finished or d.blocked
            break
        # a task ends only once everything under it is done (mission control's site gate): one always can
        can_end = sorted(t for t in d.in_progress if prereqs[t] <= set(d.done))
        assert can_end, f"every task in progress waits: {dict(d.in_progress)}"
        tid = rng.choice(can_end)
        if rng.random() < 0.15:
            d.fail(
                tid, count=False
            )  # back to the pool, never stuck (a brick fetched on a stuck segment waits)
        else:
            d.complete(tid)
