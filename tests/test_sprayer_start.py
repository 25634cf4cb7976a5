"""Sprayers start apart (masonry.mission.dispatch_chain, issue 27): up to the wall's width, with two sprayers or
more, each sprayer's first segment is the available one starting nearest its spot (the quarter points at two),
where the critical-path policy ranks every first segment alike (the 12 m wall); where it ranks part of the wall
first (the 6 x 30 wall's +x third) the policy's own picks stand."""

from __future__ import annotations

from collections.abc import Sequence

import pytest

from masonry.blueprint import Blueprint, UavSpec
from masonry.blueprint_gen import running_bond
from masonry.mission.dispatch_chain import ChainThrough, start_spots
from masonry.mission.fleet import fleet_for
from masonry.mission.uav_stack import priority_durations_s
from masonry.planner import estimate_durations_s
from masonry.planner import plan as plan_of
from masonry.planner.dispatch import Dispatcher
from masonry.planner.dispatch_admission import Admission

SPRAYERS = [
    UavSpec("glue-1", "adhesion", (16.0, -6.0, 0.0)),
    UavSpec("glue-2", "adhesion", (1.0, -6.0, 0.0)),
]


def test_the_spots_are_the_middles_of_equal_shares_in_the_order_of_the_homes() -> None:
    along_x = [(-6.0, 0.0, 0.1), (2.0, 0.0, 0.1), (6.0, 0.0, 0.1)]
    assert start_spots(along_x, SPRAYERS) == (0, {"glue-2": -3.0, "glue-1": 3.0})
    along_y = [(0.0, -4.0, 0.1), (0.0, 4.0, 0.1)]
    three = [*SPRAYERS, UavSpec("glue-3", "adhesion", (0.0, 9.0, 0.0))]
    axis, spots = start_spots(along_y, three)
    assert axis == 1
    assert spots == pytest.approx(
        {"glue-1": -4.0 + 8.0 / 6.0, "glue-2": -4.0 + 3 * 8.0 / 6.0, "glue-3": 4.0 - 8.0 / 6.0}
    )
    assert start_spots([], SPRAYERS) == (0, {})


def first_segments(d: Dispatcher) -> dict[str, float]:
    """Where each sprayer's first segment starts (x, m), from the first call of ``assign``."""
    return {a.uav: d.plan.task(a.task_id).start_m[0] for a in d.assign() if a.uav.startswith("glue")}


def dispatcher(cls: type[Dispatcher], bp: Blueprint, fleet: Sequence[UavSpec], width: int) -> Dispatcher:
    """``cls`` as mission control builds it: critical-path on the expected durations, ``site``, the admission rule
    (every UAV on its pad)."""
    p = plan_of(bp)
    expected = estimate_durations_s(p, fleet, cruise_altitude_m=bp.cruise_altitude_m)
    d = cls(p, fleet, "critical-path", durations_s=priority_durations_s(expected), reservation="site")
    d.admission = Admission(width, lambda _name: True)
    return d


def test_on_the_12_m_wall_the_two_sprayers_start_at_the_quarter_points() -> None:
    bp = running_bond(3, 40, placed_courses=1)
    fleet = fleet_for(bp, 4, 2)
    spread = first_segments(dispatcher(ChainThrough, bp, fleet, 8))
    assert spread == pytest.approx({"glue-1": -3.075, "glue-2": 2.775})  # the quarter points -3.0 / +2.85
    plain = first_segments(dispatcher(Dispatcher, bp, fleet, 8))
    # the policy's own picks: glue-2 six segments from the wall's end (+5.0 m), a short run and then a jump
    assert plain == pytest.approx({"glue-1": -2.175, "glue-2": 5.025})


def test_not_past_the_width_nor_with_one_sprayer() -> None:
    bp = running_bond(3, 40, placed_courses=1)
    fleet = fleet_for(bp, 4, 2)
    past = first_segments(dispatcher(ChainThrough, bp, fleet, 2))
    assert past == first_segments(dispatcher(Dispatcher, bp, fleet, 2))
    one = fleet_for(bp, 2, 1)
    assert first_segments(dispatcher(ChainThrough, bp, one, 8)) == first_segments(
        dispatcher(Dispatcher, bp, one, 8)
    )


def test_where_the_policy_ranks_part_of_the_wall_first_its_own_picks_stand() -> None:
    # the 6 x 30 wall: its +x third (x >= 1.28 m) one critical-path step above the rest; a sprayer sent to its
    # quarter point (-2.2 m) was sent back into the other's run after one segment (seeds 1-5 +2.1 %)
    bp = running_bond(6, 30, placed_courses=1)
    fleet = fleet_for(bp, 4, 2)
    d = dispatcher(ChainThrough, bp, fleet, 8)
    assert isinstance(d, ChainThrough) and d._spots == {}
    starts = first_segments(d)
    assert starts == first_segments(dispatcher(Dispatcher, bp, fleet, 8))
    # the ranked part's starts (before the pallet's interleaved rows, pallet46: both at x >= 1.2 m)
    assert starts == pytest.approx({"glue-1": -0.225, "glue-2": 3.225})


def test_only_the_first_segment_goes_to_the_spot() -> None:
    bp = running_bond(3, 40, placed_courses=1)
    d = dispatcher(ChainThrough, bp, fleet_for(bp, 4, 2), 8)
    first = {a.uav: a.task_id for a in d.assign() if a.uav.startswith("glue")}
    d.complete(first["glue-1"])
    end = d.plan.task(first["glue-1"]).end_m
    again = {a.uav: a.task_id for a in d.assign({"glue-1": (end[0], end[1], 0.55)}) if a.uav == "glue-1"}
    nxt = d.plan.task(again["glue-1"])
    assert nxt.start_m[0] == pytest.approx(end[0])  # it chains on along its run


@pytest.mark.parametrize("sprayers", [3, 4])
def test_the_spares_past_the_core_have_no_spot_and_the_core_starts_as_4_plus_2(sprayers: int) -> None:
    # 4 + 3 and 4 + 4 fly as their core 4 + 2 (the spares past it on their pads): the same quarter points
    bp = running_bond(3, 40, placed_courses=1)
    fleet = fleet_for(bp, 4, sprayers)
    d = dispatcher(ChainThrough, bp, fleet, 8)
    assert isinstance(d, ChainThrough) and set(d._spots) == {"glue-1", "glue-2"}
    assert first_segments(d) == first_segments(dispatcher(ChainThrough, bp, fleet_for(bp, 4, 2), 8))
