"""The offline schedule's chain term (masonry.planner.schedule_chain): a sprayer's segment not sprayed right after
the one ending at its start costs its climb out and first descent (issue 27)."""

from __future__ import annotations

import itertools
import math

from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.blueprint_gen import running_bond
from masonry.fsm.config import UavConfig
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.planner import plan as make_plan
from masonry.planner.bounds import empty_flight_s, min_durations_s
from masonry.planner.schedule import solve_schedule
from masonry.planner.schedule_chain import CHAIN_DISTANCE_M, chain_costs
from masonry.planner.tasks import AdhesionTask, Plan
from masonry.timing import DEFAULT_TIMING, MIN_LEG_S
from test_schedule import check_feasible

TOL_S = 1e-6
CRUISE_M = 1.5
Z_M = 0.1  # the top of the course the beads lie on


def test_the_chain_distance_and_descents_are_the_machines():
    cfg = UavConfig("a1", "adhesion", (0.0, 0.0, 0.0))
    assert cfg.chain_distance_m == CHAIN_DISTANCE_M
    assert (cfg.chain_descent_s, cfg.spray_descent_s) == (
        DEFAULT_TIMING.chain_descent_s,
        DEFAULT_TIMING.spray_descent_s,
    )


def _run(n: int, home_m: tuple[float, float, float]) -> tuple[Plan, tuple[UavSpec, ...]]:
    """``n`` beads of 0.3 m end to end along x (each starts where the one before ends), one sprayer."""
    tasks = tuple(
        AdhesionTask(f"A{k}", k, k + 1, (0.3 * k, 0.0, Z_M), (0.3 * (k + 1), 0.0, Z_M), 0.3) for k in range(n)
    )
    return Plan(tasks=tasks, dependencies=(), conflicts=()), (UavSpec("a1", "adhesion", home_m),)


def test_costs_by_hand():
    p, _ = _run(3, (0.0, -3.0, 0.0))
    tick = 0.01
    c = chain_costs(p.tasks, DEFAULT_TIMING, CRUISE_M, tick)
    assert c.follows == {(0, 1), (1, 2)}
    # a climb out and a first descent are at least one minimum leg each; the chained descent is 0.5 s
    assert all(x >= math.floor(MIN_LEG_S / tick) for x in c.climb)
    assert all(x >= math.floor((MIN_LEG_S - DEFAULT_TIMING.chain_descent_s) / tick) for x in c.descend)
    assert c.extra(0, 1) == 0 and c.extra(1, 0) == c.climb[1] + c.descend[0]
    assert c.extra(-1, 2) == c.descend[2]


def _best_by_hand(p: Plan, home_m, tick: float) -> tuple[int, tuple[int, ...]]:
    """The least makespan (ticks) of one sprayer over every order of ``p``'s segments, and its order."""
    md = min_durations_s(p, cruise_altitude_m=CRUISE_M)
    c = chain_costs(p.tasks, DEFAULT_TIMING, CRUISE_M, tick)
    best: tuple[int, tuple[int, ...]] | None = None
    for order in itertools.permutations(range(len(p.tasks))):
        t, prev, at = 0, -1, home_m
        for j in order:
            task = p.tasks[j]
            t += math.floor(empty_flight_s(at, task.start_m) / tick) + c.extra(prev, j)
            t += math.floor(md[task.id] / tick)
            prev, at = j, task.end_m
        if best is None or t < best[0]:
            best = (t, order)
    assert best is not None
    return best


def test_chaining_is_chosen_where_the_plain_model_may_run_the_beads_backwards():
    """The sprayer's pad lies past the far end of the run: without the chain term the nearest start first (the
    run backwards) is as good as any order; with it, the only optimum sprays the run from its head."""
    home = (1.2, -2.0, 0.0)
    p, fleet = _run(3, home)
    s = solve_schedule(p, fleet, cruise_altitude_m=CRUISE_M, reservation="task", time_limit_s=10.0, workers=1)
    assert s.status == "optimal"
    ticks, order = _best_by_hand(p, home, s.tick_s)
    assert order == (0, 1, 2)
    assert s.makespan_s == round(ticks * s.tick_s, 6)
    assert [t.id for t in s.uavs[0].tasks] == ["A0", "A1", "A2"]
    check_feasible(p, fleet, s, CRUISE_M)
    # the model without the term counts every bead at its chained least: never more, and here less
    plain = solve_schedule(
        p, fleet, cruise_altitude_m=CRUISE_M, reservation="task", time_limit_s=10.0, workers=1, chaining=False
    )
    assert plain.status == "optimal" and plain.makespan_s < s.makespan_s - 1.0
    check_feasible(p, fleet, plain, CRUISE_M, chaining=False)


@seed(27)
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True)
@given(
    courses=st.integers(2, 3),
    per_course=st.integers(3, 6),
    adhesion=st.integers(1, 2),
    reservation=st.sampled_from(["site", "task"]),
    decomposition=st.sampled_from(["none", "course"]),
)
def test_chained_schedules_of_random_running_bonds_keep_every_constraint(
    courses, per_course, adhesion, reservation, decomposition
):
    bp0 = running_bond(courses, per_course, placed_courses=1)
    fleet = fleet_for(bp0, 2, adhesion)
    bp = with_fleet(bp0, fleet)
    p = make_plan(bp)
    s = solve_schedule(
        p,
        fleet,
        cruise_altitude_m=bp.cruise_altitude_m,
        reservation=reservation,
        decomposition=decomposition,
        part_tasks=12,
        time_limit_s=2.0,
        workers=1,
    )
    assert s.status in ("optimal", "feasible")
    # dependencies, conflicts (tasks or site parts), each UAV's flights with the chain term, the bound
    check_feasible(p, fleet, s, bp.cruise_altitude_m)
    if reservation == "site" and decomposition == "none":
        check_windows(p, s, bp.cruise_altitude_m)


def check_windows(p: Plan, s, cruise_altitude_m: float) -> None:
    """Under ``site`` a segment's site part, with its first descent before it unless it follows the one ending
    at its start and its climb out after it unless the next one does (or it is its UAV's last), overlaps no
    conflicting task's (independently of the solver, from each UAV's order)."""
    todo = [t for t in p.tasks if not t.done]
    index = {t.id: i for i, t in enumerate(todo)}
    c = chain_costs(todo, DEFAULT_TIMING, cruise_altitude_m, s.tick_s)
    window = {}
    for u in s.uavs:
        ids = [index[t.id] for t in u.tasks]
        for n, t in enumerate(u.tasks):
            i = ids[n]
            lo = hi = 0
            if isinstance(todo[i], AdhesionTask):
                lo = 0 if n and (ids[n - 1], i) in c.follows else c.descend[i]
                hi = 0 if n + 1 == len(ids) or (i, ids[n + 1]) in c.follows else c.climb[i]
            window[t.id] = (t.site_start_s - lo * s.tick_s, t.site_end_s + hi * s.tick_s)
    for a, b in p.conflicts:
        if a in window and b in window:
            x, y = window[a], window[b]
            assert x[1] <= y[0] + TOL_S or y[1] <= x[0] + TOL_S, (a, b, x, y)


def test_a_small_running_bonds_windows_and_the_default_is_the_chain_term():
    bp0 = running_bond(2, 4, placed_courses=1)
    fleet = fleet_for(bp0, 2, 1)
    bp = with_fleet(bp0, fleet)
    p = make_plan(bp)
    s = solve_schedule(p, fleet, cruise_altitude_m=bp.cruise_altitude_m, reservation="site", time_limit_s=3.0)
    check_feasible(p, fleet, s, bp.cruise_altitude_m)
    check_windows(p, s, bp.cruise_altitude_m)
    plain = solve_schedule(
        p, fleet, cruise_altitude_m=bp.cruise_altitude_m, reservation="site", time_limit_s=3.0, chaining=False
    )
    check_feasible(p, fleet, plain, bp.cruise_altitude_m, chaining=False)
