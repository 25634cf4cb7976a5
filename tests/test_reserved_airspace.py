"""``--airspace table``: mission control grants flights from a space-time reservation table
(:mod:`masonry.mission.reserved`); ``columns`` stays the default."""

from __future__ import annotations

import dataclasses
import math
import random
from pathlib import Path

import pytest
from typer.testing import CliRunner

from airspace_rig import table_pair, table_pair_waiting_for_each_others_site
from masonry.blueprint import UavSpec, load_blueprint, validate_blueprint
from masonry.blueprint_gen import pyramid, running_bond, towers
from masonry.blueprint_random import LayoutLimits, _box, _footprint, _pallet_on, random_layout
from masonry.cli import app
from masonry.errors import InputError
from masonry.mission.airspace_state import Phase
from masonry.mission.reserved import DEFAULT_AIRSPACE, TableClearance
from masonry.mission.reserved_approach import APPROACH_OFF_M
from masonry.mission.simulate import simulate
from masonry.mission.sites import work_span_m
from masonry.planner import plan as make_plan
from masonry.reservation import Work
from masonry.segments import segment_segment_m
from masonry.separation import pad_site_distance_m

ROOT = Path(__file__).resolve().parent.parent
SEPARATION_BOUND_M = 1.0


def test_the_default_airspace_is_columns():
    assert DEFAULT_AIRSPACE == "columns"


def test_a_landed_uav_holds_its_pad_and_takes_off_with_the_column_over_it():
    air = table_pair()
    assert air.phase("a") is Phase.LANDED
    assert [v.kind for v in air.volumes("a")] == ["stay"]
    assert air.take_off("a")
    assert air.phase("a") is Phase.PARKED
    assert air.volumes("a")[0].z1_m == pytest.approx(2.0)  # up to the transit base


def test_a_flight_is_granted_as_timed_legs_ending_in_a_stay_at_the_site():
    air = table_pair()
    air.take_off("a")
    g = air.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -5.0, 1.2))
    assert g.granted and g.layer_m is not None
    kinds = [v.kind for v in air.volumes("a")]
    assert kinds[-1] == "stay" and {"climb", "transit", "descend"} <= set(kinds)
    assert air.conflicts() == []


def test_a_second_uav_for_the_same_site_waits_where_it_is_and_is_granted_once_the_site_is_free():
    air = table_pair()
    air.take_off("a")
    assert air.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    air.take_off("b")
    wait = air.request("b", (0.3, 0.0, 1.2), 0.5, (3.0, -5.0, 1.2))
    assert not wait.granted and wait.hold_m is None  # it waits on its own stay, not in shared air
    assert air.blockers("b") and air.blockers("b")[0][0] == "a"
    assert air.grant(30.0) == []  # a is still at the site (its stay is open-ended)
    air.end_transit("a")
    assert air.request("a", (0.0, -5.0, 2.0), 31.0, (0.0, 0.0, 1.2)).granted  # a flies home
    granted = []
    for t in range(32, 120):
        if t == 34:
            air.progress("a", (0.0, -2.5, 1.2))  # a says where it is: on its leg home, its climb behind it
        if t == 40:
            air.end_transit("a")  # a is over its pad, on time
        granted += [g.uav for g in air.grant(float(t))]
    assert granted == ["b"]
    assert air.forced == 0  # nobody ran late past what the table could make room for
    assert air.conflicts() == []


class _Gate:
    """A site gate that lets everyone in and records who moved on from a site."""

    def __init__(self) -> None:
        self.left_by: list[tuple[str, float]] = []

    def may_enter(self, uav, site_m):
        return True

    def entered(self, uav, site_m, now_s):
        pass

    def waited_on(self, uav):
        return ()

    def left(self, uav, now_s):
        self.left_by.append((uav, now_s))
        return True


def test_a_uav_sent_to_its_parking_spot_is_granted_its_flight_from_there_not_from_where_it_asked():
    # two UAVs each wait for the other's site (a cycle of stays): b is sent to its parking spot, a takes b's site.
    # b's flight to a's old site starts where b waits, at its spot: planned from where b asked (b's old site, a's
    # stay now) it waited for good, and granted while b still flew to its spot it was a flight from a place b was
    # not at (a UAV flew where the table reserved nothing for it: min separation 0.65 m on the 12 m wall)
    air = table_pair_waiting_for_each_others_site()
    s2 = (3.0, 0.0, 1.2)  # b's site
    granted: list[tuple[str, Phase]] = []
    spot = None
    for k in range(62, 200):
        t = k / 2.0
        for g in air.grant(t):
            if g.hold_m is not None:
                spot = g.hold_m
            granted += [(g.uav, air.phase(g.uav))] if g.granted else []
        if t == 40.0:
            air.progress("b", (3.0, -2.5, 6.4))  # on its way to its spot
        if t == 45.0:
            assert spot is not None and air.phase("b") is Phase.TO_HOLD
            air.progress("b", spot)  # there
        if t == 60.0:
            air.progress("a", s2)
            air.end_transit("a")
    assert [u for u, _p in granted] == ["a", "b"]
    climb = air.volumes("b")[0]
    assert spot is not None and climb.a == pytest.approx(spot[:2])  # from its spot
    assert air.conflicts() == []


def test_a_uav_asking_for_the_next_site_ends_its_site_interval_however_close_the_sites_are():
    # adhesion segments 0.15 m apart: closer than AT_SITE_M, yet the first task's site interval is over once its
    # UAV asks for the next one (else two UAVs could wait for each other's finished sites)
    gate = _Gate()
    air = TableClearance(0.8, 2.0, homes={"a": (0.0, -5.0, 0.0)}, start_base_m=1.2, gate=gate)
    air.take_off("a")
    assert air.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -5.0, 1.2)).granted
    air.end_transit("a")
    assert gate.left_by == []  # (its first flight: no site before it)
    assert air.request("a", (0.15, 0.0, 1.2), 20.0, (0.0, 0.0, 1.2)).granted
    assert gate.left_by == [("a", 20.0)]


def test_a_leg_flies_at_the_lowest_layer_even_under_the_works_top():
    air = table_pair()
    air.take_off("a")
    # hovering 4 cm over the lowest layer (1.2 m), off to a pickup worked up to 2.1 m: the leg flies at 1.2 m
    g = air.request("a", (0.0, 0.0, 1.2), 0.0, (0.0, -5.0, 1.24), top_m=2.1)
    assert g.granted and g.layer_m == pytest.approx(1.2)


def test_a_bad_airspace_is_one_clear_error():
    with pytest.raises(InputError, match="`airspace` must be one of columns, table"):
        simulate(towers(1, 2), airspace="tubes")
    res = CliRunner().invoke(
        app, ["sim", str(ROOT / "blueprints" / "paper_case_study.yaml"), "--airspace", "tubes"]
    )
    assert res.exit_code == 2
    assert "--airspace must be columns or table" in res.output


def test_the_case_study_under_task_reservation_still_flies_in_the_papers_order():
    bp = load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml")
    r = simulate(bp, seed=0, reservation="task", airspace="table")
    assert r.completed
    assert [a.task_id for a in sorted(r.attempts, key=lambda a: a.start_s)] == ["A0", "B0", "A1", "B1"]
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is not None and r.min_separation_m >= SEPARATION_BOUND_M
    assert not any("hold_patience_s" in (a.reason or "") for a in r.attempts)


@pytest.mark.slow
def test_two_by_two_uavs_over_three_towers_complete_apart():
    r = simulate(
        towers(3, 2, spacing_m=1.6, brick_uavs=2, adhesion_uavs=2), reservation="task", airspace="table"
    )
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is not None and r.min_separation_m >= SEPARATION_BOUND_M
    assert math.isfinite(r.makespan_s)


def _issue_27_pyramid():
    """Issue 27's compact layout: a 21-brick pyramid (6-brick base, its first course placed), r_c 0.8 m, the
    pallet beside it (east), 3 brick + 2 adhesion UAVs on pads 1 m apart south of it all."""
    wall = pyramid(6, clearance_m=0.8, placed_courses=1)
    bricks = _pallet_on(wall.bricks, "east")
    points = [(b.pickup_m[0], b.pickup_m[1]) for b in bricks if b.pickup_m is not None]
    fx0, fx1, fy0, fy1 = _footprint(bricks)
    x0, x1, y0, _y1 = _box([*points, (fx0, fy0), (fx1, fy1)])
    names = [("brick-1", "brick"), ("brick-2", "brick"), ("brick-3", "brick"), ("glue-1", "adhesion")]
    names.append(("glue-2", "adhesion"))
    y = y0 - pad_site_distance_m(0.8)
    fleet = tuple(UavSpec(n, r, ((x0 + x1) / 2.0 + (k - 2) * 1.0, y, 0.0)) for k, (n, r) in enumerate(names))
    bp = dataclasses.replace(wall, bricks=bricks, fleet=fleet)
    validate_blueprint(bp)
    return bp


@pytest.mark.slow
def test_the_issue_27_livelock_completes_with_no_attempt_given_up_for_waiting():
    r = simulate(_issue_27_pyramid(), policy="fifo", seed=1, airspace="table")
    assert r.completed and r.stall is None
    assert not any("hold_patience_s" in (a.reason or "") for a in r.attempts)
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is not None and r.min_separation_m >= SEPARATION_BOUND_M
    # UAVs held back from their sites waited at their approach spots (mission control wires the rule in)
    approached = [t.id for t in r.tasks for w in t.waits if w.cause.holds == "approach"]
    assert approached


@pytest.mark.slow
@pytest.mark.parametrize("seed", [3, 11, 17])
def test_small_compact_random_layouts_complete_apart(seed):
    limits = LayoutLimits(max_courses=2, max_per_course=3, max_uavs_per_role=2, clearance_m=(0.5, 0.8))
    bp = random_layout(random.Random(seed), limits)
    r = simulate(bp, seed=seed, airspace="table")
    assert r.completed, r.stall
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    assert r.min_separation_m is None or r.min_separation_m >= SEPARATION_BOUND_M
    assert not any("hold_patience_s" in (a.reason or "") for a in r.attempts)


@pytest.mark.parametrize("wall", ["pyramid", "running bond", "compact pyramid"])
def test_the_stays_at_sites_already_keep_the_site_rule_apart(wall):
    # why a timed site window grants nothing sooner with the table (docs/safety.md, "The site rule and the stays at
    # sites"): two tasks closer than r_c have work zones that clash, and a UAV holds its zone, open-ended, until its
    # next flight is granted; only pairs exactly r_c apart (the planner's G^c counts them) are left to the site rule
    blueprint = {
        "pyramid": lambda: load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
        "running bond": lambda: running_bond(2, 12, placed_courses=1),
        "compact pyramid": _issue_27_pyramid,
    }[wall]()
    plan = make_plan(blueprint)
    air = TableClearance(blueprint.clearance_m, 2.0, start_base_m=1.2)
    tasks = {t.id: t for t in plan.tasks}

    def zone(task_id):
        (a, b) = work_span_m(tasks[task_id])
        return Work(a, 1.2, 0.0, b, air.zone_r_m).zone()

    at_r_c = 0
    for a, b in plan.conflicts:
        (a0, a1), (b0, b1) = work_span_m(tasks[a]), work_span_m(tasks[b])
        d = segment_segment_m(a0, a1, b0, b1)
        if d < blueprint.clearance_m - 1e-6:
            assert air.table.separation.conflict(zone(a), zone(b)), (a, b)
        else:  # (3-D within r_c, so horizontally too: exactly r_c apart)
            assert d == pytest.approx(blueprint.clearance_m, abs=1e-6), (a, b, d)
            at_r_c += 1
    assert at_r_c < 0.05 * len(plan.conflicts)


class _BusyGate(_Gate):
    """A site gate over two conflicting sites: nobody comes down at one while another UAV is at the other."""

    def __init__(self, sites) -> None:
        super().__init__()
        self.sites = sites
        self.on: dict[str, tuple[float, float, float]] = {}
        self.entered_at: list[tuple[str, float]] = []

    def may_enter(self, uav, site_m):
        return not any(o != uav and s in self.sites for o, s in self.on.items())

    def entered(self, uav, site_m, now_s):
        if site_m in self.sites:  # (a flight home starts no site interval)
            self.on[uav] = site_m
            self.entered_at.append((uav, now_s))

    def left(self, uav, now_s):
        super().left(uav, now_s)
        return self.on.pop(uav, None) is not None


def test_a_uav_held_back_far_from_its_site_waits_at_its_approach_spot_and_its_site_interval_starts_there():
    # scenario (docs/safety.md, "The approach spot"): b works at its site; a, on its pad 5 m away, is given the
    # conflicting site beside it. The site gate holds a back: a does not wait over its pad (its site interval
    # would then run through the whole 5 m flight once b is gone) but flies to the hover 1.5 m from its site
    # towards it, at the top layer, reserved like any flight; there it waits for the gate, and its site interval
    # starts when its descent is granted, once b has moved on
    s_a, s_b = (0.0, 0.0, 1.2), (0.5, 0.0, 1.2)
    gate = _BusyGate({s_a, s_b})
    homes = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0)}
    air = TableClearance(0.8, 2.0, homes=homes, start_base_m=1.2, gate=gate)
    air.work_site = lambda uav, site: site in (s_a, s_b)
    air.take_off("b")
    assert air.request("b", s_b, 0.0, (0.5, -1.5, 1.2)).granted  # near its site: straight there
    air.take_off("a")
    g = air.request("a", s_a, 1.0, (0.0, -5.0, 1.2))
    top = air.airspace.layers_m[-1]
    spot = (0.0, -APPROACH_OFF_M, top)  # (1.5 m from its site towards a)
    assert not g.granted and g.hold_m == pytest.approx(spot) and g.layer_m == pytest.approx(top)
    assert air.phase("a") is Phase.TO_HOLD and gate.entered_at == [("b", 0.0)]
    assert air.approached_count == 1
    for t in range(2, 20):
        assert not any(g.granted for g in air.grant(float(t)))
    air.end_transit("b")
    air.progress("a", spot)  # a is at its approach spot
    assert air.phase("a") is Phase.AT_HOLD
    answer = air.request("a", s_a, 20.0, spot)
    assert not answer.granted  # b is at its site: a waits where it is, at its spot
    assert air.blockers("a") == [("-", "site-rule")]
    air.request("b", (3.0, -5.0, 1.2), 30.0, s_b)  # b moves on: its site interval ends
    granted = []
    for t in range(31, 60):
        if t == 45:
            air.progress("b", (3.0, -5.0, 1.2))  # b is over its pad, its flight's windows end
            air.end_transit("b")
        granted += [(g.uav, t) for g in air.grant(float(t)) if g.granted]
    # once b has moved on: the spot is out of b's column, a's flight is timed around b's climb and leg
    assert [u for u, _t in granted] == ["a"] and granted[0][1] >= 31
    assert gate.entered_at == [("b", 0.0), ("a", float(granted[0][1]))]  # a's site interval starts then
    climb = next(r.volume for r in air.table.of("a") if r.purpose == "climb")
    assert climb.a == pytest.approx(spot[:2]) and climb.z1_m == pytest.approx(top)  # from the spot
    assert air.conflicts() == []


_SPOT_HOMES = {"a": (0.0, -5.0, 0.0), "b": (3.0, -5.0, 0.0)}


def _a_at_its_spot_for_bs_site(
    s_a: tuple[float, float, float], s_b: tuple[float, float, float], s_c: tuple[float, float, float]
) -> tuple[TableClearance, tuple[float, float, float], _BusyGate]:
    """b works at s_b (beside s_a, busy); a, asking for s_a, is sent to its approach spot and waits there (held at
    30 s); s_c is b's next site. Returns the table, a's spot and the sites' gate (homes: ``_SPOT_HOMES``)."""
    gate = _BusyGate({s_a, s_b})
    air = TableClearance(0.8, 2.0, homes=_SPOT_HOMES, start_base_m=1.2, gate=gate)
    air.work_site = lambda uav, site: site in (s_a, s_b, s_c)
    air.take_off("b")
    assert air.request("b", s_b, 0.0, (0.5, -1.5, 1.2)).granted
    air.take_off("a")
    spot = air.request("a", s_a, 1.0, (0.0, -5.0, 1.2)).hold_m
    assert spot is not None
    for t in range(2, 30):
        air.grant(float(t))
    air.end_transit("b")
    air.progress("b", s_b)
    air.progress("a", spot)
    assert not air.request("a", s_a, 30.0, spot).granted and air.phase("a") is Phase.AT_HOLD
    return air, spot, gate


def test_a_uav_at_its_approach_spot_is_beside_the_site_out_of_a_neighbours_climb():
    # scenario (docs/safety.md, "The approach spot"): a waits at its approach spot for b's site to free; b moves
    # on to a site beside a's, to work up to 3.5 m. The spot is 1.5 m from a's site, not over it, so b's climb
    # and flight pass it and are granted at once (over a's site, at any layer, the hover was in their way: a
    # cycle of waits, broken only by sending a to its parking spot 6 m up, its next site interval starting there)
    s_a, s_b, s_c = (0.0, 0.0, 1.2), (0.5, 0.0, 1.2), (0.4, 0.4, 1.2)
    air, spot, _gate = _a_at_its_spot_for_bs_site(s_a, s_b, s_c)
    assert spot == pytest.approx((0.0, -1.5, air.airspace.layers_m[-1]))  # 1.5 m towards a, at the top layer
    assert air.request("b", s_c, 31.0, s_b, top_m=3.5).granted
    assert air.held_back == 0 and air.conflicts() == []


def test_a_uav_at_its_approach_spot_in_a_cycle_of_waits_is_sent_to_its_parking_spot():
    # scenario (docs/safety.md, "The approach spot"): a waits at its approach spot for b's site to free; b moves
    # on to a site beside a's spot, to work up to 4 m, which the spot is in the way of, while b's stay is in the
    # way of a's descent: a cycle of waits. a, at its spot, is sent to its parking spot like any waiting
    # UAV of a cycle (b's own parking flight would climb through a's hover), and b's flight goes once a is there
    s_a, s_b, s_c = (0.0, 0.0, 1.2), (0.5, 0.0, 1.2), (0.4, -1.1, 1.2)
    air, _spot, gate = _a_at_its_spot_for_bs_site(s_a, s_b, s_c)
    assert not air.request("b", s_c, 31.0, s_b, top_m=4.0).granted
    assert air.blockers("b") == [("a", "stay")]
    parked, granted = None, []
    for k in range(64, 200):
        t = k / 2.0
        for g in air.grant(t):
            if g.uav == "a" and g.hold_m is not None:
                parked = (g.hold_m, t)
            if g.granted:
                granted.append((g.uav, t))
        if parked is not None and t == parked[1] + 20.0:
            air.progress("a", parked[0])  # a is at its parking spot
    assert parked is not None and parked[0][:2] == pytest.approx(_SPOT_HOMES["a"][:2])
    assert parked[0][2] > air.airspace.layers_m[-1]  # over every layer, over its pad
    assert granted and granted[0][0] == "b" and granted[0][1] >= parked[1]
    assert [u for u, _t in gate.entered_at] == ["b"]  # a's site interval has not started: it never came down
    assert air.conflicts() == []
