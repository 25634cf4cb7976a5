"""Bricks past a segment (masonry.mission.dispatch_chain): past the wall's width, a segment in progress keeps no
brick task unavailable (a brick UAV is minutes from the site, the sprayer seconds), while a brick in progress
still keeps its conflicting segments unavailable; up to the width, or without the admission rule, as before."""

from __future__ import annotations

import pytest

from masonry.blueprint import UavSpec
from masonry.blueprint_gen import running_bond
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.simulate import simulate
from masonry.planner.dispatch_admission import Admission
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

FLEET = [UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)), UavSpec("glue-1", "adhesion", (-2.0, -3.0, 0.0))]


def glue(n: int, x0: float) -> AdhesionTask:
    return AdhesionTask(f"A{n}", 0, 1, (x0, 0.0, 0.1), (x0 + 0.15, 0.0, 0.1), 0.15)


def brick(n: int, x: float) -> BrickTask:
    return BrickTask(f"B{n}", n, False, (x, 0.0, 0.15), 0.0, (x, -2.0, 0.05))


def plan() -> Plan:
    """B0 (chain B0 -> A3 -> B4) first; then A0, which conflicts with B1 (chain B1 -> A2) and not with B2 (chain 1)."""
    tasks = (
        brick(0, -5.0),
        glue(0, 0.0),
        brick(1, 0.3),
        brick(2, 5.0),
        glue(2, 0.3),
        glue(3, -5.0),
        brick(4, -5.3),
    )
    deps = (("A3", "B0"), ("B4", "A3"), ("A2", "B1"))
    return Plan(tasks, deps, (("A0", "B1"), ("A2", "B2"), ("A3", "B4"), ("B0", "B4")))


def second_brick(width: int | None) -> tuple[list[str], str]:
    """brick-1 takes B0 and glue-1 A0; B0 done, what brick-1 is given next (and whether B1 was available)."""
    d = ChainThrough(plan(), FLEET, reservation="site")
    if width is not None:
        d.admission = Admission(width, lambda _name: False)
    assert sorted(a.task_id for a in d.assign()) == ["A0", "B0"]
    seen = list(d.available)
    d.complete("B0")
    return seen, next(a.task_id for a in d.assign() if a.uav == "brick-1")


def test_past_the_width_the_brick_next_to_a_segment_in_progress_is_available() -> None:
    seen, given = second_brick(width=1)  # two UAVs, one site at a time: past the width
    assert "B1" in seen
    assert given == "B1"  # the longer chain, though A0 is being sprayed next to it


@pytest.mark.parametrize("width", [None, 2])
def test_up_to_the_width_or_without_the_admission_rule_as_before(width: int | None) -> None:
    seen, given = second_brick(width)
    assert "B1" not in seen
    assert given == "B2"


def test_a_brick_in_progress_still_keeps_its_segments_unavailable() -> None:
    d = ChainThrough(plan(), FLEET, reservation="site")
    d.admission = Admission(1, lambda _name: False)
    d.assign()
    d.complete("B0")
    d.complete("A0")
    assert [a.task_id for a in d.assign()] == ["B1", "A3"]  # A2 waits for B1; A3 ready, B4 not
    d.complete("A3")
    # B4 is ready and available; A2 is not ready (B1 runs): nothing about B1's conflicting tasks changed
    assert "A2" not in d.available


def test_a_segment_releases_what_it_blocked_when_it_started_though_the_fleet_changed() -> None:
    # A0 starts with the rule off (B1 blocked); the rule is on when A0 ends: B1 must be free again
    d = ChainThrough(plan(), FLEET, reservation="site")
    d.admission = Admission(2, lambda _name: False)
    d.assign()
    assert "B1" not in d.available
    d.admission = Admission(1, lambda _name: False)
    d.complete("A0")
    assert "B1" in d.available


def test_a_mission_past_its_walls_width_completes_and_keeps_its_separation() -> None:
    # a 3.6 m wall (width 3 at r_c 1.5 m) flown by 3 + 1 UAVs: the rule is on
    r = simulate(
        running_bond(2, 12, placed_courses=1), brick_uavs=3, adhesion_uavs=1, seed=1, camera="geometric"
    )
    assert all(t.status == "done" for t in r.tasks)
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
    assert r.conflict_violations == 0 and r.dependency_violations == 0
