"""Dispatcher: policies, failures, UAV loss, resume, and the safety invariants as property tests."""

from __future__ import annotations

import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.errors import PlanningError
from masonry.planner.dispatch import Assignment, Dispatcher
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan


def P(x: float, y: float = 0.0, z: float = 0.0) -> tuple[float, float, float]:
    return (x, y, z)


def brick(i: int, x: float, *, done: bool = False, pickup_x: float = -2.0, z: float = 0.05) -> BrickTask:
    return BrickTask(f"B{i}", i, done, (x, 0.0, z), 0.0, (pickup_x, 0.0, 0.05))


def glue(n: int, x0: float, x1: float, below: int = 0, above: int = 1, z: float = 0.1) -> AdhesionTask:
    return AdhesionTask(f"A{n}", below, above, (x0, 0.0, z), (x1, 0.0, z), abs(x1 - x0))


def fleet(bricks: int = 1, glues: int = 1, home: float = -3.0) -> list[UavSpec]:
    return [UavSpec(f"brick-{k + 1}", "brick", P(home, k)) for k in range(bricks)] + [
        UavSpec(f"glue-{k + 1}", "adhesion", P(home, -k - 1)) for k in range(glues)
    ]


def case_study_plan() -> Plan:
    """The paper's Section VI: A0, A1 on pre-placed bricks; B0 after A0, B1 after A1; B0 conflicts with A1."""
    tasks = (
        brick(0, 0.3),
        brick(1, 1.0),
        glue(0, 0.2, 0.4),
        glue(1, 0.9, 1.1),
    )
    return Plan(tasks, (("B0", "A0"), ("B1", "A1")), (("B0", "A1"),))


def ids(assignments: list[Assignment]) -> list[str]:
    return [a.task_id for a in assignments]


# ---------------------------------------------------------------- basic behaviour


@pytest.mark.parametrize("policy", ["fifo", "critical-path", "nearest"])
def test_case_study_order_with_one_uav_per_role(policy: str) -> None:
    d = Dispatcher(case_study_plan(), fleet(), policy)
    assert ids(d.assign()) == ["A0"]
    assert d.assign() == []  # nothing else: B0 waits for A0, adhesion UAV busy
    d.complete("A0")
    # B0 goes; A1 is allowed by the dependencies but conflicts with B0 in progress (the paper's clearance wait).
    assert ids(d.assign()) == ["B0"]
    assert "A1" not in d.available
    assert d.idle_uavs == ("glue-1",)
    d.complete("B0")
    assert ids(d.assign()) == ["A1"]
    d.complete("A1")
    assert ids(d.assign()) == ["B1"]
    d.complete("B1")
    assert d.finished and not d.blocked
    assert set(d.done) == {"A0", "A1", "B0", "B1"}
    assert dict(d.attempts) == {"A0": 1, "A1": 1, "B0": 1, "B1": 1}


def test_assignment_carries_attempt_number_and_is_frozen() -> None:
    d = Dispatcher(case_study_plan(), fleet(), "fifo")
    (a,) = d.assign()
    assert a == Assignment("glue-1", "A0", 1)
    with pytest.raises(AttributeError):
        a.uav = "x"  # type: ignore[misc]
    assert d.fail("A0")
    (b,) = d.assign()
    assert b == Assignment("glue-1", "A0", 2)


def test_preplaced_bricks_start_done_and_unlock_dependents() -> None:
    tasks = (brick(0, 0.0, done=True), glue(0, -0.1, 0.1), brick(1, 0.0, z=0.15))
    plan = Plan(tasks, (("A0", "B0"), ("B1", "A0")), (("A0", "B1"),))
    d = Dispatcher(plan, fleet())
    assert "B0" in d.done and not d.finished
    assert d.available == ("A0",)
    assert ids(d.assign()) == ["A0"]
    d.complete("A0")
    assert ids(d.assign()) == ["B1"]
    d.complete("B1")
    assert d.finished


def test_conflicting_tasks_of_the_same_role_are_not_assigned_together() -> None:
    tasks = (brick(0, 0.0), brick(1, 0.5), brick(2, 5.0))
    plan = Plan(tasks, (), (("B0", "B1"),))
    d = Dispatcher(plan, fleet(bricks=3, glues=0), "fifo")
    got = ids(d.assign())
    assert got == ["B0", "B2"]
    assert d.idle_uavs == ("brick-3",)
    d.complete("B0")
    assert ids(d.assign()) == ["B1"]


def test_fifo_follows_plan_order() -> None:
    tasks = tuple(brick(i, float(10 - i)) for i in range(5))
    d = Dispatcher(Plan(tasks, (), ()), fleet(bricks=1, glues=0), "fifo")
    order = []
    while not d.finished:
        (a,) = d.assign()
        order.append(a.task_id)
        d.complete(a.task_id)
    assert order == ["B0", "B1", "B2", "B3", "B4"]


def test_critical_path_prefers_the_longest_remaining_chain() -> None:
    # B0 alone; B1 -> B2 -> B3 is a chain of 3 (B3 after B2 after B1).
    tasks = tuple(brick(i, float(i)) for i in range(4))
    plan = Plan(tasks, (("B2", "B1"), ("B3", "B2")), ())
    d = Dispatcher(plan, fleet(bricks=1, glues=0), "critical-path")
    assert d.chain_s("B1") == 3.0 and d.chain_s("B0") == 1.0
    assert ids(d.assign()) == ["B1"]
    d.complete("B1")
    assert ids(d.assign()) == ["B2"]  # chain 2 beats B0's 1


def test_critical_path_weights_chains_by_durations() -> None:
    tasks = tuple(brick(i, float(i)) for i in range(3))
    plan = Plan(tasks, (("B2", "B1"),), ())
    durations = {"B0": 100.0, "B1": 10.0, "B2": 10.0}
    d = Dispatcher(plan, fleet(bricks=1, glues=0), "critical-path", durations_s=durations)
    assert d.chain_s("B0") == 100.0 and d.chain_s("B1") == 20.0
    assert ids(d.assign()) == ["B0"]


def test_critical_path_breaks_ties_by_distance() -> None:
    # Equal chains; the UAV sits next to B2's pickup.
    tasks = (
        BrickTask("B0", 0, False, P(0.0), 0.0, P(9.0)),
        BrickTask("B1", 1, False, P(0.0), 0.0, P(5.0)),
        BrickTask("B2", 2, False, P(0.0), 0.0, P(1.0)),
    )
    d = Dispatcher(Plan(tasks, (), ()), [UavSpec("brick-1", "brick", P(1.0, 0.5))], "critical-path")
    assert ids(d.assign()) == ["B2"]


def test_critical_path_counts_chains_within_one_typical_task_as_ties() -> None:
    # median duration 45 s: chains 45 and 50 are in the same step (ties -> nearest), 40 is a step lower.
    tasks = (
        BrickTask("B0", 0, False, P(0.0), 0.0, P(0.5)),
        BrickTask("B1", 1, False, P(0.0), 0.0, P(9.0)),
        BrickTask("B2", 2, False, P(0.0), 0.0, P(3.0)),
    )
    durations = {"B0": 40.0, "B1": 50.0, "B2": 45.0}
    d = Dispatcher(
        Plan(tasks, (), ()), [UavSpec("brick-1", "brick", P(0.0))], "critical-path", durations_s=durations
    )
    assert d.tie_step_s == 45.0
    order = []
    while not d.finished:
        (a,) = d.assign()
        order.append(a.task_id)
        d.complete(a.task_id)
    # B2 (nearer) before B1 although B1's chain is 5 s longer; B0, a step lower, last although nearest of all
    assert order == ["B2", "B1", "B0"]


def test_nearest_uses_current_positions_and_last_drop_off() -> None:
    tasks = (glue(0, 10.0, 10.2), glue(1, 0.0, 0.2), glue(2, 5.0, 5.2))
    d = Dispatcher(Plan(tasks, (), ()), fleet(bricks=0, glues=1, home=4.0), "nearest")
    assert ids(d.assign()) == ["A2"]  # closest to home x=4
    d.complete("A2")  # now at x=5.2
    assert ids(d.assign({"glue-1": (-1.0, 0.0, 0.0)})) == ["A1"]  # position given: near x=0
    d.complete("A1")
    assert ids(d.assign()) == ["A0"]


def test_nearest_counts_the_pickup_to_drop_off_leg() -> None:
    # B0: pickup close to the UAV but a long carry; B1: pickup a bit farther, short carry.
    tasks = (
        BrickTask("B0", 0, False, P(20.0), 0.0, P(1.0)),
        BrickTask("B1", 1, False, P(3.5), 0.0, P(3.0)),
    )
    d = Dispatcher(Plan(tasks, (), ()), [UavSpec("brick-1", "brick", P(0.0))], "nearest")
    assert ids(d.assign()) == ["B1"]


def test_fail_returns_task_until_max_attempts_then_stuck_and_blocked() -> None:
    tasks = (brick(0, 0.0), brick(1, 0.0, z=0.15), brick(2, 9.0))
    plan = Plan(tasks, (("B1", "B0"),), ())
    d = Dispatcher(plan, fleet(bricks=1, glues=0), "fifo", max_attempts=2)
    assert ids(d.assign()) == ["B0"]
    assert d.fail("B0") is True
    assert d.attempts["B0"] == 1 and "B0" in d.available
    (a,) = d.assign()
    assert a.task_id == "B0" and a.attempt == 2
    assert d.fail("B0") is False
    assert set(d.stuck) == {"B0"} and "B0" not in d.available
    assert not d.blocked  # B2 can still run
    assert ids(d.assign()) == ["B2"]
    assert not d.blocked  # in progress
    d.complete("B2")
    assert d.assign() == []
    assert d.blocked and not d.finished
    assert d.remaining == ("B0", "B1")


def test_remove_uav_releases_its_task_without_counting_an_attempt() -> None:
    tasks = (brick(0, 0.0), brick(1, 0.4))
    plan = Plan(tasks, (), (("B0", "B1"),))
    d = Dispatcher(plan, fleet(bricks=2, glues=0), "fifo")
    assert ids(d.assign()) == ["B0"]
    assert d.task_of("brick-1") == "B0"
    assert d.remove_uav("brick-1") == "B0"
    assert d.remove_uav("brick-1") is None  # already gone
    assert "B0" not in d.attempts
    assert d.uavs == ("brick-2",)
    (a,) = d.assign()
    assert a == Assignment("brick-2", "B0", 1)
    d.complete("B0")
    assert ids(d.assign()) == ["B1"]
    assert d.remove_uav("brick-2") == "B1"
    assert d.blocked and d.remaining == ("B1",)


def test_losing_every_uav_of_a_role_blocks_only_when_work_of_that_role_is_left() -> None:
    d = Dispatcher(case_study_plan(), fleet(), "fifo")
    d.remove_uav("brick-1")
    assert not d.blocked  # adhesion work can go on
    d.complete(d.assign()[0].task_id)  # A0
    d.complete(d.assign()[0].task_id)  # A1
    assert d.assign() == []
    assert d.blocked


def test_restore_skips_done_tasks_and_keeps_attempt_counts() -> None:
    d = Dispatcher(case_study_plan(), fleet(), "fifo", max_attempts=3)
    d.restore(["A0", "B0"], {"A0": 1, "B0": 1, "A1": 2})
    assert {"A0", "B0"} <= set(d.done)
    (a,) = d.assign()
    assert a == Assignment("glue-1", "A1", 3)
    assert d.fail("A1") is False
    assert d.blocked


def test_restore_marks_exhausted_tasks_stuck_and_refuses_when_running() -> None:
    d = Dispatcher(case_study_plan(), fleet(), "critical-path", max_attempts=2)
    d.restore([], {"A0": 2})
    assert "A0" in d.stuck
    assert ids(d.assign()) == ["A1"]
    with pytest.raises(PlanningError, match="before any task"):
        d.restore([], {})


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"policy": "random"}, "unknown dispatch policy 'random'"),
        ({"max_attempts": 0}, "max_attempts"),
        ({"durations_s": {"A0": 1.0}}, "durations_s has no entry for task B0"),
        ({"durations_s": {"A0": 1.0, "A1": 1.0, "B0": -1.0, "B1": 1.0}}, r"durations_s\['B0'\]"),
    ],
)
def test_bad_arguments_raise_planning_error(kwargs: dict, message: str) -> None:
    with pytest.raises(PlanningError, match=message):
        Dispatcher(case_study_plan(), fleet(), **kwargs)


@pytest.mark.parametrize(
    ("plan", "message"),
    [
        (Plan((brick(0, 0.0),), (("B0", "B9"),), ()), "dependency names unknown task 'B9'"),
        (Plan((brick(0, 0.0),), (), (("B0", "B0"),)), "cannot conflict with itself"),
        (Plan((brick(0, 0.0), brick(0, 1.0)), (), ()), "two tasks with id 'B0'"),
        (
            Plan((brick(0, 0.0), brick(1, 1.0)), (("B0", "B1"), ("B1", "B0")), ()),
            "cycle through task B",
        ),
    ],
)
def test_bad_plans_raise_planning_error(plan: Plan, message: str) -> None:
    with pytest.raises(PlanningError, match=message):
        Dispatcher(plan, fleet())


def test_bad_events_raise_planning_error() -> None:
    d = Dispatcher(case_study_plan(), fleet())
    with pytest.raises(PlanningError, match="cannot complete task B0: it is not assigned"):
        d.complete("B0")
    with pytest.raises(PlanningError, match="unknown task 'Z'"):
        d.fail("Z")
    with pytest.raises(PlanningError, match="unknown UAV 'ghost'"):
        d.remove_uav("ghost")
    with pytest.raises(PlanningError, match="unknown UAV 'ghost'"):
        d.assign({"ghost": (0.0, 0.0, 0.0)})
    with pytest.raises(PlanningError, match="position of UAV glue-1"):
        d.assign({"glue-1": (0.0, math.nan, 0.0)})
    with pytest.raises(PlanningError, match="two UAVs named"):
        Dispatcher(case_study_plan(), fleet() + fleet())
    (a,) = d.assign()
    d.complete(a.task_id)
    with pytest.raises(PlanningError, match="already done"):
        d.complete(a.task_id)


def test_views_are_live_and_read_only() -> None:
    d = Dispatcher(case_study_plan(), fleet())
    done, running = d.done, d.in_progress
    (a,) = d.assign()
    assert dict(running) == {a.task_id: a.uav}
    d.complete(a.task_id)
    assert a.task_id in done and len(done) == 1
    with pytest.raises(TypeError):
        running["x"] = "y"  # type: ignore[index]
    assert d.task("B1").kind == "brick"


def test_event_cost_is_independent_of_wall_size() -> None:
    """An event touches only the task's neighbours: count the per-task counter updates, not time."""

    def chain_plan(n: int) -> Plan:
        tasks = tuple(brick(i, 0.3 * i) for i in range(n))
        deps = tuple((f"B{i}", f"B{i - 1}") for i in range(1, n))
        conflicts = tuple((f"B{i}", f"B{i + 1}") for i in range(n - 1))
        return Plan(tasks, deps, conflicts)

    def touched(n: int) -> int:
        d = Dispatcher(chain_plan(n), fleet(bricks=1, glues=0), "critical-path")
        counter = {"n": 0}
        original = d._maybe_available

        def spy(i: int) -> None:
            counter["n"] += 1
            original(i)

        d._maybe_available = spy  # type: ignore[method-assign]
        (a,) = d.assign()
        d.complete(a.task_id)
        return counter["n"]

    assert touched(10) == touched(2000)


# ---------------------------------------------------------------- property tests


@st.composite
def random_plans(draw: st.DrawFn) -> Plan:
    """A random DAG plan: bricks and adhesion tasks at random places, random dependencies and conflicts."""
    n = draw(st.integers(1, 24))
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    tasks = []
    for i in range(n):
        x, y = rng.uniform(0, 4), rng.uniform(0, 4)
        if rng.random() < 0.6:
            tasks.append(BrickTask(f"B{i}", i, rng.random() < 0.1, (x, y, 0.05), 0.0, (x - 3, y, 0.05)))
        else:
            tasks.append(AdhesionTask(f"A{i}", i, i + 1, (x, y, 0.1), (x + 0.2, y, 0.1), 0.2))
    p_dep, p_conf = rng.uniform(0, 0.4), rng.uniform(0, 0.5)
    deps = []
    conflicts = []
    for j in range(n):
        for i in range(j):
            # edges only from later to earlier tasks: acyclic by construction
            if rng.random() < p_dep:
                deps.append((tasks[j].id, tasks[i].id))
            if rng.random() < p_conf:
                conflicts.append((tasks[i].id, tasks[j].id))
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts))


def simulate(
    plan: Plan,
    uavs: list[UavSpec],
    policy: str,
    seed: int,
    p_fail: float,
    losses: int,
    durations_s: dict[str, float] | None = None,
) -> Dispatcher:
    """Drive the dispatcher with a random event order and check every safety invariant from the outside."""
    rng = random.Random(seed)
    prereqs: dict[str, set[str]] = {t.id: set() for t in plan.tasks}
    for u, v in plan.dependencies:
        prereqs[u].add(v)
    conflicts: dict[str, set[str]] = {t.id: set() for t in plan.tasks}
    for a, b in plan.conflicts:
        conflicts[a].add(b)
        conflicts[b].add(a)
    role_of = {t.id: t.kind for t in plan.tasks}
    uav_role = {u.name: u.role for u in uavs}
    d = Dispatcher(plan, uavs, policy, max_attempts=3, durations_s=durations_s)
    completed: list[str] = []
    done = {t.id for t in plan.tasks if t.done}
    running: dict[str, str] = {}
    alive = {u.name for u in uavs}
    for _ in range(10 * len(plan.tasks) + 50):
        for a in d.assign():
            assert a.uav in alive and a.uav not in running.values(), "assigned to a busy or lost UAV"
            assert uav_role[a.uav] == role_of[a.task_id], "wrong role"
            assert a.task_id not in done and a.task_id not in running, "assigned twice"
            assert prereqs[a.task_id] <= done, f"{a.task_id} started before its prerequisites"
            assert not (conflicts[a.task_id] & running.keys()), f"{a.task_id} conflicts with a running task"
            running[a.task_id] = a.uav
        assert dict(d.in_progress) == running
        if not running:
            # nothing running: either finished, or blocked (and then truly nothing is assignable)
            assert d.finished or d.blocked
            break
        tid = rng.choice(sorted(running))
        r = rng.random()
        if losses and r < 0.1:
            losses -= 1
            uav = running.pop(tid)
            assert d.remove_uav(uav) == tid
            alive.discard(uav)
        elif r < p_fail:
            uav = running.pop(tid)
            d.fail(tid)
        else:
            running.pop(tid)
            d.complete(tid)
            assert tid not in done, "completed twice"
            done.add(tid)
            completed.append(tid)
    assert set(d.done) == done
    assert len(completed) == len(set(completed))
    return d


@settings(max_examples=150)
@given(
    plan=random_plans(),
    bricks=st.integers(1, 4),
    glues=st.integers(1, 3),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
    seed=st.integers(0, 10**6),
)
def test_random_plans_finish_safely_without_faults(
    plan: Plan, bricks: int, glues: int, policy: str, seed: int
) -> None:
    d = simulate(plan, fleet(bricks, glues), policy, seed, p_fail=0.0, losses=0)
    assert d.finished, f"not finished: remaining {d.remaining}"
    assert set(d.done) == {t.id for t in plan.tasks}


@settings(max_examples=150)
@given(
    plan=random_plans(),
    bricks=st.integers(1, 4),
    glues=st.integers(1, 3),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
    seed=st.integers(0, 10**6),
    p_fail=st.floats(0.0, 0.6),
    losses=st.integers(0, 3),
)
def test_random_plans_with_failures_and_losses_stay_safe(
    plan: Plan, bricks: int, glues: int, policy: str, seed: int, p_fail: float, losses: int
) -> None:
    d = simulate(plan, fleet(bricks, glues), policy, seed, p_fail, losses)
    assert d.finished or d.blocked
    if d.blocked:
        # Blocked means: some task stuck, or a role with work left has no UAV.
        live_roles = {"brick" if u.startswith("brick") else "adhesion" for u in d.uavs}
        left_roles = {d.task(t).kind for t in d.remaining}
        assert d.stuck or (left_roles - live_roles)


def test_random_completion_against_a_brute_force_reference() -> None:
    """At every step the available set equals a from-scratch recomputation over the whole plan."""
    rng = random.Random(7)
    for trial in range(30):
        plan = _seeded_plan(rng)
        d = Dispatcher(plan, fleet(3, 2), rng.choice(["fifo", "critical-path", "nearest"]))
        prereqs = {t.id: set() for t in plan.tasks}
        for u, v in plan.dependencies:
            prereqs[u].add(v)
        conflicts = {t.id: set() for t in plan.tasks}
        for a, b in plan.conflicts:
            conflicts[a].add(b)
            conflicts[b].add(a)
        while True:
            done = set(d.done)
            running = set(d.in_progress)
            expected = {
                t.id
                for t in plan.tasks
                if t.id not in done
                and t.id not in running
                and t.id not in d.stuck
                and prereqs[t.id] <= done
                and not (conflicts[t.id] & running)
            }
            assert set(d.available) == expected, f"trial {trial}"
            d.assign()
            if not d.in_progress:
                break
            tid = rng.choice(sorted(d.in_progress))
            if rng.random() < 0.2:
                d.fail(tid)
            else:
                d.complete(tid)
        assert d.finished or d.stuck


def _seeded_plan(rng: random.Random) -> Plan:
    n = rng.randint(1, 30)
    tasks = [brick(i, rng.uniform(0, 3)) if rng.random() < 0.6 else glue(i, 0.0, 0.2) for i in range(n)]
    deps = [(tasks[j].id, tasks[i].id) for j in range(n) for i in range(j) if rng.random() < 0.15]
    conflicts = [(tasks[i].id, tasks[j].id) for j in range(n) for i in range(j) if rng.random() < 0.2]
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts))


@settings(max_examples=25)
@given(
    courses=st.integers(1, 4),
    per_course=st.integers(1, 6),
    placed=st.integers(0, 1),
    bricks=st.integers(1, 3),
    glues=st.integers(1, 2),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
    kind=st.sampled_from(["running-bond", "pyramid", "towers"]),
    seed=st.integers(0, 10**6),
    p_fail=st.sampled_from([0.0, 0.3]),
    losses=st.integers(0, 1),
)
def test_random_walls_from_the_planner_stay_safe(
    courses: int,
    per_course: int,
    placed: int,
    bricks: int,
    glues: int,
    policy: str,
    kind: str,
    seed: int,
    p_fail: float,
    losses: int,
) -> None:
    from masonry.blueprint_gen import generate
    from masonry.planner import plan as make_plan
    from masonry.planner.bounds import estimate_durations_s

    shape = {
        "running-bond": {"courses": courses, "bricks_per_course": per_course},
        "pyramid": {"base": per_course},
        "towers": {"towers": per_course, "height": courses, "spacing_m": 0.5},
    }[kind]
    bp = generate(
        kind, placed_courses=min(placed, courses - 1), brick_uavs=bricks, adhesion_uavs=glues, **shape
    )
    plan = make_plan(bp)
    d = simulate(plan, list(bp.fleet), policy, seed, p_fail, losses)
    if p_fail == 0.0 and losses == 0:
        assert d.finished, f"not finished: remaining {d.remaining}"
    else:
        assert d.finished or d.blocked
    # weighted by expected durations, as mission control runs it: just as safe, and it finishes
    durations = estimate_durations_s(plan, bp.fleet)
    assert simulate(plan, list(bp.fleet), policy, seed + 1, 0.0, 0, durations).finished


def test_duplicate_edges_count_once() -> None:
    tasks = (brick(0, 0.0), brick(1, 0.0, z=0.15), brick(2, 0.2))
    plan = Plan(tasks, (("B1", "B0"), ("B1", "B0")), (("B0", "B2"), ("B2", "B0"), ("B0", "B2")))
    d = Dispatcher(plan, fleet(bricks=2, glues=0), "fifo")
    assert ids(d.assign()) == ["B0"]
    d.complete("B0")
    assert ids(d.assign()) == ["B1", "B2"]  # one completion released B1's only prerequisite and B2's blocker


@pytest.mark.parametrize("policy", ["fifo", "critical-path", "nearest"])
@pytest.mark.parametrize("weighted", [False, True])
def test_bundled_case_study_blueprint_dispatches_in_the_papers_order(policy: str, weighted: bool) -> None:
    from pathlib import Path

    from masonry.blueprint import load_blueprint
    from masonry.planner import plan as make_plan
    from masonry.planner.bounds import estimate_durations_s

    bp = load_blueprint(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
    plan = make_plan(bp)
    durations = estimate_durations_s(plan, bp.fleet) if weighted else None
    d = Dispatcher(plan, bp.fleet, policy, durations_s=durations)
    steps = []
    while not d.finished:
        steps.append(ids(d.assign()))
        assert len(d.in_progress) == 1  # the case study never runs two tasks at once
        d.complete(next(iter(d.in_progress)))
    assert steps == [["A0"], ["B0"], ["A1"], ["B1"]]
