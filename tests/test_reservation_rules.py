"""The reservation table's rules (docs/safety.md, "The reservation table's rules"): one named scenario per rule,
written as a table in the scenario language of tests/reservation_scenario.py (UAVs on pads, clock steps, requests,
the grants, waits and moves expected). Every step also re-checks the table's invariants (no two UAVs' reservations
clash; every UAV holds exactly one open-ended reservation, its last). The random-sequence invariant test is
tests/test_reservation_invariants.py."""

from __future__ import annotations

import math
import re
from dataclasses import replace
from pathlib import Path

import pytest

from masonry.errors import PlanningError
from masonry.geofence import Site
from masonry.reservation import (
    Airspace,
    Fence,
    Grant,
    Hold,
    Place,
    Request,
    Reservation,
    Table,
    Wait,
    Work,
    decide,
    layout_problems,
    leg,
    pad,
    start_table,
)
from reservation_scenario import LAYERS_M, Scenario, play

SAFETY_MD = Path(__file__).resolve().parent.parent / "docs" / "safety.md"


def _of(s: Scenario, uav: str, purpose: str, nth: int = 0) -> Reservation:
    """``uav``'s ``nth`` reservation for ``purpose``, by start time."""
    return [r for r in s.table.of(uav) if r.purpose == purpose][nth]


def test_rule_separation_in_space_and_time() -> None:
    # one layer: b's flight crosses a's, so it leaves its pad later, and its leg starts just as a's ends
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                    | expect
        0   | a   | fly to (10, 4) work 20  | granted now layer 0
        0   | b   | fly to (0, 4) work 20   | granted at 22.2 layer 0
        """,
        layers_m=LAYERS_M[:1],
    )
    assert _of(s, "b", "transit").t0_s == pytest.approx(_of(s, "a", "transit").t1_s)  # half-open windows
    # the table itself refuses a clash, naming both
    crossing = Reservation("c", leg((5.0, -5.0), (5.0, 5.0), 2.5), 20.0, 30.0, "transit")
    with pytest.raises(PlanningError, match=r"c's transit from 20\.0 s to 30\.0 s clashes with a's transit"):
        s.table.add(crossing)
    s.table.add(crossing.shifted(120.0))  # the same space once a and b have passed: no clash
    layer_up = leg((5.0, -5.0), (5.0, 5.0), 2.5 + 1.1)
    s.table.add(Reservation("c", layer_up, 20.0, 30.0, "transit"))  # the same time a layer up: no clash


def test_rule_a_landed_uav_holds_only_its_pad() -> None:
    # pads 1.05 m apart: a takes off beside b, landed (the pad separation, 1.0 m) ...
    play(
        {"a": (0, 0), "b": (1.05, 0)},
        """
        t_s | uav | does                    | expect
        0   | a   | fly to (-5, 5) work 20  | granted now layer 0
        """,
    )
    # ... but two airborne UAVs keep 1.2 m: b takes off once a's climb beside its pad and the start of its leg
    # (within 1.2 m of b's column) are over
    s = play(
        {"a": (0, 0), "b": (1.05, 0)},
        """
        t_s | uav | does                    | expect
        0   | a   | fly to (-5, 5) work 20  | granted now layer 0
        0   | b   | fly to (6, 5) work 20   | granted later
        """,
    )
    assert _of(s, "b", "climb").t0_s == pytest.approx(_of(s, "a", "transit").t1_s)
    assert _of(s, "b", "stay").volume == pad((1.05, 0.0))  # on its pad until then


def test_rule_a_flight_is_reserved_whole_with_its_margin() -> None:
    s = play(
        {"a": (0, 0)},
        """
        t_s | uav | does                   | expect
        0   | a   | fly to (6, 8) work 20  | granted now layer 0
        """,
    )
    plan = s.plans["a"].reservations
    assert " ".join(r.purpose for r in plan) == "climb transit descend work climb transit descend stay"
    climb, transit, work = plan[0], plan[1], plan[3]
    # minimum-jerk legs at TaskTiming's peak speeds (2.5 m at 0.4 m/s, 10 m at 1 m/s), each window 2 s longer
    assert climb.t1_s - climb.t0_s == pytest.approx(1.875 * 2.5 / 0.4 + 2.0)
    assert transit.t0_s == pytest.approx(1.875 * 2.5 / 0.4)  # the next leg starts when the last one is flown
    assert transit.t1_s - transit.t0_s == pytest.approx(18.75 + 2.0)
    assert work.t1_s - work.t0_s == pytest.approx(20.0 + 2.0)
    assert all(r.t1_s > r.t0_s for r in plan)  # reserved before it is flown, all of it
    first = s.table.of("a")[0]  # its pad until it leaves (at 0 s: kept, empty, as the mark of its departure)
    assert (first.purpose, first.volume, first.t0_s, first.t1_s) == ("stay", pad((0.0, 0.0)), 0.0, 0.0)


def test_rule_earliest_start_then_lowest_layer() -> None:
    # four layers: b crosses a's path one layer up and leaves now, rather than at 22.2 s on layer 0; c, in nobody's
    # way, flies at the lowest; d works 3 m up, over layer 0 (2.5 m): the lowest it may use is layer 1
    play(
        {"a": (0, 0), "b": (10, 0), "c": (20, 0), "d": (30, 0)},
        """
        t_s | uav | does                    | expect
        0   | a   | fly to (10, 4) work 20  | granted now layer 0
        0   | b   | fly to (0, 4) work 20   | granted now layer 1
        0   | c   | fly to (20, 4) work 20  | granted now layer 0
        0   | d   | fly to (30, 4) z 3 work 20  | granted now layer 1
        """,
    )


#: An L-shaped site (its notch x > 6, y > 6 outside), 4.5 m high: layers 0 and 1 (2.5, 3.6 m) keep 0.5 m under it,
#: layer 2 (4.7 m) does not
L_SITE = Site(((-2.0, -2.0), (12.0, -2.0), (12.0, 6.0), (6.0, 6.0), (6.0, 12.0), (-2.0, 12.0)), 4.5)


def test_no_flight_with_a_leg_outside_the_fence_is_granted() -> None:
    # rule 4 with a fence: c's flight crosses a's (layer 0) and b's (layer 1): it would take layer 2 now, over the
    # fence's ceiling; it takes a lower layer later. A flight whose straight leg cuts the notch, or to a site
    # outside, is never granted (no layer keeps it inside)
    s = play(
        {"a": (0, 0), "b": (10, 0), "c": (5, -1.5)},
        """
        t_s | uav | does                    | expect
        0   | a   | fly to (10, 4) work 20  | granted now layer 0
        0   | b   | fly to (0, 4) work 20   | granted now layer 1
        0   | c   | fly to (5, 8) work 20   | granted later
        """,
        fence=Fence(L_SITE),
    )
    assert s.plans["c"].layer_m in LAYERS_M[:2]
    assert all(r.volume.z1_m <= 4.0 for u in "abc" for r in s.table.of(u))
    script = """
        t_s | uav | does                    | expect
        0   | c   | fly to (5, 8) work 20   | granted now layer 2
    """
    play(
        {"a": (0, 0), "b": (10, 0), "c": (5, -1.5)},
        script.replace(
            "0   | c",
            "0   | a   | fly to (10, 4) work 20  | -\n0 | b | fly to (0, 4) work 20 | -\n0   | c",
            1,
        ),
    )
    play(
        {"a": (0, 0), "d": (10, 4.5)},
        """
        t_s | uav | does                    | expect
        0   | d   | fly to (5, 11) work 20  | waits outside the fence
        0   | a   | fly to (20, 1) work 20  | waits outside the fence
        0   | a   | fly to (5, 11) work 20  | granted now layer 0
        """,
        fence=Fence(L_SITE),
    )
    # without the fence the cut is flown
    play({"d": (10, 4.5)}, "t_s | uav | does | expect\n0 | d | fly to (5, 11) work 20 | granted now layer 0")


def test_a_silent_uavs_way_home_keeps_inside_the_fence_where_a_layer_does() -> None:
    # the setting of rule 10's test on two layers under a 4.2 m ceiling (b then flies on to (-1, 9), clear of a's
    # site): a's way home is clear of b at 4.7 m, over the ceiling; it is reserved at 2.5 m, inside, and b's plan (not under way) moves. Before (as with no
    # fence), the way home took the lowest layer clear of everyone, over the ceiling. Where no layer keeps it
    # inside (a 2.8 m ceiling from when a falls silent: both over it) it is reserved all the same, at the lowest
    # layer clear of everyone: it cannot wait
    script = """
        t_s   | uav | does                             | expect
        0     | a   | fly to (5, 5) work 10 then site  | granted now
        0     | b   | park (2.5, 2.5)                  | -
        0     | b   | fly to (-1, 9) work 10           | -
    """
    box = ((-5.0, -5.0), (15.0, -5.0), (15.0, 15.0), (-5.0, 15.0))
    for ceiling_m, layer_m, moved in ((None, 4.7, ()), (4.2, 2.5, ("b",)), (2.8, 4.7, ())):
        s = play({"a": (0, 0), "b": (10, 0)}, script, layers_m=(2.5, 4.7), fence=Fence(Site(box, 4.2)))
        fence = None if ceiling_m is None else Fence(Site(box, ceiling_m))
        s.fence = fence  # (b's plans, at 2.5 m under the 4.2 m ceiling, the same in each)
        s.at(48.5).silent("a").moved(*moved)
        home = s.plans["a"]
        assert home.layer_m == layer_m, (ceiling_m, home.layer_m)
        inside = fence is None or all(fence.admits(r.volume, r.purpose) for r in home.reservations)
        assert inside == (ceiling_m != 2.8), ceiling_m


def test_rule_every_plan_ends_where_the_uav_may_stay() -> None:
    # a stays at its site, then flies to a parking spot, then home; each plan starts where the last one ended,
    # once the UAV is there (not before: the next flight from the site is granted from its arrival, 32.0 s)
    s = play(
        {"a": (0, 0)},
        """
        t_s | uav | does                             | expect
        0   | a   | fly to (5, 5) work 10 then site  | granted now
        0   | a   | park (0, -3)                     | granted at 32.0
        40  | a   | home                             | granted at 68.45
        """,
    )
    stays = [r for r in s.table.of("a") if r.purpose == "stay"]
    assert [r.volume for r in stays] == [
        pad((0.0, 0.0)),
        Work((5.0, 5.0), 1.0, 10.0).zone(),
        pad((0.0, -3.0)),
        pad((0.0, 0.0)),
    ]
    assert [r.open_ended for r in stays] == [False, False, False, True]
    assert all(
        p.t1_s == q.t0_s
        for p, q in zip(stays[:-1], [r for r in s.table.of("a") if r.purpose == "climb"], strict=True)
    )


def test_rule_a_waiting_uav_holds_only_where_it_stays() -> None:
    # b's site is 0.5 m from a's: its flight fits from 134.5 s, beyond the 60 s horizon: it waits on its pad,
    # told until when and for whom; asked again then, it is granted
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s    | uav | does                      | expect
        0      | a   | fly to (5, 5) work 120    | granted now
        0      | b   | fly to (5.5, 5) work 20   | waits for a until 134.5
        """,
    )
    assert s.table.of("b") == (Reservation("b", pad((10.0, 0.0)), 0.0, math.inf, "stay"),)  # nothing new
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s    | uav | does                      | expect
        0      | a   | fly to (5, 5) work 120    | granted now
        0      | b   | fly to (5.5, 5) work 20   | waits for a until 134.5
        134.5  | b   | fly to (5.5, 5) work 20   | granted now
        """,
    )
    assert _of(s, "b", "descend").t0_s >= _of(s, "a", "work").t1_s  # it comes down once a's work is over
    # within the horizon the same wait is a grant with a later start, the UAV on its pad until then
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                      | expect
        0   | a   | fly to (5, 5) work 120    | granted now
        0   | b   | fly to (5.5, 5) work 20   | granted at 134.5
        """,
        horizon_s=1000.0,
    )
    assert s.table.of("b")[0].volume == pad((10.0, 0.0)) and s.table.of("b")[0].t1_s == pytest.approx(
        134.5, abs=0.05
    )
    # while a's stay at its site is in the way, the wait has no end: until they leave
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                             | expect
        0   | a   | fly to (5, 5) work 10 then site  | granted now
        40  | b   | fly to (5.5, 5) work 20          | waits for a until they leave
        """,
    )
    assert [r.purpose for r in s.table.of("b")] == ["stay"]  # a wait reserves nothing


def test_a_hold_keeps_take_offs_on_the_ground_not_the_uavs_in_the_air() -> None:
    # rule 6 with holds: the operator's pause holds every take-off, named, until it is lifted; a wind grounding of
    # a lets a in the air fly home, then keeps it on its pad; b is not held by a's
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                             | expect
        0   | *   | hold operator                    | -
        0   | a   | fly to (5, 5) work 20 then site  | waits until they leave held operator
        0   | b   | fly to (8, 5) work 20            | waits held operator
        10  | *   | lift operator                    | -
        10  | a   | fly to (5, 5) work 20 then site  | granted now
        60  | a   | hold wind                        | -
        60  | a   | home                             | granted now
        60  | b   | fly to (8, 5) work 20            | granted
        100 | a   | fly to (2, 5) work 20            | waits held wind
        """,
    )
    assert [r.purpose for r in s.table.of("a")][-1] == "stay" and s.table.of("a")[-1].volume == pad(
        (0.0, 0.0)
    )
    assert [(h.cause, h.t0_s, h.t1_s) for h in s.table.holds] == [("wind", 60.0, math.inf)]
    # a hold with an end (a forecast): the take-off starts as it ends, within the horizon; one that starts after
    # the flight would leave does not touch it; a flight that fits only inside a later hold starts after it
    table = start_table({"a": (0.0, 0.0), "b": (10.0, 0.0)})
    fly = Request("a", Place((0.0, 0.0)), Work((5.0, 5.0), 1.0, 20.0), Place((0.0, 0.0)))
    air = Airspace(LAYERS_M)
    held = replace(table, holds=(Hold("wind", 0.0, 30.0, frozenset({"a"})),))
    got = decide(held, fly, 0.0, air)
    assert isinstance(got, Grant) and got.plan.start_s == 30.0
    later = replace(table, holds=(Hold("operator", 20.0, 50.0),))
    got = decide(later, fly, 0.0, air)
    assert isinstance(got, Grant) and got.plan.start_s == 0.0
    b_first = decide(
        later, replace(fly, uav="b", start=Place((10.0, 0.0)), stay=Place((10.0, 0.0))), 0.0, air
    )
    assert isinstance(b_first, Grant)
    crossing = Request("a", Place((0.0, 0.0)), Work((10.0, 4.0), 1.0, 20.0), Place((0.0, 0.0)))
    one_layer = Airspace(LAYERS_M[:1], horizon_s=1000.0)
    free_at = decide(b_first.table, crossing, 0.0, one_layer)
    assert isinstance(free_at, Grant) and 0.0 < free_at.plan.start_s < 50.0
    got = decide(
        replace(b_first.table, holds=(Hold("operator", 0.0, free_at.plan.start_s + 1.0),)),
        crossing,
        0.0,
        one_layer,
    )
    assert isinstance(got, Grant) and got.plan.start_s == free_at.plan.start_s + 1.0
    wait = decide(replace(table, holds=(Hold("operator", 0.0),)), fly, 0.0, air)
    assert (
        isinstance(wait, Wait) and wait.cause == "operator" and "operator holds every UAV" in wait.describe()
    )


def test_rule_the_site_rule_holds_on_site_intervals() -> None:
    # sites 1.5 m apart: the air separation (1.2 m) lets both work at once ...
    play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                                 | expect
        0   | a   | fly to (5, 5) work 30 task A0        | granted now
        0   | b   | fly to (6.5, 5) work 30 task B0      | granted now
        """,
    )
    # ... the paper's rule with r_c = 1.8 m does not: b comes down once a's site interval is over
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                                  | expect
        0   | a   | fly to (5, 5) work 30 rc 1.8 task A0   | granted now
        0   | b   | fly to (6.5, 5) work 30 rc 1.8 task B0 | granted later
        """,
    )
    a_site, b_site = _of(s, "a", "site"), _of(s, "b", "site")
    assert (a_site.task, b_site.task) == ("A0", "B0")
    assert a_site.t0_s == pytest.approx(_of(s, "a", "descend").t0_s)  # from the descent ...
    assert a_site.t1_s == pytest.approx(_of(s, "a", "work").t1_s)  # ... to the work's end (and its margin)
    assert b_site.t0_s == pytest.approx(a_site.t1_s) == pytest.approx(_of(s, "b", "descend").t0_s)


def test_rule_a_late_uav_moves_later_plans_visibly() -> None:
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                      | expect
        0   | a   | fly to (5, 5) work 30     | granted now
        0   | b   | fly to (5.5, 5) work 20   | granted at 44.5
        42  | a   | late 25                   | moves b
        """,
    )
    assert _of(s, "a", "work").t1_s == pytest.approx(64.0 + 25.0, abs=0.05)  # its window under way ends later
    b_climb = _of(s, "b", "climb")
    assert b_climb.t0_s > 44.5 and _of(s, "b", "stay").t1_s == pytest.approx(
        b_climb.t0_s
    )  # b waits on its pad
    assert all(m.after.t0_s >= m.before.t0_s and m.after.t1_s >= m.before.t1_s for m in s.moves)  # only later


def test_rule_a_plan_under_way_never_moves() -> None:
    # b left its pad at 1.0 s; its way back passes over a's site after a has left it. a, late at its site, waits
    # there (its work window lengthens) until b has passed: b's plan does not move
    s = play(
        {"a": (0, 0), "b": (20, -10)},
        """
        t_s | uav | does                                   | expect
        0   | a   | fly to (5, 5) work 30                  | granted now
        0   | b   | fly to (20, 10) work 20 then (-10, 0)  | granted at 1.0
        40  | a   | late 30                                | moves nobody
        """,
        layers_m=LAYERS_M[:1],
    )
    b_transit = _of(s, "b", "transit", 1)
    assert _of(s, "a", "climb", 1).t0_s == pytest.approx(b_transit.t1_s)
    assert _of(s, "a", "work").t1_s == pytest.approx(b_transit.t1_s + 2.0)  # it climbs out as b has passed
    assert b_transit.t0_s == pytest.approx(84.3, abs=0.05)  # as granted
    # where a would have to wait in the air, the change is refused and the table stays as it was
    play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                      | expect
        0   | a   | fly to (5, 5) work 30     | granted now
        0   | b   | fly to (5.5, 5) work 20   | granted at 44.5
        50  | a   | late 30                   | refused clash and neither can move
        """,
    )


def test_rule_a_silent_uavs_way_home_is_reserved() -> None:
    # a stays at its site; b parks under a's way home and is to leave from there at 53.5 s. a falls silent at
    # 48.5 s: its way home is reserved from then, and b's plan (not under way) moves: b stays parked until a passed
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s   | uav | does                             | expect
        0     | a   | fly to (5, 5) work 10 then site  | granted now
        0     | b   | park (2.5, 2.5)                  | granted at 15.3
        0     | b   | fly to (8, 8) work 10            | granted at 53.5
        48.5  | a   | silent                           | moves b
        """,
        layers_m=LAYERS_M[:1],
    )
    home = s.plans["a"]
    assert home.start_s == 48.5 and home.stay.volume == pad((0.0, 0.0)) and home.stay.open_ended
    assert [r.purpose for r in home.reservations] == ["home", "home", "home", "stay"]
    b_climb = _of(s, "b", "climb", 1)
    assert b_climb.t0_s >= home.reservations[1].t1_s - 1e-9  # b climbs out once a's leg over it is over
    assert _of(s, "b", "stay", 1).t1_s == pytest.approx(b_climb.t0_s)  # and waits for it on the ground


def test_rule_a_lost_uavs_last_volume_stays_reserved() -> None:
    # b is granted a flight to beside a's site from 24.5 s; a is lost there at 5 s: b's plan (not under way) is
    # withdrawn and b stays on its pad; its request waits until a is accounted for (found at 50 s, on its pad)
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                             | expect
        0   | a   | fly to (5, 5) work 10            | granted now
        0   | b   | fly to (5.5, 5) work 10          | granted at 24.5
        5   | a   | lost (5, 5)                      | moves b
        10  | b   | fly to (5.5, 5) work 10          | waits for a until they leave
        50  | a   | found                            | -
        50  | b   | fly to (5.5, 5) work 10          | granted now
        """,
    )
    assert [r.purpose for r in s.table.of("a")][-2:] == ["lost", "stay"] and _of(s, "a", "lost").t1_s == 50.0
    # a plan under way that needs the lost UAV's space is refused, the table as it was
    play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                      | expect
        0   | b   | fly to (5.5, 5) work 10   | granted now
        5   | a   | lost (5, 5)               | refused clash and neither can move
        """,
    )


def test_rule_a_uav_at_a_site_can_always_go_home() -> None:
    # a and b stay at sites 2 m apart and each asks for a site beside the other: a cycle of waits, neither ends
    # by itself. Either one's flight home is granted (its climb is in its own column, its leg over every stay,
    # its pad out of everyone's way), and then the other's request is
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                             | expect
        0   | a   | fly to (5, 5) work 10 then site  | granted now
        0   | b   | fly to (7, 5) work 10 then site  | granted now
        60  | a   | fly to (7.5, 5) work 10          | waits for b until they leave
        60  | b   | fly to (4.5, 5) work 10          | waits for a until they leave
        60  | b   | home                             | granted now
        60  | a   | fly to (7.5, 5) work 10          | granted now
        """,
    )
    zones = [Work(xy, 1.0, 1.0).zone() for xy in [(5.0, 5.0), (7.0, 5.0), (7.5, 5.0), (4.5, 5.0)]]
    assert layout_problems(s.pads, zones, LAYERS_M) == []  # the layout the guarantee needs


# ---- the document and the tests say the same


def _rules() -> list[tuple[str, str]]:
    """docs/safety.md's rules: (rule's first words, the test it names)."""
    text = SAFETY_MD.read_text(encoding="utf-8")
    section = text.split("### The reservation table's rules", 1)[1].split("\n### ", 1)[0]
    return re.findall(r"^\d+\. \*\*(.+?)\*\*.*?`(test_rule_\w+)`", section, flags=re.M | re.S)


def test_the_rules_fit_on_two_pages_and_each_names_its_scenario_test() -> None:
    rules = _rules()
    assert 1 <= len(rules) <= 12, [r for r, _t in rules]
    named = [t for _r, t in rules]
    tests = sorted(name for name in globals() if name.startswith("test_rule_"))
    assert sorted(named) == tests, "every rule names one test_rule_* of this module, and each is named once"


def test_a_wait_changes_nothing_and_a_grant_only_adds() -> None:
    """Under the rules: a request told to wait leaves the table as it was; a grant keeps every reservation of the
    others as it was."""
    s = play(
        {"a": (0, 0), "b": (10, 0)},
        """
        t_s | uav | does                             | expect
        0   | a   | fly to (5, 5) work 10 then site  | granted now
        """,
    )
    before: Table = s.table
    s.at(40).fly("b", to=(5.5, 5.0)).waits()
    assert s.table == before and isinstance(s.last, Wait) and math.isinf(s.last.until_s)
    s.fly("b", to=(8.0, 8.0))
    assert set(before.of("a")) == set(s.table.of("a"))
