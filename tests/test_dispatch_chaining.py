"""Dispatch chains adhesion segments (issue 27): the segment starting where the UAV's nozzle ended, else the run
of the nearest segment entered up to ``HEAD_DETOUR_M`` further back; never past the policy's ranking."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec, load_blueprint
from masonry.mission.simulate import simulate
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_chaining import HEAD_DETOUR_M, chain_pick, segment_links
from masonry.planner.dispatch_ranking import Ranking
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.timing import DEFAULT_TIMING

ROOT = Path(__file__).resolve().parents[1]


def glue(n: int, x0: float, x1: float, y0: float = 0.0, y1: float = 0.0) -> AdhesionTask:
    return AdhesionTask(f"A{n}", 0, 1, (x0, y0, 0.1), (x1, y1, 0.1), abs(x1 - x0) + abs(y1 - y0))


def run(n: int, x0: float = -1.05, step: float = 0.15) -> list[AdhesionTask]:
    """``n`` contiguous segments along x, each starting where the one before ends (one course's overlaps)."""
    return [glue(k, x0 + k * step, x0 + (k + 1) * step) for k in range(n)]


def one_sprayer(home_x: float) -> list[UavSpec]:
    return [UavSpec("glue-1", "adhesion", (home_x, -3.0, 0.0))]


def spray_in_turn(d: Dispatcher, above_m: float = 0.45) -> list[str]:
    """Assign and complete one task at a time, the UAV reporting itself over the end of the segment it sprayed
    (its body ``above_m`` over the nozzle), as mission control does."""
    order: list[str] = []
    positions = None
    while True:
        got = d.assign(positions)
        if not got:
            return order
        tid = got[0].task_id
        order.append(tid)
        d.complete(tid)
        end = d.plan.task(tid).end_m  # type: ignore[union-attr]
        positions = {"glue-1": (end[0], end[1], end[2] + above_m)}


def test_segment_links_join_a_segment_to_the_one_starting_where_it_ends() -> None:
    tasks = [*run(3), BrickTask("B0", 0, False, (0.0, 0.0, 0.15), 0.0, (0.0, -2.0, 0.05))]
    successors, predecessors = segment_links(tasks)
    assert successors == [(1,), (2,), (), ()]
    assert predecessors == [(), (0,), (1,), ()]


@pytest.mark.parametrize("policy", ["critical-path", "nearest"])
def test_a_sprayer_right_of_a_course_sprays_it_from_its_start_chaining_every_segment(policy: str) -> None:
    # the UAV's home is right of the course: the nearest *start* is the last segment's, which without the
    # preference sends it along the course backwards (A5, A4, ...: 0.3 m from each end to the next start)
    d = Dispatcher(Plan(tuple(run(6)), (), ()), one_sprayer(2.0), policy, reservation="site")
    assert spray_in_turn(d) == ["A0", "A1", "A2", "A3", "A4", "A5"]


def test_fifo_keeps_plan_order() -> None:
    tasks = tuple(reversed(run(4)))  # plan order A3, A2, A1, A0
    d = Dispatcher(Plan(tasks, (), ()), one_sprayer(-2.0), "fifo")
    assert spray_in_turn(d) == ["A3", "A2", "A1", "A0"]


def test_a_uav_still_at_the_end_of_its_segment_chains_else_it_takes_the_nearest_run_head() -> None:
    # A0 A1 contiguous, A2 A3 contiguous, 0.2 m further on; A0 sprayed
    tasks = (*run(2, x0=-0.6), glue(2, -0.1, 0.05), glue(3, 0.05, 0.2))
    for at, expected in (
        ((-0.2, 0.0, 0.55), "A1"),  # 0.25 m from A0's end (A2's start is nearer): chained
        ((-0.2, -1.0, 0.0), "A2"),  # a metre off it (it climbed out, flew away): the nearest head
    ):
        d = Dispatcher(Plan(tasks, (), ()), one_sprayer(-0.6), "nearest")
        assert [a.task_id for a in d.assign()] == ["A0"]
        d.complete("A0")
        assert [a.task_id for a in d.assign({"glue-1": at})] == [expected], at


def test_the_chained_segment_is_taken_only_among_the_tasks_the_policy_ranks_first() -> None:
    # critical-path: A1 starts where A0 ends but its chain is shorter than A2's by more than a tie step
    tasks = (*run(2), glue(2, 1.0, 1.15))
    plan = Plan(tasks, (), ())
    d = Dispatcher(plan, one_sprayer(-1.0), durations_s={"A0": 10.0, "A1": 10.0, "A2": 50.0})
    assert [a.task_id for a in d.assign()] == ["A2"]
    d.complete("A2")
    d2 = Dispatcher(plan, one_sprayer(-1.0), durations_s={"A0": 50.0, "A1": 10.0, "A2": 50.0})
    assert [a.task_id for a in d2.assign()] == ["A0"]
    d2.complete("A0")
    # A1 is chained to A0, but A2 ranks a step higher
    assert [a.task_id for a in d2.assign({"glue-1": (-0.9, 0.0, 0.55)})] == ["A2"]


def test_a_sprayer_at_the_far_end_of_a_long_run_enters_it_at_most_head_detour_m_back() -> None:
    # ten segments, 1.5 m; the UAV 0.3 m right of them, its body 0.45 m up: the nearest start is A9's (0.54 m)
    tasks = run(10)
    successors, predecessors = segment_links(tasks)
    start = [t.start_m for t in tasks]
    picked = chain_pick(
        dict.fromkeys(range(10)), (0.6, 0.0, 0.55), start, [0.0] * 10, successors, predecessors
    )
    assert picked == 3  # A3's start is 1.28 m away, 0.74 m further than A9's (A2's: 1.42 m, 0.88 m further)


def test_a_ring_of_segments_is_walked_back_once_at_most() -> None:
    # a tower's course: four segments around a square, each ending where the next starts
    ring = [
        glue(0, 0.0, 1.0, 0.0, 0.0),
        glue(1, 1.0, 1.0, 0.0, 1.0),
        glue(2, 1.0, 0.0, 1.0, 1.0),
        glue(3, 0.0, 0.0, 1.0, 0.0),
    ]
    successors, predecessors = segment_links(ring)
    assert successors == [(1,), (2,), (3,), (0,)]
    start = [t.start_m for t in ring]
    everything = {0: None, 1: None, 2: None, 3: None}
    # nearest A2's start; A1's is 0.8 m further: not worth it
    assert chain_pick(everything, (1.0, 1.2, 0.5), start, [0.0] * 4, successors, predecessors) == 2
    # a small ring, all within the detour: back round it once, not for ever
    small = [
        glue(0, 0.0, 0.1, 0.0, 0.0),
        glue(1, 0.1, 0.1, 0.0, 0.1),
        glue(2, 0.1, 0.0, 0.1, 0.1),
        glue(3, 0.0, 0.0, 0.1, 0.0),
    ]
    links = segment_links(small)
    got = chain_pick(everything, (0.1, 0.1, 0.5), [t.start_m for t in small], [0.0] * 4, *links)
    assert got in everything
    d = Dispatcher(Plan(tuple(ring), (), ()), [UavSpec("glue-1", "adhesion", (1.0, 1.2, 0.0))], "nearest")
    assert spray_in_turn(d) == ["A2", "A3", "A0", "A1"]


@settings(max_examples=120, derandomize=True)
@given(
    xs=st.lists(st.integers(-20, 20), min_size=1, max_size=12, unique=True),
    ranks=st.lists(st.integers(0, 2), min_size=12, max_size=12),
    at=st.integers(-25, 25),
    after=st.one_of(st.none(), st.integers(0, 11)),
)
def test_a_pick_is_always_one_of_the_policys_best(
    xs: list[int], ranks: list[int], at: int, after: int | None
) -> None:
    """Whatever the chaining prefers, critical-path's pick has the highest chain step available."""
    tasks = [glue(k, x * 0.15, x * 0.15 + 0.15) for k, x in enumerate(xs)]
    n = len(tasks)
    successors, predecessors = segment_links(tasks)
    ranking = Ranking(
        "critical-path", ranks[:n], [t.start_m for t in tasks], [0.0] * n, successors, predecessors
    )
    for i in range(n):
        ranking.add(i, "adhesion")
    picked = ranking.pick(
        "adhesion", (at * 0.15, 0.0, 0.55), after if after is not None and after < n else None
    )
    assert picked is not None
    assert ranks[picked] == max(ranks[:n]), f"picked {picked} of ranks {ranks[:n]}"
    best = [i for i in range(n) if ranks[i] == ranks[picked]]
    if after is not None and after < n and any(j in best for j in successors[after]):
        assert picked in successors[after]  # the chained segment wins among the best
    else:  # else at most HEAD_DETOUR_M further than the nearest of the best
        here = (at * 0.15, 0.0, 0.55)
        nearest = min(math.dist(here, tasks[i].start_m) for i in best)
        assert math.dist(here, tasks[picked].start_m) <= nearest + HEAD_DETOUR_M + 1e-9


def test_the_pyramid_sprayer_chains_most_of_its_first_course_at_one_plus_one() -> None:
    """The bundled pyramid, 1 + 1, default options: the first course's 14 contiguous overlaps are mostly sprayed
    chained (a ``chain_descent_s`` descent, not the full ``spray_descent_s`` one); before issue 27's preference
    the sprayer took them backwards and chained none."""
    report = simulate(
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
        brick_uavs=1,
        adhesion_uavs=1,
        seed=1,
        camera="geometric",
        max_time_s=200.0,
    )
    limit_s = (DEFAULT_TIMING.chain_descent_s + DEFAULT_TIMING.spray_descent_s) / 2.0
    course0 = {f"A{k}" for k in range(14)}
    done = [
        a for a in report.attempts if a.task_id in course0 and a.status == "done" and a.phases is not None
    ]
    assert len(done) == 14
    chained = sorted(a.task_id for a in done if a.phases is not None and a.phases.descending < limit_s)
    assert len(chained) >= 7, chained
