"""The wall's last brick and the spare brick UAVs past the 2 : 1 core (masonry.mission.dispatch_chain).

Any brick UAV with no task, on its pad or in the air, is given the wall's last brick as soon as the glue under it
is ready (docs/performance/fleet.md, "The last brick for any brick UAV"); a spare on its pad is given a brick it
can start now, never one to fetch ahead of its glue (the pyramid's 3 + 1: "The third brick UAV of the pyramid's
3 + 1")."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import UavSpec, load_blueprint
from masonry.mission.dispatch_chain import ChainThrough
from masonry.mission.simulate import simulate
from masonry.planner.dispatch_admission import Admission
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan

ROOT = Path(__file__).resolve().parents[1]


def fleet(bricks: int) -> list[UavSpec]:
    out = [UavSpec(f"brick-{k + 1}", "brick", (3.0 * k, -5.0, 0.0)) for k in range(bricks)]
    return [*out, UavSpec("glue-1", "adhesion", (-3.0, -5.0, 0.0))]


def glue(n: int, x0: float, x1: float) -> AdhesionTask:
    return AdhesionTask(f"A{n}", 0, 1, (x0, 0.0, 0.1), (x1, 0.0, 0.1), abs(x1 - x0))


def brick(n: int, x: float) -> BrickTask:
    return BrickTask(f"B{n}", 1, False, (x, 0.0, 0.15), 0.0, (x, -2.0, 0.05))


def last_brick_on_two_segments() -> Plan:
    """B0, the only brick, rests on A0 and A1 (a run of two segments, conflicting with each other and with it)."""
    tasks = (glue(0, -0.3, 0.0), glue(1, 0.0, 0.3), brick(0, 0.0))
    deps = (("B0", "A0"), ("B0", "A1"))
    return Plan(tasks, deps, (("A0", "A1"), ("A0", "B0"), ("A1", "B0")))


@pytest.mark.parametrize("bricks", [1, 2, 3])
def test_the_first_brick_uav_on_its_pad_fetches_the_last_brick_once_the_glue_under_it_is_ready(
    bricks: int,
) -> None:
    # A0 and A1 ready, neither sprayed: B0 cannot be prefetched (its glue is not in progress), but it is the last
    # brick: the first brick UAV, on its pad, fetches it while the glue is sprayed, in every fleet (1 + 1 to 3 + 1)
    d = ChainThrough(last_brick_on_two_segments(), fleet(bricks), reservation="site")
    d.admission = Admission(3, lambda _name: True)  # every UAV on its pad
    d.assign()
    assert d.in_progress.get("B0") == "brick-1"
    assert "glue-1" in d.in_progress.values()


@pytest.mark.parametrize("bricks", [2, 3])
def test_a_brick_uav_in_the_air_with_no_task_fetches_the_last_brick_before_one_on_its_pad(
    bricks: int,
) -> None:
    # brick-2 in the air (at the wall, its brick just placed), the others on their pads: brick-1, first in fleet
    # order, leaves the last brick to it (no take-off)
    d = ChainThrough(last_brick_on_two_segments(), fleet(bricks), reservation="site")
    d.admission = Admission(3, lambda name: name != "brick-2")
    d.assign()
    assert d.in_progress == {"B0": "brick-2", "A0": "glue-1"}


def test_a_brick_uav_flying_home_for_its_swap_leaves_the_last_brick_to_one_on_its_pad() -> None:
    d = ChainThrough(last_brick_on_two_segments(), fleet(2), reservation="site")
    d.admission = Admission(3, lambda name: name != "brick-2", swap_sent=lambda name: name == "brick-2")
    d.assign(may_start=lambda name: name != "brick-2")  # (its swap is due: it may take no task)
    assert d.in_progress == {"B0": "brick-1", "A0": "glue-1"}


def test_the_spare_fetches_the_last_brick_while_the_core_cannot_start() -> None:
    d = ChainThrough(last_brick_on_two_segments(), fleet(3), reservation="site")
    d.admission = Admission(3, lambda _name: True)
    d.assign(may_start=lambda name: name not in ("brick-1", "brick-2"))  # the core away for its swaps
    assert d.in_progress == {"B0": "brick-3", "A0": "glue-1"}


def three_bricks_on_three_segments() -> Plan:
    """B<k> on A<k> (k = 0, 1, 2), 3 m apart, no segment sprayed."""
    tasks = (*(glue(k, 3.0 * k - 0.3, 3.0 * k) for k in range(3)), *(brick(k, 3.0 * k) for k in range(3)))
    deps = tuple((f"B{k}", f"A{k}") for k in range(3))
    return Plan(tasks, deps, tuple((f"A{k}", f"B{k}") for k in range(3)))


def test_only_the_last_brick_to_give_is_fetched_before_its_glue_is_given() -> None:
    # B0 is prefetched as before (A0 given); B1 and B2 wait for their glue: neither is the last brick to give
    d = ChainThrough(three_bricks_on_three_segments(), fleet(2), reservation="site")
    d.admission = Admission(3, lambda _name: True)
    d.assign()
    assert d.in_progress == {"A0": "glue-1", "B0": "brick-1"}
    d.complete("A0")
    d.complete("B0")
    d.assign(may_start=lambda name: name != "glue-1")  # the sprayer not on its way yet
    assert d.in_progress == {}
    # the sprayer given A1: B1 prefetched as before; B2 now the last brick to give, its glue ready: fetched too
    d.assign()
    assert d.in_progress == {"A1": "glue-1", "B1": "brick-1", "B2": "brick-2"}


def test_not_before_every_segment_under_it_is_ready() -> None:
    # A1 waits for a brick of the course below (B1): B0 is not the one brick left, and its glue is not ready
    base = last_brick_on_two_segments()
    plan = Plan((*base.tasks, brick(1, 2.0)), (*base.dependencies, ("A1", "B1")), base.conflicts)
    d = ChainThrough(plan, fleet(3), reservation="site")
    d.admission = Admission(3, lambda _name: True)
    d.assign(may_start=lambda name: name != "brick-1")  # brick-1 chose B1 and may not start yet
    assert d.in_progress == {"A0": "glue-1", "B1": "brick-2"}
    d.complete("B1")
    d.assign(may_start=lambda name: name not in ("brick-1", "brick-2"))
    assert d.in_progress == {"A0": "glue-1", "B0": "brick-3"}  # B1 placed: A1 ready, B0 the last brick


def test_not_when_a_segment_under_it_was_given_up() -> None:
    d = ChainThrough(last_brick_on_two_segments(), fleet(2), reservation="site")
    d.admission = Admission(3, lambda _name: True)
    glue_only = lambda name: name == "glue-1"  # noqa: E731
    d.assign(may_start=glue_only)
    sprayed = next(iter(d.in_progress))
    d.complete(sprayed)
    d.assign(may_start=glue_only)
    assert not d.fail(next(iter(d.in_progress)), give_up=True)  # the other segment: given up (stuck)
    d.assign()
    assert d.in_progress == {} and "B0" not in d.done


def bricks_on_one_segment() -> Plan:
    """B0, B1, B2 each on A0 alone (prefetchable once A0 is in progress)."""
    tasks = (glue(0, -0.3, 0.0), brick(0, 3.0), brick(1, 6.0), brick(2, 9.0))
    return Plan(tasks, (("B0", "A0"), ("B1", "A0"), ("B2", "A0")), ())


def test_past_the_width_a_spare_on_its_pad_fetches_no_brick_ahead_of_its_glue() -> None:
    # the core (2 + 1, three UAVs) past the wall's two sites; its two brick UAVs cannot start (away for their
    # swaps): the spare is not sent to fetch a brick whose glue is still sprayed; once the glue is done it takes a
    # brick it can start
    d = ChainThrough(bricks_on_one_segment(), fleet(3), reservation="site")
    d.admission = Admission(2, lambda _name: True)
    core_away = {"brick-1", "brick-2"}
    d.assign(may_start=lambda name: name not in core_away)
    assert d.in_progress == {"A0": "glue-1"}
    d.complete("A0")
    d.assign(may_start=lambda name: name not in core_away)
    assert set(d.in_progress.values()) == {"brick-3"}


def test_under_the_width_a_spare_on_its_pad_prefetches_as_before() -> None:
    d = ChainThrough(bricks_on_one_segment(), fleet(3), reservation="site")
    d.admission = Admission(3, lambda _name: True)  # three sites for the core's three UAVs
    d.assign(may_start=lambda name: name not in ("brick-1", "brick-2"))
    assert set(d.in_progress.values()) == {"glue-1", "brick-3"}


def test_a_core_uav_on_its_pad_still_prefetches() -> None:
    d = ChainThrough(bricks_on_one_segment(), fleet(3), reservation="site")
    d.admission = Admission(2, lambda _name: True)
    d.assign(may_start=lambda name: name != "brick-1")
    assert d.in_progress == {"A0": "glue-1", "B0": "brick-2"}


def test_a_spare_in_the_air_prefetches_as_before() -> None:
    d = ChainThrough(bricks_on_one_segment(), fleet(3), reservation="site")
    d.admission = Admission(2, lambda _name: False)  # every UAV in the air
    d.assign(may_start=lambda name: name not in ("brick-1", "brick-2"))
    assert set(d.in_progress.values()) == {"glue-1", "brick-3"}  # the nearest brick to prefetch


def test_the_pyramid_at_3_plus_1_completes_and_keeps_its_separation() -> None:
    r = simulate(
        load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
        brick_uavs=3,
        adhesion_uavs=1,
        seed=3,
        camera="geometric",
        reservation="site",
    )
    assert all(t.status == "done" for t in r.tasks)
    assert r.min_separation_m is not None and r.min_separation_m >= 1.0
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    by_id = {t.id: t for t in r.tasks}
    last = max(r.tasks, key=lambda t: t.end_s or 0.0)
    assert last.id == "B35"  # on A54 and A55, the last two segments
    # given once B34 was placed (A55 ready), before the sprayer was given A55: at the pallet while it sprays
    b35, a55 = by_id["B35"].start_s, by_id["A55"].start_s
    assert b35 is not None and a55 is not None and b35 < a55
