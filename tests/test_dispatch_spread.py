"""critical-path spreads the brick UAVs along the wall (issue 27; docs/dispatch.md, "Spreading the brick UAVs
along the wall"): among the bricks it ranks alike, a brick UAV takes the one with the shortest flight plus
``SPREAD_WEIGHT`` metres per metre its site is closer than ``SPREAD_RADIUS_M`` to a site another UAV works
for; fifo and nearest are unchanged, and so is an adhesion UAV's pick."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_ranking import SPREAD_RADIUS_M, SPREAD_WEIGHT, crowd_m
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan


def brick(n: int, x: float) -> BrickTask:
    """Brick ``n`` at ``x`` on a straight course, its pickup 3 m in front of it."""
    return BrickTask(f"B{n}", n, False, (x, 0.0, 0.15), 0.0, (x, -3.0, 0.05))


def course(xs: list[float]) -> Plan:
    """One course of independent bricks that conflict with nothing (the spread alone decides)."""
    return Plan(tasks=tuple(brick(n, x) for n, x in enumerate(xs)), dependencies=(), conflicts=())


def two_brick_uavs(x0: float = 0.0, x1: float = 0.1) -> list[UavSpec]:
    return [UavSpec("brick-1", "brick", (x0, -4.0, 0.0)), UavSpec("brick-2", "brick", (x1, -4.0, 0.0))]


def test_crowd_is_nothing_past_the_radius_and_grows_by_the_weight_per_metre_closer() -> None:
    assert crowd_m((0.0, 0.0, 0.0), []) == 0.0
    assert crowd_m((0.0, 0.0, 0.0), [(SPREAD_RADIUS_M, 0.0, 0.0), (0.0, -SPREAD_RADIUS_M - 1.0, 5.0)]) == 0.0
    assert crowd_m((0.0, 0.0, 0.0), [(SPREAD_RADIUS_M - 1.0, 0.0, 9.0)]) == pytest.approx(SPREAD_WEIGHT)
    two = [(1.0, 0.0, 0.0), (0.0, 2.0, 0.0)]  # horizontal distances 1 and 2: summed
    assert crowd_m((0.0, 0.0, 0.0), two) == pytest.approx(SPREAD_WEIGHT * (2 * SPREAD_RADIUS_M - 3.0))


def test_the_second_brick_uav_takes_a_brick_away_from_the_first_ones_site() -> None:
    # bricks every 0.3 m from 0 to 4.5 m; both UAVs start at x = 0: the first takes B0 (nearest), the second, by
    # flight alone, B1 next to it, but B1 is 0.3 m from B0's site: 2.7 m closer than the radius, 5.4 m of cost,
    # so it takes the first brick SPREAD_RADIUS_M away (B10, at 3.0 m: 3 m more flight, no crowd)
    xs = [0.3 * k for k in range(16)]
    d = Dispatcher(course(xs), two_brick_uavs(), policy="critical-path")
    got = {a.uav: a.task_id for a in d.assign()}
    assert got == {"brick-1": "B0", "brick-2": "B10"}


@pytest.mark.parametrize("policy", ["nearest", "fifo"])
def test_nearest_and_fifo_do_not_spread(policy: str) -> None:
    xs = [0.3 * k for k in range(16)]
    d = Dispatcher(course(xs), two_brick_uavs(), policy=policy)
    assert {a.uav: a.task_id for a in d.assign()} == {"brick-1": "B0", "brick-2": "B1"}


def test_the_spread_does_not_reach_past_the_rank() -> None:
    # B0 waits for B1 (a longer chain for B1): the second UAV still takes the lower-ranked brick only if nothing
    # of the top rank is left; here B1 is the top and goes to brick-1, and brick-2 takes the spread's best of the
    # rest, never B0 (not ready)
    xs = [0.0, 0.3, 0.6, 3.6]
    plan = Plan(
        tasks=tuple(brick(n, x) for n, x in enumerate(xs)), dependencies=(("B0", "B1"),), conflicts=()
    )
    d = Dispatcher(plan, two_brick_uavs(0.3, 0.4), policy="critical-path")
    got = {a.uav: a.task_id for a in d.assign()}
    assert got["brick-1"] == "B1"
    assert got["brick-2"] == "B3"  # B2 is 0.3 m from B1's site; B3 3.3 m: 3 m more flight, no crowd


def test_an_adhesion_uav_is_not_spread() -> None:
    glue = [
        AdhesionTask(f"A{k}", 0, 1, (0.3 * k, 0.0, 0.1), (0.3 * k + 0.3, 0.0, 0.1), 0.3) for k in range(3)
    ]
    far = AdhesionTask("A3", 0, 1, (5.0, 0.0, 0.1), (5.3, 0.0, 0.1), 0.3)
    plan = Plan(tasks=(*glue, far), dependencies=(), conflicts=())
    fleet = [UavSpec("glue-1", "adhesion", (0.0, -1.0, 0.0)), UavSpec("glue-2", "adhesion", (0.3, -1.0, 0.0))]
    d = Dispatcher(plan, fleet, policy="critical-path")
    got = {a.uav: a.task_id for a in d.assign()}
    assert got == {"glue-1": "A0", "glue-2": "A1"}


@settings(max_examples=60, deadline=None)
@given(
    xs=st.lists(st.floats(-10.0, 10.0, allow_nan=False), min_size=1, max_size=12, unique=True),
    home=st.floats(-10.0, 10.0, allow_nan=False),
)
def test_a_lone_brick_uav_takes_the_nearest_brick_as_before(xs: list[float], home: float) -> None:
    # nobody else works: the spread adds nothing, and the pick is critical-path's shortest flight
    d = Dispatcher(course(xs), [UavSpec("brick-1", "brick", (home, -4.0, 0.0))], policy="critical-path")
    (a,) = d.assign()
    cost = [
        math.dist((home, -4.0, 0.0), (x, -3.0, 0.05)) + math.dist((x, -3.0, 0.05), (x, 0.0, 0.15)) for x in xs
    ]
    assert cost[int(a.task_id[1:])] == pytest.approx(min(cost))


@settings(max_examples=60, deadline=None)
@given(xs=st.lists(st.floats(-10.0, 10.0, allow_nan=False), min_size=2, max_size=12, unique=True))
def test_the_second_pick_is_the_least_cost_of_flight_and_crowd(xs: list[float]) -> None:
    d = Dispatcher(course(xs), two_brick_uavs(), policy="critical-path")
    got = {a.uav: a.task_id for a in d.assign()}
    first = xs[int(got["brick-1"][1:])]
    left = [x for x in xs if x != first]
    here = (0.1, -4.0, 0.0)

    def cost(x: float) -> float:
        flight = math.dist(here, (x, -3.0, 0.05)) + math.dist((x, -3.0, 0.05), (x, 0.0, 0.15))
        return flight + crowd_m((x, 0.0), [(first, 0.0)])

    assert cost(xs[int(got["brick-2"][1:])]) == pytest.approx(min(cost(x) for x in left))
