"""Makespan lower bound, duration estimates, and the bound never exceeding what the dispatcher achieves."""

from __future__ import annotations

import dataclasses
import math
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.errors import PlanningError
from masonry.planner.bounds import (
    dispatch_makespan_s,
    estimate_durations_s,
    longest_chain_s,
    lower_bound_s,
)
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.timing import DEFAULT_TIMING


def timing(**fields: float):
    return dataclasses.replace(DEFAULT_TIMING, **fields)


def brick(i: int, x: float, *, done: bool = False, z: float = 0.05) -> BrickTask:
    return BrickTask(f"B{i}", i, done, (x, 0.0, z), 0.0, (x, -2.0, 0.05))


def glue(n: int, x: float, z: float = 0.1, length: float = 0.3) -> AdhesionTask:
    return AdhesionTask(f"A{n}", 0, 1, (x, 0.0, z), (x + length, 0.0, z), length)


def uavs(bricks: int, glues: int) -> list[UavSpec]:
    return [UavSpec(f"brick-{k}", "brick", (0.0, -2.0, 0.0)) for k in range(bricks)] + [
        UavSpec(f"glue-{k}", "adhesion", (0.0, -3.0, 0.0)) for k in range(glues)
    ]


def test_chain_term_dominates_a_sequential_plan() -> None:
    tasks = (glue(0, 0.0), brick(0, 0.0), glue(1, 0.0, z=0.2), brick(1, 0.0, z=0.15))
    deps = (("B0", "A0"), ("A1", "B0"), ("B1", "A1"))
    plan = Plan(tasks, deps, ())
    durations = {"A0": 10.0, "B0": 30.0, "A1": 10.0, "B1": 30.0}
    assert longest_chain_s(plan, durations) == 80.0
    assert lower_bound_s(plan, uavs(4, 4), durations) == 80.0
    assert dispatch_makespan_s(plan, uavs(4, 4), durations) == 80.0


def test_work_term_dominates_independent_tasks() -> None:
    tasks = (*tuple(brick(i, 2.0 * i) for i in range(6)), glue(0, 0.0))
    durations = {f"B{i}": 10.0 for i in range(6)} | {"A0": 5.0}
    plan = Plan(tasks, (), ())
    assert lower_bound_s(plan, uavs(2, 1), durations) == 30.0
    assert lower_bound_s(plan, uavs(3, 1), durations) == 20.0
    assert dispatch_makespan_s(plan, uavs(2, 1), durations, "fifo") == 30.0


def test_done_tasks_cost_nothing_and_missing_durations_are_named() -> None:
    tasks = (brick(0, 0.0, done=True), glue(0, 0.0), brick(1, 0.0, z=0.15))
    plan = Plan(tasks, (("A0", "B0"), ("B1", "A0")), ())
    assert lower_bound_s(plan, uavs(1, 1), {"A0": 4.0, "B1": 6.0}) == 10.0
    with pytest.raises(PlanningError, match="durations_s has no entry for task B1"):
        lower_bound_s(plan, uavs(1, 1), {"A0": 4.0})
    with pytest.raises(PlanningError, match=r"durations_s\['A0'\] must be finite"):
        lower_bound_s(plan, uavs(1, 1), {"A0": math.inf, "B1": 1.0})
    assert lower_bound_s(Plan((brick(0, 0.0, done=True),), (), ()), [], {}) == 0.0


def test_a_role_with_work_and_no_uav_is_an_error() -> None:
    plan = Plan((glue(0, 0.0), brick(0, 0.0)), (), ())
    with pytest.raises(PlanningError, match="no adhesion UAV in the fleet for 1 adhesion task"):
        lower_bound_s(plan, uavs(1, 0), {"A0": 1.0, "B0": 1.0})
    with pytest.raises(PlanningError, match="cannot finish"):
        dispatch_makespan_s(plan, uavs(1, 0), {"A0": 1.0, "B0": 1.0})


def test_cycle_is_an_error() -> None:
    plan = Plan((brick(0, 0.0), brick(1, 1.0)), (("B0", "B1"), ("B1", "B0")), ())
    with pytest.raises(PlanningError, match="cycle"):
        longest_chain_s(plan, {"B0": 1.0, "B1": 1.0})


def test_estimates_follow_the_flight() -> None:
    near = BrickTask("B0", 0, False, (1.0, 0.0, 0.05), 0.0, (1.0, -1.0, 0.05))
    far = BrickTask("B1", 1, False, (1.0, 0.0, 0.05), 0.0, (1.0, -5.0, 0.05))
    high = BrickTask("B2", 2, False, (1.0, 0.0, 0.55), 0.0, (1.0, -1.0, 0.05))
    short, long_ = glue(0, 0.0, length=0.15), glue(1, 0.0, length=0.6)
    done = brick(9, 0.0, done=True)
    plan = Plan((near, far, high, short, long_, done), (), ())
    est = estimate_durations_s(plan, uavs(1, 1))
    assert set(est) == {"B0", "B1", "B2", "A0", "A1"}
    # B0: carry 1 m, approach min(carry, home (0,-2) -> pickup (1,-1)) = 1 m; B1: carry 5 m, approach from home
    assert est["B1"] - est["B0"] == pytest.approx((5.0 + math.hypot(1.0, 3.0)) - (1.0 + 1.0))
    assert est["B2"] < est["B0"]  # a higher drop-off: a shorter climb back to cruise altitude
    assert est["A1"] - est["A0"] == pytest.approx(0.45 / 0.15)
    faster = estimate_durations_s(plan, uavs(1, 1), timing=timing(cruise_speed_mps=2.0))
    assert faster["B1"] < est["B1"] and faster["A0"] == est["A0"]
    with pytest.raises(PlanningError, match="cruise_speed_mps must be finite and > 0"):
        estimate_durations_s(plan, uavs(1, 1), timing=timing(cruise_speed_mps=0.0))


def test_estimate_approach_uses_the_nearest_brick_home_or_the_drop_off() -> None:
    task = BrickTask("B0", 0, False, (0.0, 0.0, 0.05), 0.0, (0.0, -4.0, 0.05))
    plan = Plan((task,), (), ())
    at_depot = [UavSpec("b", "brick", (0.0, -4.0, 0.0))]
    far_away = [UavSpec("b", "brick", (50.0, 0.0, 0.0))]
    base = estimate_durations_s(plan, at_depot)["B0"]
    # far home: the approach is capped by the return from the drop-off (4 m)
    assert estimate_durations_s(plan, far_away)["B0"] == pytest.approx(base + 4.0)
    assert estimate_durations_s(plan, far_away, include_approach=False)["B0"] == pytest.approx(base)


@st.composite
def dag_plans(draw: st.DrawFn) -> tuple[Plan, dict[str, float]]:
    rng = random.Random(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(1, 20))
    tasks = [
        BrickTask(f"B{i}", i, rng.random() < 0.1, (rng.uniform(0, 5), 0.0, 0.05), 0.0, (0.0, -2.0, 0.05))
        if rng.random() < 0.6
        else glue(i, rng.uniform(0, 5))
        for i in range(n)
    ]
    deps = [(tasks[j].id, tasks[i].id) for j in range(n) for i in range(j) if rng.random() < 0.2]
    conflicts = [(tasks[i].id, tasks[j].id) for j in range(n) for i in range(j) if rng.random() < 0.2]
    durations = {t.id: rng.uniform(1.0, 60.0) for t in tasks if not t.done}
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts)), durations


@settings(max_examples=120)
@given(
    case=dag_plans(),
    bricks=st.integers(1, 4),
    glues=st.integers(1, 3),
    policy=st.sampled_from(["fifo", "critical-path", "nearest"]),
    travel=st.booleans(),
)
def test_lower_bound_never_exceeds_a_dispatched_makespan(
    case: tuple[Plan, dict[str, float]], bricks: int, glues: int, policy: str, travel: bool
) -> None:
    plan, durations = case
    fleet = uavs(bricks, glues)
    bound = lower_bound_s(plan, fleet, durations)
    span = dispatch_makespan_s(plan, fleet, durations, policy, cruise_speed_mps=1.0 if travel else None)
    assert bound <= span + 1e-9
    # and the bound is attained by some term: at least the longest single task
    assert bound >= max(durations.values(), default=0.0) - 1e-9


def test_min_cycles_add_the_flight_from_the_nearest_drop_off_or_home() -> None:
    from masonry.planner.bounds import min_cycles_s

    # two bricks whose pickups are 4 m behind the wall, homes 6 m behind them: the nearest start of B0's flight
    # is B1's drop-off, 1 m along the wall (sqrt(17) m away); B1's is B0's drop-off (same distance)
    tasks = (
        BrickTask("B0", 0, False, (0.0, 0.0, 0.05), 0.0, (0.0, -4.0, 0.05)),
        BrickTask("B1", 1, False, (1.0, 0.0, 0.05), 0.0, (1.0, -4.0, 0.05)),
        glue(0, 5.0),
    )
    plan = Plan(tasks, (), ())
    fleet = [UavSpec("brick-1", "brick", (0.0, -10.0, 0.0)), UavSpec("glue-1", "adhesion", (5.0, -10.0, 0.0))]
    base = {"B0": 30.0, "B1": 31.0, "A0": 10.0}
    cycles = min_cycles_s(
        plan, fleet, base, timing=timing(cruise_speed_mps=1.0, arrive_tolerance_m=0.1), min_leg_s=1.0
    )
    flight = math.hypot(1.0, 4.0) - 0.2  # peak speed 1 m/s; 0.1 m of slack at each end
    assert cycles["B0"] == pytest.approx(30.0 + flight - 1.0)
    assert cycles["B1"] == pytest.approx(31.0 + flight - 1.0)
    assert cycles["A0"] == 10.0  # no sound approach term for adhesion
    # the home is nearer when it is right behind the pickup
    near_home = [UavSpec("brick-1", "brick", (0.0, -4.5, 0.0)), fleet[1]]
    cycles = min_cycles_s(plan, near_home, base, timing=timing(arrive_tolerance_m=0.1))
    assert cycles["B0"] == pytest.approx(30.0)  # 0.5 m - slack: less than the last leg's 1 s, nothing added
    # the role term uses them, the chain term does not
    seq = Plan(tasks, (("B1", "B0"),), ())
    assert lower_bound_s(seq, fleet, base) == pytest.approx(61.0)
    work = min_cycles_s(seq, fleet, base, timing=timing(arrive_tolerance_m=0.1))
    assert lower_bound_s(seq, fleet, base, work_s=work) == pytest.approx(61.0 + 2 * (flight - 1.0))
    assert longest_chain_s(seq, base) == pytest.approx(61.0)
    with pytest.raises(PlanningError, match=r"work_s|durations_s"):
        lower_bound_s(seq, fleet, base, work_s={"B0": 1.0})
    with pytest.raises(PlanningError, match="cruise_speed_mps"):
        min_cycles_s(seq, fleet, base, timing=timing(cruise_speed_mps=0.0))


def test_the_old_keywords_still_work_with_a_deprecation_warning() -> None:
    from masonry.planner.bounds import min_cycles_s, min_durations_s

    plan = Plan((brick(0, 1.0), brick(1, 2.0), glue(0, 0.0)), (), ())
    fleet = uavs(1, 1)
    with pytest.warns(DeprecationWarning, match=r"descent_s=.*timing=.*descent_duration_s=\.\.\."):
        old = min_durations_s(plan, descent_s=5.0, effector_offset_z_m=-0.5)
    assert old == min_durations_s(
        plan, timing=timing(descent_duration_s=5.0, effector_offset_m=(0.0, 0.0, -0.5))
    )
    with pytest.warns(DeprecationWarning, match="leg_peak_factor"):
        faster = min_durations_s(plan, leg_peak_factor=1.0)
    assert all(faster[k] <= v for k, v in min_durations_s(plan).items())
    with pytest.warns(DeprecationWarning, match="cruise_speed_mps="):
        old_est = estimate_durations_s(plan, fleet, cruise_speed_mps=2.0, spray_descent_s=1.0)
    assert old_est == estimate_durations_s(
        plan, fleet, timing=timing(cruise_speed_mps=2.0, spray_descent_s=1.0)
    )
    with pytest.warns(DeprecationWarning, match="arrive_tolerance_m="):
        old_cycles = min_cycles_s(plan, fleet, arrive_tolerance_m=0.2, effector_offset_m=(0.1, 0.0, -0.45))
    assert old_cycles == min_cycles_s(
        plan, fleet, timing=timing(arrive_tolerance_m=0.2, effector_offset_m=(0.1, 0.0, -0.45))
    )
    with pytest.raises(TypeError, match="unexpected keyword argument 'descent_duration_s'"):
        min_durations_s(plan, descent_duration_s=5.0)
    with pytest.raises(TypeError, match="unexpected keyword argument 'clearance_m'"):
        estimate_durations_s(plan, fleet, clearance_m=0.5)


def test_the_default_timing_is_the_default_uav_config() -> None:
    """The bounds' default numbers are the machines' (``UavConfig``'s defaults come from ``TaskTiming``)."""
    from masonry.fsm import UavConfig
    from masonry.planner.bounds import min_durations_s

    plan = Plan((brick(0, 1.0), glue(0, 0.0)), (), ())
    config_timing = UavConfig("b", "brick", (0.0, 0.0, 0.0)).timing()
    assert config_timing == DEFAULT_TIMING
    assert min_durations_s(plan) == min_durations_s(plan, timing=config_timing)
    slower = min_durations_s(plan, timing=timing(descent_duration_s=9.0))
    assert slower["B0"] > min_durations_s(plan)["B0"] and slower["A0"] == min_durations_s(plan)["A0"]
