"""Chaining through a queued task (masonry.mission.dispatch_chain): a sprayer at the end of its segment is given
the next one of its run when it is ready, even while a conflicting brick task is in progress, as long as the
fleet's core (two brick UAVs per sprayer) has no more UAVs than the wall has sites to work at once and the fleet more
than one brick UAV; and the spares past that core stay on their pads while the core's UAVs of their role are
busy."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import UavSpec, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.dispatch_chain import (
    APART_BRICK_REACH_M,
    ChainThrough,
    mission_dispatcher,
)
from masonry.mission.fleet import fleet_for
from masonry.mission.simulate import simulate
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_admission import Admission
from masonry.planner.graphs import plan as plan_of
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

ROOT = Path(__file__).resolve().parents[1]
FLEET = [
    UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)),
    UavSpec("brick-2", "brick", (3.0, -3.0, 0.0)),
    UavSpec("glue-1", "adhesion", (-2.0, -3.0, 0.0)),
]
A0_END_M = (-0.9, 0.0, 0.55)  # the sprayer's body over the end of A0 (its nozzle hangs below it)


def glue(n: int, x0: float, x1: float) -> AdhesionTask:
    return AdhesionTask(f"A{n}", 0, 1, (x0, 0.0, 0.1), (x1, 0.0, 0.1), abs(x1 - x0))


def run_and_a_brick() -> Plan:
    """A0 -> A1 contiguous (a run), A2 further on; brick B0 conflicts with A1 only."""
    tasks = (
        glue(0, -1.05, -0.9),
        glue(1, -0.9, -0.75),
        glue(2, 1.0, 1.15),
        BrickTask("B0", 0, False, (-0.6, 0.0, 0.15), 0.0, (-0.6, -2.0, 0.05)),
    )
    return Plan(tasks, (), (("A1", "B0"),))


def after_a0(d: Dispatcher) -> list[str]:
    """The brick UAV takes B0 and the sprayer A0; A0 done, the sprayer still at its end: what is it given?"""
    assert sorted(a.task_id for a in d.assign()) == ["A0", "B0"]
    d.complete("A0")
    return [a.task_id for a in d.assign({"glue-1": A0_END_M})]


def test_the_sprayer_takes_the_next_segment_of_its_run_while_a_conflicting_brick_is_in_progress() -> None:
    d = ChainThrough(run_and_a_brick(), FLEET, reservation="site")
    d.admission = Admission(3, lambda _name: False)  # three sites to work at once, three UAVs
    assert after_a0(d) == ["A1"]
    assert d.in_progress == {"A1": "glue-1", "B0": "brick-1"}


def test_the_plain_dispatcher_sends_it_elsewhere() -> None:
    d = Dispatcher(run_and_a_brick(), FLEET, reservation="site")
    d.admission = Admission(3, lambda _name: False)
    assert after_a0(d) == ["A2"]


@pytest.mark.parametrize("width", [None, 2])
def test_not_past_the_walls_width_nor_without_the_admission_rule(width: int | None) -> None:
    d = ChainThrough(run_and_a_brick(), FLEET, reservation="site")
    if width is not None:
        d.admission = Admission(width, lambda _name: False)  # three UAVs for two sites: they queue already
    assert after_a0(d) == ["A2"]


def test_past_the_width_counts_the_core_not_the_spares() -> None:
    # three brick UAVs for one sprayer: a core of 2 + 1 (three UAVs, three sites) and one spare; the rules go by the
    # core, so the sprayer chains through as the 2 + 1 fleet's would
    fleet = [*FLEET, UavSpec("brick-3", "brick", (6.0, -3.0, 0.0))]
    d = ChainThrough(run_and_a_brick(), fleet, reservation="site")
    d.admission = Admission(3, lambda _name: False)
    assert after_a0(d) == ["A1"]


def bricks_apart(n: int) -> Plan:
    """``n`` bricks 3 m apart (no conflicts) and one segment far from them."""
    bricks = tuple(
        BrickTask(f"B{k}", 0, False, (3.0 * k, 0.0, 0.15), 0.0, (3.0 * k, -2.0, 0.05)) for k in range(n)
    )
    return Plan((*bricks, glue(0, 20.0, 20.15)), (), ())


@pytest.mark.parametrize(("bricks", "sprayers", "busy"), [(3, 1, 2), (5, 2, 4), (4, 2, 4), (2, 1, 2)])
def test_a_spare_past_the_core_stays_on_its_pad_while_the_core_of_its_role_is_busy(
    bricks: int, sprayers: int, busy: int
) -> None:
    fleet = [UavSpec(f"brick-{k + 1}", "brick", (3.0 * k, -5.0, 0.0)) for k in range(bricks)]
    fleet += [UavSpec(f"glue-{k + 1}", "adhesion", (-3.0 - 3.0 * k, -5.0, 0.0)) for k in range(sprayers)]
    d = ChainThrough(bricks_apart(6), fleet, reservation="site")
    d.admission = Admission(6, lambda _name: True)  # every UAV on its pad
    given = [a for a in d.assign() if a.task_id.startswith("B")]
    assert [a.uav for a in given] == [f"brick-{k + 1}" for k in range(busy)]
    d.complete(given[0].task_id)  # one of the core is free: the next idle UAV in fleet order takes its place
    assert len([a for a in d.assign() if a.task_id.startswith("B")]) == 1


def test_resting_spares_stay_on_their_pads_while_a_core_uav_is_away_and_the_core_takes_off_again() -> None:
    # 4 + 4 (core 4 + 2): glue-1 of the core is away for its swap. Its role's spares past the core rest (the
    # sprayers are not the wall's pace): glue-3 and glue-4 stay on their pads; glue-1, back on its pad, takes off
    fleet = [UavSpec(f"brick-{k + 1}", "brick", (3.0 * k, -5.0, 0.0)) for k in range(4)]
    fleet += [UavSpec(f"glue-{k + 1}", "adhesion", (-3.0 - 3.0 * k, -5.0, 0.0)) for k in range(4)]
    segments = tuple(glue(k, 2.0 * k, 2.0 * k + 0.15) for k in range(6))
    plan = Plan(segments, (), ())
    away = {"glue-1"}
    d = ChainThrough(plan, fleet, reservation="site")
    d.admission = Admission(6, lambda name: name not in away)  # every UAV on its pad but glue-1
    resting = {"adhesion": True}
    d.spares_rest = lambda role: resting.get(role, False)

    def home(name: str) -> bool:
        return name not in away  # (mission control gives no task to a UAV away for its swap)

    assert [a.uav for a in d.assign(may_start=home)] == ["glue-2"]  # glue-1 away: the spares stay down
    away.clear()  # glue-1 back on its pad with a fresh pack
    assert [a.uav for a in d.assign(may_start=home)] == ["glue-1"]
    resting["adhesion"] = False  # the sprayers the pace: a spare takes a free place of the core
    d.complete(d.task_of("glue-1") or "")
    away.add("glue-1")
    assert [a.uav for a in d.assign(may_start=home)] == ["glue-3"]


def test_a_spare_in_the_air_is_not_held_back() -> None:
    fleet = [UavSpec(f"brick-{k + 1}", "brick", (3.0 * k, -5.0, 0.0)) for k in range(3)]
    fleet.append(UavSpec("glue-1", "adhesion", (-3.0, -5.0, 0.0)))
    d = ChainThrough(bricks_apart(6), fleet, reservation="site")
    d.admission = Admission(6, lambda _name: False)  # every UAV in the air: none is kept on its pad
    assert len([a for a in d.assign() if a.task_id.startswith("B")]) == 3


def test_not_with_one_brick_uav() -> None:
    # the one brick UAV is the whole of its role: the sprayer does not make it wait
    d = ChainThrough(run_and_a_brick(), [FLEET[0], FLEET[2]], reservation="site")
    d.admission = Admission(3, lambda _name: False)
    assert after_a0(d) == ["A2"]


def test_a_segment_not_ready_is_not_taken() -> None:
    # A1 waits for B0 (a segment over the brick): chaining through would send the sprayer to a site it may not
    # enter before the brick is laid
    base = run_and_a_brick()
    d = ChainThrough(Plan(base.tasks, (("A1", "B0"),), base.conflicts), FLEET, reservation="site")
    d.admission = Admission(3, lambda _name: False)
    assert sorted(a.task_id for a in d.assign()) == ["A0", "B0"]
    d.complete("A0")
    assert [a.task_id for a in d.assign({"glue-1": A0_END_M})] == ["A2"]


def test_mission_control_uses_it_for_the_reactive_policies_under_site_only() -> None:
    p = plan_of(running_bond(2, 6, placed_courses=1))
    fleet = [UavSpec("brick-1", "brick", (0.0, -5.0, 0.0)), UavSpec("glue-1", "adhesion", (1.0, -5.0, 0.0))]
    for policy in ("critical-path", "fifo", "nearest"):
        assert type(mission_dispatcher(p, fleet, policy, reservation="site")) is ChainThrough
        assert type(mission_dispatcher(p, fleet, policy, reservation="task")) is Dispatcher


@pytest.mark.parametrize(("blueprint", "bricks", "adhesion"), [("pyramid", 1, 1), ("bond", 2, 1)])
def test_missions_with_it_complete_and_keep_their_separation(
    blueprint: str, bricks: int, adhesion: int
) -> None:
    bp = (
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml")
        if blueprint == "pyramid"
        else running_bond(2, 12)
    )
    r = simulate(bp, brick_uavs=bricks, adhesion_uavs=adhesion, seed=1, camera="geometric")
    assert all(t.status == "done" for t in r.tasks)
    assert r.min_separation_m >= 1.0
    assert r.conflict_violations == 0 and r.dependency_violations == 0


TWO_SPRAYERS = [
    UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)),
    UavSpec("brick-2", "brick", (3.0, -3.0, 0.0)),
    UavSpec("glue-1", "adhesion", (-2.0, -3.0, 0.0)),
    UavSpec("glue-2", "adhesion", (-1.5, -3.0, 0.0)),
]


def segments_by_two_bricks() -> Plan:
    """A1 conflicts with A0 (the first sprayer's) and brick B0; A2, farther, with brick B1 only."""
    tasks = (
        glue(0, -1.05, -0.9),
        glue(1, -0.9, -0.75),
        glue(2, 1.0, 1.15),
        BrickTask("B0", 0, False, (-0.6, 0.0, 0.15), 0.0, (-0.6, -2.0, 0.05)),
        BrickTask("B1", 1, False, (1.3, 0.0, 0.15), 0.0, (1.3, -2.0, 0.05)),
    )
    return Plan(tasks, (), (("A0", "A1"), ("A1", "B0"), ("A2", "B1")))


@pytest.mark.parametrize(("width", "second"), [(2, "A2"), (3, "A1"), (None, "A1")])
def test_past_the_width_the_second_sprayer_is_given_a_segment_away_from_the_first(
    width: int | None, second: str
) -> None:
    # nothing available for glue-2: A1 (nearer, next to glue-1's A0) or A2 (by a brick only); past the width
    # (the 2 + 2 fleet's core of 2 + 1, three UAVs, for two sites) it is A2, else the nearest; glue-2, past the
    # core, is in the air here, and a UAV in the air is never held back
    d = ChainThrough(segments_by_two_bricks(), TWO_SPRAYERS, reservation="site")
    if width is not None:
        d.admission = Admission(width, lambda _name: False)
    d.assign()
    assert d.in_progress == {"B0": "brick-1", "B1": "brick-2", "A0": "glue-1", second: "glue-2"}


def bricks_by_a_sprayer(x_m: float = 3.0) -> tuple[Plan, list[UavSpec]]:
    """B1 conflicts with brick B0, B2 (at ``x_m``) with segment A0 only; brick-2 waits nearer B1."""
    tasks = (
        BrickTask("B0", 0, False, (0.0, 0.0, 0.15), 0.0, (0.0, -2.0, 0.05)),
        BrickTask("B1", 1, False, (0.3, 0.0, 0.15), 0.0, (0.3, -2.0, 0.05)),
        BrickTask("B2", 2, False, (x_m, 0.0, 0.15), 0.0, (x_m, -2.0, 0.05)),
        glue(0, x_m + 0.1, x_m + 0.25),
    )
    fleet = [
        UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)),
        UavSpec("brick-2", "brick", (0.5, -3.0, 0.0)),
        UavSpec("glue-1", "adhesion", (x_m, -3.0, 0.0)),
    ]
    return Plan(tasks, (), (("B0", "B1"), ("B2", "A0"))), fleet


@pytest.mark.parametrize(("width", "second"), [(2, "B2"), (3, "B1"), (None, "B1")])
def test_past_the_width_the_second_brick_uav_is_given_a_brick_away_from_the_first(
    width: int | None, second: str
) -> None:
    # nothing available for brick-2 once brick-1 has B0 and glue-1 A0: B1 (nearer, next to B0) or B2 (by the
    # segment only); past the width (three UAVs, two sites) it is B2, else the nearest
    plan, fleet = bricks_by_a_sprayer()
    d = ChainThrough(plan, fleet, reservation="site")
    if width is not None:
        d.admission = Admission(width, lambda _name: False)
    d.assign(may_start=lambda name: name != "brick-2")
    assert d.in_progress == {"B0": "brick-1", "A0": "glue-1"}
    d.assign()
    assert d.in_progress == {"B0": "brick-1", "A0": "glue-1", second: "brick-2"}


def test_past_the_width_a_brick_away_from_the_first_is_not_looked_for_beyond_its_reach() -> None:
    # B2 apart but 3.5 m from B1 (the dispatcher's own choice), beyond APART_BRICK_REACH_M: brick-2 takes B1
    plan, fleet = bricks_by_a_sprayer(x_m=0.3 + APART_BRICK_REACH_M + 0.5)
    d = ChainThrough(plan, fleet, reservation="site")
    d.admission = Admission(2, lambda _name: False)
    d.assign(may_start=lambda name: name != "brick-2")
    d.assign()
    assert d.in_progress == {"B0": "brick-1", "A0": "glue-1", "B1": "brick-2"}


@pytest.mark.parametrize("sprayers", [2, 3, 4])
def test_the_admission_cap_shares_the_wall_among_the_core_not_the_spares(sprayers: int) -> None:
    # the bundled pyramid (width 2: four UAVs busy at most): 4 + 3 and 4 + 4 keep 3 brick UAVs and 1 sprayer busy as
    # their core 4 + 2 does, not 2 + 2 (1,489 / 1,477 s on seeds 1 / 2 against 4 + 2's 1,201 / 1,175 s)
    bp = load_blueprint(ROOT / "blueprints" / "pyramid.yaml")
    fleet = fleet_for(bp, 4, sprayers)
    d = ChainThrough(plan_of(bp), fleet, reservation="site")
    rule = Admission(2, lambda _name: True)
    d.admission = rule
    assert rule.applies(len(fleet))
    assert rule.cap(*d._cap_counts("brick")) == 3 and rule.cap(*d._cap_counts("adhesion")) == 1
    assert d.capped_alone("adhesion") and not d.capped_alone("brick")
