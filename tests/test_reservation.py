"""The space-time reservation model (issue 27, masonry.reservation): the unit pieces (volumes, the separation, the
table, decide, the layout condition). Its rules, one named scenario each, are in tests/test_reservation_rules.py;
its random-sequence invariants in tests/test_reservation_invariants.py."""

from __future__ import annotations

import math
import re

import pytest

from masonry.errors import InvalidArgument, PlanningError
from masonry.planner.conflicts import CONFLICT_TOLERANCE_M
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
    leg,
    pad,
    site,
    start_table,
)
from masonry.reservation.space import SITE_TOLERANCE_M, Separation
from masonry.separation import LAYER_SPACING_M, SEPARATION_XY_M, pad_separation_m
from reservation_scenario import LAYERS_M

# ---- the volumes and the separation


def test_separation_defaults_are_the_projects_numbers() -> None:
    sep = Separation()
    assert (sep.xy_m, sep.z_m, sep.pad_m) == (SEPARATION_XY_M, LAYER_SPACING_M, pad_separation_m())
    assert SITE_TOLERANCE_M == CONFLICT_TOLERANCE_M


def test_air_volumes_keep_the_horizontal_or_the_vertical_separation() -> None:
    sep = Separation()
    a = leg((0.0, 0.0), (10.0, 0.0), 2.5)
    assert sep.conflict(a, leg((5.0, -5.0), (5.0, 5.0), 2.5))  # crossing at one altitude
    assert not sep.conflict(a, leg((5.0, -5.0), (5.0, 5.0), 2.5 + LAYER_SPACING_M))  # a layer apart
    assert sep.conflict(a, leg((0.0, 1.1), (10.0, 1.1), 2.5))  # parallel, 1.1 m < 1.2 m
    assert not sep.conflict(a, leg((0.0, 1.2), (10.0, 1.2), 2.5))
    assert sep.conflict(a, leg((0.0, 1.5), (10.0, 1.5), 2.5, radius_m=0.31))  # its radius counts


def test_a_landed_uav_keeps_only_the_pad_separation() -> None:
    sep = Separation()
    beside = pad_separation_m() + 0.05  # 1.05 m: closer than the air separation
    assert not sep.conflict(pad((0.0, 0.0)), column((beside, 0.0), 0.0, 3.0))  # one takes off beside it
    assert sep.conflict(column((0.0, 0.0), 0.0, 3.0), column((beside, 0.0), 0.0, 3.0))  # two take off: no


def test_the_site_rule_is_the_papers_r_c() -> None:
    sep = Separation()
    assert sep.conflict(site((0.0, 0.0), 0.8), site((0.8, 0.0), 0.8))  # dist <= r_c conflicts
    assert not sep.conflict(site((0.0, 0.0), 0.8), site((0.81, 0.0), 0.8))
    assert sep.conflict(site((0.0, 0.0), 0.8, (0.0, 2.0)), site((0.5, 1.0), 0.8))  # an adhesion segment
    assert not sep.conflict(site((0.0, 0.0), 0.8), column((0.0, 0.0), 0.0, 3.0))  # a site holds no air
    # the 3-D distance, as the planner's G^c: a site 0.5 m over and 0.5 m beside is 0.71 m away
    assert sep.conflict(site((0.0, 0.0), 0.8, z_m=0.05), site((0.5, 0.0), 0.8, z_m=0.55))
    assert not sep.conflict(site((0.0, 0.0), 0.8, z_m=0.05), site((0.5, 0.0), 0.8, z_m=0.75))


@pytest.mark.parametrize(
    "make",
    [
        lambda: Reservation("a", pad((0.0, 0.0)), 5.0, 4.0, "stay"),
        lambda: Reservation("a", pad((0.0, 0.0)), math.inf, math.inf, "stay"),
        lambda: Reservation("", pad((0.0, 0.0)), 0.0, 1.0, "stay"),
        lambda: Reservation("a", pad((0.0, 0.0)), 0.0, 1.0, "nap"),  # type: ignore[arg-type]
        lambda: column((0.0, math.nan), 0.0, 1.0),
        lambda: column((0.0, 0.0), 0.0, 1.0, radius_m=-1.0),
        lambda: Airspace(()),
        lambda: Airspace((3.0, 2.0)),
    ],
)
def test_bad_values_are_refused(make: object) -> None:
    with pytest.raises(InvalidArgument):
        make()  # type: ignore[operator]


def test_the_table_refuses_a_clash_and_names_both() -> None:
    table = Table().add(Reservation("a", leg((0.0, 0.0), (10.0, 0.0), 2.5), 0.0, 10.0, "transit"))
    crossing = Reservation("b", leg((5.0, -5.0), (5.0, 5.0), 2.5), 5.0, 15.0, "transit")
    with pytest.raises(
        PlanningError, match=re.escape("b's transit from 5.0 s to 15.0 s clashes with a's transit")
    ):
        table.add(crossing)
    assert (
        len(table.add(crossing.shifted(5.0)).reservations) == 2
    )  # half-open windows: it may start as a ends
    assert (
        len(table.add(Reservation("a", crossing.volume, 5.0, 15.0, "transit")).reservations) == 2
    )  # its own


def test_pads_closer_than_the_pad_separation_are_refused() -> None:
    with pytest.raises(PlanningError, match="clashes"):
        start_table({"a": (0.0, 0.0), "b": (0.5, 0.0)})


def test_decide_needs_the_uav_to_hold_a_place_to_stay() -> None:
    request = Request("ghost", Place((0.0, 0.0)), Work((5.0, 5.0), 1.0, 10.0))
    with pytest.raises(PlanningError, match="ghost holds no place to stay"):
        decide(Table(), request, 0.0, Airspace(LAYERS_M))


def test_any_layer_lets_a_leg_fly_below_the_works_top() -> None:
    # a pickup worked up to 3.0 m (over the lowest layer) from a UAV hovering a little over that layer
    table = Table().add(Reservation("a", column((0.0, 0.0), 0.0, LAYERS_M[0] + 0.04), 0.0, math.inf, "stay"))
    request = Request("a", Place((0.0, 0.0), LAYERS_M[0] + 0.04, "site"), Work((6.0, 0.0), 3.0, 5.0))
    assert min(LAYERS_M) < 3.0 < max(LAYERS_M)
    strict = decide(table, request, 0.0, Airspace(LAYERS_M))
    low = decide(table, request, 0.0, Airspace(LAYERS_M, any_layer=True))
    assert isinstance(strict, Grant) and strict.plan.layer_m > 3.0
    assert isinstance(low, Grant) and low.plan.layer_m == LAYERS_M[0]
    # the descent over the site reaches from the layer up to the work's top: the column the UAV works in
    descent = next(r for r in low.plan.reservations if r.purpose == "descend")
    assert (descent.volume.z0_m, descent.volume.z1_m) == (LAYERS_M[0], 3.0)


def test_a_clash_the_table_was_given_unchecked_does_not_make_decide_raise() -> None:
    # mission control gives the table what a UAV physically holds without a check (a UAV heard again after a
    # link drop stays where it is: a column from the ground to it), which may clash with another's open-ended
    # window. Ending the stay as the flight starts only shortens it: it was re-added with a check and raised
    # "brick-2's stay from 19.4 s to 19.4 s clashes with glue-2's climb" (chaos seed 97, --airspace table;
    # its window ended a fraction of a second after it began)
    here = Reservation("a", column((0.0, 0.0), 0.0, 4.0), 19.4, math.inf, "stay")
    climb = Reservation("b", column((1.0, 0.0), 0.5, 1.5), 17.4, math.inf, "climb")
    table = Table(reservations=(here, climb))
    assert table.clashes(here) == (climb,)
    request = Request("a", Place((0.0, 0.0), 4.0, "site"), Work((8.0, 0.0), 1.0, 10.0))
    granted = decide(table, request, 20.0, Airspace(LAYERS_M))
    assert isinstance(granted, Grant) and granted.plan.start_s == pytest.approx(20.0)
    ended = [r for r in granted.table.of("a") if r.purpose == "stay" and r.t0_s == 19.4]
    assert [r.t1_s for r in ended] == [granted.plan.start_s]  # the stay ends as it sets off
    assert climb in granted.table.reservations  # nothing of b's changed
    with pytest.raises(PlanningError, match="cannot be made to end later"):
        table.ended(here.until(20.0), 30.0)


def test_decide_is_pure() -> None:
    table = start_table({"a": (0.0, 0.0)})
    request = Request("a", Place((0.0, 0.0)), Work((5.0, 5.0), 1.0, 10.0))
    first = decide(table, request, 0.0, Airspace(LAYERS_M))
    assert isinstance(first, Grant) and first == decide(table, request, 0.0, Airspace(LAYERS_M))
    assert table == start_table({"a": (0.0, 0.0)})


def test_the_packages_public_names_resolve() -> None:
    import masonry.reservation as reservation

    assert [name for name in reservation.__all__ if not hasattr(reservation, name)] == []


def test_site_volumes_conflict_exactly_as_the_planners_conflict_graph() -> None:
    """Over a real wall: every pair of G^c conflicts as site volumes, and every pair of site volumes that conflicts
    but is not in G^c is a dependent pair (the planner drops those: they never run at once anyway)."""
    import networkx as nx

    from masonry.blueprint_gen import running_bond
    from masonry.planner import plan as make_plan
    from masonry.planner.tasks import BrickTask

    bp = running_bond(3, 8, placed_courses=1)
    p = make_plan(bp)
    r_c = float(bp.clearance_m)

    def volume(t: object) -> object:
        if isinstance(t, BrickTask):
            x, y, z = t.position_m
            return site((x, y), r_c, z_m=z)
        (x0, y0, z0), (x1, y1, _z1) = t.start_m, t.end_m  # type: ignore[attr-defined]
        return site((x0, y0), r_c, (x1, y1), z_m=z0)

    g = nx.DiGraph(p.dependencies)
    conflicts = {frozenset(c) for c in p.conflicts}
    assert conflicts, "the wall has conflicts to compare"
    sep = Separation()
    vols = {t.id: volume(t) for t in p.tasks}
    ids = [t.id for t in p.tasks if not t.done]  # G^c is over the tasks still to do
    for i, a in enumerate(ids):
        for b in ids[i + 1 :]:
            ours = sep.conflict(vols[a], vols[b])  # type: ignore[arg-type]
            if frozenset((a, b)) in conflicts:
                assert ours, (a, b)
            elif ours:
                assert nx.has_path(g, a, b) or nx.has_path(g, b, a), (a, b)


def test_layout_problems_name_what_breaks_the_guarantee() -> None:
    from masonry.reservation import layout_problems

    zone = Work((5.0, 5.0), 1.0, 10.0).zone()
    assert layout_problems({"a": (0.0, 0.0), "b": (3.0, 0.0)}, [zone], LAYERS_M) == []
    problems = layout_problems(
        {"a": (0.0, 0.0), "b": (0.5, 0.0), "c": (5.0, 4.0)}, [zone], (2.0, 3.1), parking={"a": (9.0, 9.0)}
    )
    assert problems == [
        "a's pad and b's pad are closer than the pad separation 1.00 m",
        "c's pad at (5.0, 4.0) is within the separation of work zone 0 at (5.0, 5.0)",
        "layer 2.0 m is less than 1.1 m over work zone 0 (1.0 m high)",
    ]
    # a layer low enough to pass over a landed UAV within the separation: the leg would wait for it for ever
    ground = Work((5.0, 5.0), 0.0, 10.0).zone()
    assert layout_problems({"a": (0.0, 0.0)}, [ground], (1.2,)) == [
        "layer 1.2 m is less than 1.1 m over a landed UAV (0.3 m high)"
    ]


def test_an_empty_window_overlaps_nothing() -> None:
    """A stay that ended as it began (the mark of a departure) holds no instant."""
    mark = Reservation("a", column((0.0, 0.0), 0.0, 3.0), 5.0, 5.0, "stay")
    crossing = Reservation("b", leg((-5.0, 0.0), (5.0, 0.0), 2.5), 0.0, 10.0, "transit")
    assert not mark.overlaps_in_time(crossing) and not crossing.overlaps_in_time(mark)
    assert Table().add(mark, crossing).reservations == (mark, crossing)
    assert crossing.overlaps_in_time(Reservation("a", mark.volume, 9.9, 10.1, "climb"))


def test_the_airspace_flies_the_uavs_timing() -> None:
    from masonry.timing import DEFAULT_TIMING, TaskTiming

    default = Airspace.from_timing(LAYERS_M)
    assert (default.cruise_mps, default.vertical_mps) == (
        DEFAULT_TIMING.cruise_speed_mps,
        DEFAULT_TIMING.vertical_speed_mps,
    )
    assert default == Airspace(LAYERS_M)
    fast = Airspace.from_timing(LAYERS_M, TaskTiming(cruise_speed_mps=2.0, vertical_speed_mps=0.8))
    request = Request("a", Place((0.0, 0.0)), Work((6.0, 8.0), 1.0, 20.0))
    table = start_table({"a": (0.0, 0.0)})
    slow_plan = decide(table, request, 0.0, default)
    fast_plan = decide(table, request, 0.0, fast)
    assert isinstance(slow_plan, Grant) and isinstance(fast_plan, Grant)
    transit = next(r for r in fast_plan.plan.reservations if r.purpose == "transit")
    assert transit.t1_s - transit.t0_s == pytest.approx(1.875 * 10.0 / 2.0 + 2.0)
    assert fast_plan.plan.stay.t0_s < slow_plan.plan.stay.t0_s


def test_first_arrival_waits_a_little_for_a_lower_layer_rather_than_climb() -> None:
    # b crosses a's way on the lowest layer for 12 s; the next layer is free now, 1.1 m more to climb and descend
    crossing = Reservation("b", leg((3.0, -3.0), (3.0, 3.0), LAYERS_M[0]), 0.0, 12.0, "transit")
    table = start_table({"a": (0.0, 0.0)}).add(crossing)
    request = Request("a", Place((0.0, 0.0)), Work((6.0, 0.0), 1.0, 10.0))
    soonest = decide(table, request, 0.0, Airspace(LAYERS_M, horizon_s=60.0))
    first = decide(table, request, 0.0, Airspace(LAYERS_M, horizon_s=60.0, first_arrival=True))
    assert isinstance(soonest, Grant) and isinstance(first, Grant)
    assert (soonest.plan.start_s, soonest.plan.layer_m) == (0.0, LAYERS_M[1])  # rule 4: the earliest start
    assert first.plan.layer_m == LAYERS_M[0] and first.plan.start_s > 0.0  # waits on its pad, then lower
    assert first.plan.stay.t0_s < soonest.plan.stay.t0_s  # and is at its site sooner
    # a request that can start now at the lowest layer is planned alike either way
    clear = start_table({"a": (0.0, 0.0)})
    assert decide(clear, request, 0.0, Airspace(LAYERS_M, first_arrival=True)) == decide(
        clear, request, 0.0, Airspace(LAYERS_M)
    )


def test_a_wait_no_layer_ends_names_who_stays_in_the_way_of_every_layer() -> None:
    # a stays at its site (0, 0) and asks for its pad; b hovers for good across its way on the lowest layer, c waits
    # for good over a's site at the second (an approach spot): its climb to any higher layer passes c. Both are in
    # the way for good; naming only the lowest layer's (b, a landed or parked UAV with nothing to do) left c, whom
    # mission control could send to its parking spot, out of the cycle breaker's sight (issue 27's pyramid, 3 + 2,
    # --airspace table, once the swap stagger changed the trajectory: stalled 300 s)
    table = Table().add(
        Reservation("a", column((0.0, 0.0), 0.0, 1.2), 0.0, math.inf, "stay"),
        Reservation("b", column((1.5, -1.5), LAYERS_M[0], LAYERS_M[0]), 0.0, math.inf, "stay"),
        Reservation("c", column((0.3, 0.0), LAYERS_M[1], LAYERS_M[1]), 0.0, math.inf, "stay"),
    )
    request = Request("a", Place((0.0, 0.0), 1.2, "site"), None, Place((3.0, -3.0)))
    wait = decide(table, request, 10.0, Airspace(LAYERS_M))
    assert not isinstance(wait, Grant) and math.isinf(wait.until_s)
    assert sorted(r.uav for r in wait.blocked_by) == ["b", "c"]
