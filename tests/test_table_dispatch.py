"""Dispatch that looks at the table (issue 27 §1.6): the pure probe (masonry.reservation.probe), the ranking's
chooser (masonry.planner.dispatch_ranking) and mission control's choice under ``--airspace table``
(masonry.mission.table_dispatch)."""

from __future__ import annotations

import math

import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from masonry.blueprint_gen import running_bond
from masonry.errors import PlanningError
from masonry.mission import table_dispatch
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.dispatch_ranking import CHOOSE_AMONG, Ranking
from masonry.planner.schedule_policy import ScheduleDispatcher, make_dispatcher
from masonry.planner.schedule_values import OfflineSchedule, ScheduledTask, UavSchedule
from masonry.reservation import (
    Airspace,
    Grant,
    Place,
    Request,
    Reservation,
    Table,
    Work,
    column,
    decide,
    soonest_done,
    soonest_order,
    start_table,
)

LAYERS_M = (2.0, 3.0, 4.0)
AIR = Airspace(LAYERS_M, horizon_s=math.inf, first_arrival=True, any_layer=True, piece_m=1.0)


def _work(x: float, y: float, duration_s: float = 10.0) -> Work:
    return Work((x, y), 1.0, duration_s, radius_m=0.3)


def _fleet(others: list[tuple[float, float, float, float, float]]) -> Table:
    """``me`` on its pad at (0, 0), ``u1``.. on theirs, each other UAV granted a flight to a site at its time."""
    homes = {"me": (0.0, 0.0), **{f"u{k + 1}": (2.0 * (k + 1), -3.0) for k in range(len(others))}}
    table = start_table(homes)
    for k, (x, y, at_s, work_s, _) in enumerate(others):
        uav = f"u{k + 1}"
        request = Request(uav, Place(homes[uav]), _work(x, y, work_s), Place(homes[uav]))
        try:
            got = decide(table, request, at_s, AIR)
        except (
            PlanningError
        ):  # (a window that ends as another starts, apart by a float's rounding: not this test's)
            continue
        if isinstance(got, Grant):
            table = got.table
    return table


def test_the_probe_of_one_visit_is_when_decide_grants_it_plus_the_work():
    table = _fleet([(4.0, 4.0, 0.0, 20.0, 0.0)])
    w = _work(4.2, 4.0)
    got = decide(table, Request("me", Place((0.0, 0.0)), w, None), 0.0, AIR)
    assert isinstance(got, Grant)
    assert got.plan.start_s > 0.0  # (it waits for u1's work there)
    assert soonest_done(table, "me", Place((0.0, 0.0)), [w], 0.0, AIR) == got.plan.stay.t0_s + w.duration_s


def test_the_soonest_of_two_tasks_is_the_one_not_behind_another_uav_and_ties_go_to_the_policy_s_order():
    table = _fleet([(4.0, 4.0, 0.0, 60.0, 0.0)])
    busy, free = [_work(4.2, 4.0)], [_work(-4.0, 4.0)]  # as far, one where u1 works for 60 s
    best, done = soonest_order(table, "me", Place((0.0, 0.0)), [busy, free], 0.0, AIR)
    assert best == 1 and done[1] < done[0]
    best, done = soonest_order(table, "me", Place((0.0, 0.0)), [free, free], 0.0, AIR)
    assert best == 0 and done[0] == done[1]


def test_a_task_of_two_visits_flies_on_from_where_the_first_ended():
    table = _fleet([])
    pick, drop = _work(0.0, 5.0, 12.0), _work(6.0, 5.0, 15.0)
    first = soonest_done(table, "me", Place((0.0, 0.0)), [pick], 0.0, AIR)
    both = soonest_done(table, "me", Place((0.0, 0.0)), [pick, drop], 0.0, AIR)
    alone = soonest_done(table, "me", pick.end_place(), [drop], 0.0, AIR)
    assert both == pytest.approx(first + alone)


def test_a_stay_in_the_way_is_never_left():
    """Another UAV hovering at the site for good (the table says "until it leaves"): no time."""
    hover = Reservation("u9", column((4.0, 4.0), 0.0, 1.0, 0.3), 0.0, math.inf, "stay")
    table = _fleet([]).add(hover)
    assert soonest_done(table, "me", Place((0.0, 0.0)), [_work(4.2, 4.0)], 0.0, AIR) == math.inf
    assert math.isfinite(soonest_done(table, "me", Place((0.0, 0.0)), [_work(-4.2, 4.0)], 0.0, AIR))


def test_no_visits_or_no_candidates_is_an_error():
    with pytest.raises(PlanningError, match="no site"):
        soonest_done(_fleet([]), "me", Place((0.0, 0.0)), [], 0.0, AIR)
    with pytest.raises(PlanningError, match="no candidate"):
        soonest_order(_fleet([]), "me", Place((0.0, 0.0)), [], 0.0, AIR)


_other = st.tuples(
    st.floats(-6.0, 6.0),
    st.floats(1.0, 8.0),
    st.floats(0.0, 30.0),
    st.floats(1.0, 40.0),
    st.just(0.0),
)


@settings(max_examples=60, deadline=None)
@example(  # a flight planned to start as u3's transit ends: its descent's window met it by a float rounding
    others=[
        (0.0, 1.0, 0.0, 1.0, 0.0),
        (0.0, 7.75, 0.0, 14.0, 0.0),
        (-5.0, 1.0, 0.0, 18.741688607395524, 0.0),
    ],
    sites=[(-6.0, 1.0)],
    now_s=0.0,
)
@given(
    others=st.lists(_other, min_size=0, max_size=3),
    sites=st.lists(st.tuples(st.floats(-6.0, 6.0), st.floats(1.0, 8.0)), min_size=1, max_size=3),
    now_s=st.floats(0.0, 20.0),
)
def test_the_probe_never_reserves_and_is_what_decide_then_grants(others, sites, now_s):
    table = _fleet(others)
    before = table.reservations
    start = Place((0.0, 0.0))
    visits = [_work(x, y) for x, y in sites]
    done = soonest_done(table, "me", start, visits, now_s, AIR)
    assert table.reservations == before  # nothing reserved
    first = soonest_done(table, "me", start, visits[:1], now_s, AIR)
    got = decide(table, Request("me", start, visits[0], None), now_s, AIR)
    if isinstance(got, Grant):  # on the unchanged table: no earlier than decide grants (exactly when)
        assert first == got.plan.stay.t0_s + visits[0].duration_s
        assert got.plan.start_s >= now_s
    else:
        assert first == math.inf
    assert done >= first  # the later visits only add


# ---- the ranking's chooser


def _ranking() -> Ranking:
    starts = [(float(x), 0.0, 0.0) for x in range(6)]
    r = Ranking("critical-path", [1] * 6, starts, [0.0] * 6)
    for i in range(6):
        r.add(i, "brick")
    return r


def test_the_chooser_sees_the_policy_s_pick_first_then_the_nearest_few_and_its_answer_is_taken():
    r, seen = _ranking(), []

    def last(order):
        seen.append(list(order))
        return len(order) - 1

    assert r.pick("brick", (0.0, 0.0, 0.0)) == 0  # the policy's pick: the nearest
    assert r.pick("brick", (0.0, 0.0, 0.0), choose=last) == CHOOSE_AMONG - 1
    assert seen == [list(range(CHOOSE_AMONG))]


def test_the_chooser_never_overrides_the_policy_s_priorities():
    r = Ranking("critical-path", [2, 1, 1], [(0.0, 0.0, 0.0)] * 3, [0.0] * 3)
    for i in range(3):
        r.add(i, "brick")
    assert (
        r.pick("brick", (0.0, 0.0, 0.0), choose=lambda order: len(order) - 1) == 0
    )  # one task on top: no choice
    fifo = Ranking("fifo", [1, 1], [(5.0, 0.0, 0.0), (0.0, 0.0, 0.0)], [0.0, 0.0])
    fifo.add(0, "brick")
    fifo.add(1, "brick")
    assert fifo.pick("brick", (0.0, 0.0, 0.0), choose=lambda order: len(order) - 1) == 0


def test_a_chained_segment_is_kept_whatever_the_chooser_says():
    starts = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (5.0, 0.0, 0.0)]
    r = Ranking(
        "nearest", [1, 1, 1], starts, [0.0] * 3, successors=[(1,), (), ()], predecessors=[(), (0,), ()]
    )
    r.add(1, "adhesion")
    r.add(2, "adhesion")
    assert r.pick("adhesion", (1.0, 0.0, 0.0), after=0, choose=lambda order: len(order) - 1) == 1


def test_a_uav_still_flying_to_its_stay_is_probed_from_when_it_is_there():
    """As decide plans it: from its stay's start."""
    table = _fleet([])
    w = _work(3.0, 3.0)
    got = decide(table, Request("me", Place((0.0, 0.0)), w, Place((0.0, 0.0))), 0.0, AIR)
    assert isinstance(got, Grant)
    back_s = got.plan.stay.t0_s
    assert soonest_done(got.table, "me", Place((0.0, 0.0)), [w], 0.0, AIR) > back_s


# ---- mission control under the table


def _spy(monkeypatch) -> list[tuple[str, tuple[str, ...], int, float]]:
    """Record every choice mission control makes by the table: (UAV, candidates, index taken, when)."""
    seen: list[tuple[str, tuple[str, ...], int, float]] = []
    choose = table_dispatch.choose

    def spy(mc, c, uav, ids):
        k = choose(mc, c, uav, ids)
        seen.append((uav, tuple(ids), k, c.now_s))
        return k

    monkeypatch.setattr(table_dispatch, "choose", spy)
    return seen


def test_under_the_table_a_uav_is_given_the_task_it_can_finish_soonest_not_the_policy_s_nearest(monkeypatch):
    """The 12 m wall's first course is long: two brick UAVs take bricks the policy ranks alike, and at least once
    the table's soonest finish is not the policy's pick (the nearest); that task is the one the UAV is given."""
    seen = _spy(monkeypatch)
    r = simulate(running_bond(2, 6, brick_uavs=2, adhesion_uavs=1), seed=1, airspace="table")
    assert r.completed and r.conflict_violations == 0 and r.min_separation_m > 1.0
    given = {(a.uav, a.task_id, a.start_s) for a in r.attempts}
    other = [(u, ids[k], t) for u, ids, k, t in seen if k != 0]
    assert other, "the table never chose another task than the policy's"
    assert any(choice in given for choice in other)


def test_under_the_columns_or_switched_off_the_table_is_never_asked(monkeypatch):
    seen = _spy(monkeypatch)
    r = simulate(running_bond(2, 3, brick_uavs=2, adhesion_uavs=1), seed=1)
    assert r.completed and not seen
    r = simulate(
        running_bond(2, 3, brick_uavs=2, adhesion_uavs=1), seed=1, airspace="table", table_dispatch="policy"
    )
    assert r.completed and not seen


def test_the_table_dispatch_option_changes_which_task_a_uav_is_given():
    """``simulate(..., table_dispatch=...)``, no global: the soonest finish (the default under the table) gives the
    brick UAVs other tasks, in another order, than the policy's pick on the same wall and seed."""
    bp = running_bond(2, 6, brick_uavs=2, adhesion_uavs=1)

    def taken(**option: str) -> list[tuple[str, str]]:
        r = simulate(bp, seed=1, airspace="table", **option)  # type: ignore[arg-type]
        assert r.completed and r.conflict_violations == 0
        return [
            (a.uav, a.task_id) for a in sorted(r.attempts, key=lambda a: a.start_s) if a.uav.startswith("b")
        ]

    soonest = taken()
    assert taken(table_dispatch="soonest") == soonest
    assert taken(table_dispatch="policy") != soonest


# ---- --policy schedule: its next few planned tasks through the same chooser (off by default: measured slower)


def _scheduled(by_table: bool):
    bp = running_bond(2, 4)
    bp = with_fleet(bp, fleet_for(bp, 2, 1))
    order = {"brick-1": ("B0", "B1", "B2", "B3"), "brick-2": (), "glue-1": ()}
    uavs = tuple(
        UavSchedule(n, r, tuple(ScheduledTask(t, float(k), k + 1.0) for k, t in enumerate(order[n])))
        for n, r in (("brick-1", "brick"), ("brick-2", "brick"), ("glue-1", "adhesion"))
    )
    s = OfflineSchedule(uavs, 4.0, 0.0, "none", "feasible", 0.0, "none", "site", 0.0, 0, 0.1)
    d = make_dispatcher(make_plan(bp), bp.fleet, "schedule", schedule=s, reservation="site")
    assert isinstance(d, ScheduleDispatcher)
    d.by_table = by_table
    seen: list[list[str]] = []
    d.soonest = lambda uav, ids: (seen.append(list(ids)), len(ids) - 1)[1]
    return d, seen


def test_the_schedule_policy_asks_the_chooser_among_its_next_planned_tasks_only_when_told():
    d, seen = _scheduled(by_table=False)
    assert [a.task_id for a in d.assign() if a.uav == "brick-1"] == ["B0"] and not seen
    d, seen = _scheduled(by_table=True)
    assert [a.task_id for a in d.assign() if a.uav == "brick-1"] == ["B3"]
    assert seen[0] == ["B0", "B1", "B2", "B3"]  # its own next ones, in the schedule's order
