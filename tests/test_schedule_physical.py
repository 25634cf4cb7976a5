"""The offline schedule's physical terms (masonry.planner.schedule_physical): the pallet, the battery swaps."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, seed, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from masonry.blueprint import Blueprint, Brick, UavSpec
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.errors import PlanningError
from masonry.fsm.battery import LAND_SPEED_MPS, LAND_TOUCHDOWN_S, TAKEOFF_S
from masonry.fsm.config import UavConfig
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.planner import plan as make_plan
from masonry.planner.bounds import empty_flight_s, min_durations_s
from masonry.planner.dispatch_values import task_end_m, task_start_m
from masonry.planner.schedule import solve_schedule
from masonry.planner.schedule_chain import chain_costs
from masonry.planner.schedule_physical import (
    DEFAULT_BATTERY,
    BatteryModel,
    brick_phases,
    physical_terms,
    pickup_conflicts,
    with_visit,
)
from masonry.planner.schedule_values import schedule_from_dict
from masonry.planner.schedule_visit import visit_site
from masonry.planner.tasks import BrickTask
from masonry.sim.vehicle_config import VEHICLE_PRESETS
from masonry.timing import DEFAULT_TIMING

TOL_S = 1e-6
BRICK = (0.30, 0.15, 0.10)


def _solve(bp: Blueprint, **kw):
    p = make_plan(bp)
    kw.setdefault("time_limit_s", 10.0)
    kw.setdefault("workers", 1)
    kw.setdefault("reservation", "site")
    return p, solve_schedule(
        p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, clearance_m=bp.clearance_m, **kw
    )


def _pair_at_the_pallet() -> Blueprint:
    """Two bricks 10 m apart on the wall (no conflict) whose pickups lie 0.8 m apart (within r_c), and two brick
    UAVs at the same distance from their pickups: by hand, the plain makespan is the flight and the task, and the
    pallet holds the second pickup for the first one's descent and grasp."""
    bricks = (
        Brick(0, (-5.0, 0.0, 0.05), BRICK, 0.0, False, (-0.4, -2.0, 0.05)),
        Brick(1, (5.0, 0.0, 0.05), BRICK, 0.0, False, (0.4, -2.0, 0.05)),
    )
    fleet = (UavSpec("b1", "brick", (-1.4, -6.0, 0.0)), UavSpec("b2", "brick", (1.4, -6.0, 0.0)))
    return Blueprint(bricks=bricks, fleet=fleet, source="<test>")


def test_defaults_are_the_simulators_and_the_machines():
    cfg = UavConfig("b1", "brick", (0.0, 0.0, 0.0))
    for preset in VEHICLE_PRESETS.values():
        assert DEFAULT_BATTERY.pack_s == pytest.approx(1.0 / preset.battery_drain_per_s)
    assert DEFAULT_BATTERY.low_fraction == cfg.battery_low_fraction
    assert DEFAULT_BATTERY.swap_s == cfg.battery_swap_s
    assert (DEFAULT_BATTERY.land_speed_mps, DEFAULT_BATTERY.touchdown_s) == (LAND_SPEED_MPS, LAND_TOUCHDOWN_S)
    assert DEFAULT_BATTERY.takeoff_s == TAKEOFF_S
    assert DEFAULT_BATTERY.usable_s == pytest.approx(960.0)


def test_terms_parsed():
    assert physical_terms("") == () and physical_terms("none") == () and physical_terms(()) == ()
    assert physical_terms("all") == ("pallet", "battery", "visit")
    assert physical_terms("battery, pallet") == ("pallet", "battery")
    assert physical_terms(["battery"]) == ("battery",)
    with pytest.raises(PlanningError, match="unknown term 'wind'"):
        physical_terms("pallet,wind")


@pytest.mark.parametrize("courses,per_course", [(2, 4), (3, 6)])
def test_brick_phases_sum_to_the_minimum_duration(courses, per_course):
    bp = running_bond(courses, per_course, placed_courses=1)
    p = make_plan(bp)
    tasks = [t for t in p.tasks if not t.done]
    tick = 0.01
    md = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
    dur = [math.floor(md[t.id] / tick) for t in tasks]
    phases = brick_phases(p, tasks, dur, DEFAULT_TIMING, bp.cruise_altitude_m, tick)
    assert set(phases) == {i for i, t in enumerate(tasks) if isinstance(t, BrickTask)}
    for i, ph in phases.items():
        assert min(ph.pre, ph.pick, ph.carry, ph.site, ph.post) >= 0
        assert ph.pre + ph.pick + ph.carry + ph.site + ph.post == dur[i]
        assert ph.pick == math.floor(
            (DEFAULT_TIMING.descent_duration_s + DEFAULT_TIMING.grasp_dwell_s) / tick
        )


def test_pickup_conflicts_are_symmetric_and_within_r_c():
    bp = running_bond(3, 8, placed_courses=1)
    tasks = [t for t in make_plan(bp).tasks if not t.done]
    conf = pickup_conflicts(tasks, bp.clearance_m)
    for i, js in enumerate(conf):
        assert i not in js
        for j in js:
            assert i in conf[j]
            a, b = tasks[i], tasks[j]
            assert isinstance(a, BrickTask) and isinstance(b, BrickTask)
            assert math.dist(a.pickup_m, b.pickup_m) <= bp.clearance_m + 1e-9
    assert any(conf), "the running bond's pallet has neighbouring pickups"


@pytest.mark.parametrize("reservation", ["site", "task"])
def test_the_pallet_holds_the_second_pickup_by_its_descent_and_grasp(reservation):
    bp = _pair_at_the_pallet()
    _p, plain = _solve(bp, reservation=reservation)
    _p, pallet = _solve(bp, physical="pallet", reservation=reservation)
    assert plain.status == pallet.status == "optimal"
    pick_s = math.floor((DEFAULT_TIMING.descent_duration_s + DEFAULT_TIMING.grasp_dwell_s) / 0.01) * 0.01
    assert pallet.makespan_s == pytest.approx(plain.makespan_s + pick_s, abs=TOL_S)
    assert pallet.physical == ("pallet",) and pallet.battery_swaps == 0
    # the battery alone changes nothing here: each UAV flies one task, far within a pack
    _p, battery = _solve(bp, physical="battery", reservation=reservation)
    assert battery.makespan_s == pytest.approx(plain.makespan_s, abs=TOL_S)


def _row(n: int, pack_s: float) -> tuple[Blueprint, BatteryModel]:
    """``n`` bricks 3 m apart in a row (no conflicts, their pickups 3 m apart too), one brick UAV."""
    bricks = tuple(Brick(k, (3.0 * k, 0.0, 0.05), BRICK, 0.0, False, (3.0 * k, -2.0, 0.05)) for k in range(n))
    bp = Blueprint(bricks=bricks, fleet=(UavSpec("b1", "brick", (0.0, -4.0, 0.0)),), source="<test>")
    return bp, BatteryModel(pack_s=pack_s)


def test_a_pack_that_covers_one_task_swaps_between_every_two():
    bp, battery = _row(3, pack_s=56.0)  # 44.8 s of flight: one task of ~28 s with its legs, not two
    _p, plain = _solve(bp)
    _p, swapped = _solve(bp, physical="battery", battery=battery)
    assert plain.status == swapped.status == "optimal"
    assert swapped.battery_swaps == 2
    on_pad = battery.on_pad_s(bp.cruise_altitude_m, 0.0)
    assert swapped.makespan_s >= plain.makespan_s + 2 * on_pad - TOL_S
    (uav,) = swapped.uavs
    for w, nxt in zip(uav.swaps_s, uav.tasks[1:], strict=True):
        assert w + on_pad <= nxt.start_s + TOL_S  # the swap ends before the next task starts
    # a pack that covers the whole wall never swaps, and the schedule is the plain one
    _p, full = _solve(bp, physical="battery", battery=BatteryModel(pack_s=10_000.0))
    assert full.battery_swaps == 0 and full.makespan_s == pytest.approx(plain.makespan_s, abs=TOL_S)


def test_a_task_no_pack_covers_is_refused():
    bp, battery = _row(1, pack_s=20.0)
    with pytest.raises(PlanningError, match="does not fit in a fresh pack"):
        _solve(bp, physical="battery", battery=battery)


def test_the_default_model_is_unchanged_and_the_file_keeps_the_terms():
    bp = running_bond(2, 4, placed_courses=1)
    _p, plain = _solve(bp, time_limit_s=3.0)
    doc = plain.to_dict()
    assert "physical" not in doc and all("swaps_s" not in u for u in doc["uavs"])
    bp2, battery = _row(3, pack_s=56.0)
    _p, swapped = _solve(bp2, physical="all", battery=battery)
    back = schedule_from_dict(swapped.to_dict())
    assert back.physical == ("pallet", "battery", "visit") and back.battery_swaps == 2
    assert "physical pallet+battery+visit (2 swaps)" in swapped.summary()


def check_physical(p, fleet, s, cruise_altitude_m, battery: BatteryModel, clearance_m: float) -> None:
    """The physical terms, checked on the planned times independently of the solver: pickups within r_c
    apart, each task's parts in order, each UAV's flight between swaps within its pack."""
    tick = s.tick_s
    tasks = [t for t in p.tasks if not t.done]
    md = min_durations_s(p, cruise_altitude_m=cruise_altitude_m)
    dur = [math.floor(md[t.id] / tick) for t in tasks]
    phases = brick_phases(p, tasks, dur, DEFAULT_TIMING, cruise_altitude_m, tick)
    if (
        "visit" in s.physical
    ):  # a brick's site part is its visit: flight in from r_c, align, placing, climb out
        site = [phases[i].site if i in phases else 0 for i in range(len(tasks))]
        post = [phases[i].post if i in phases else 0 for i in range(len(tasks))]
        visit = visit_site(tasks, dur, site, post, DEFAULT_TIMING, clearance_m, tick)
        phases = {i: with_visit(ph, visit[i]) for i, ph in phases.items()}
    index = {t.id: i for i, t in enumerate(tasks)}
    planned = {t.id: t for u in s.uavs for t in u.tasks}
    pick = {}
    for tid, t in planned.items():
        i = index[tid]
        if i in phases:
            ph = phases[i]
            pick[tid] = (t.start_s + ph.pre * tick, t.start_s + (ph.pre + ph.pick) * tick)
            assert t.site_start_s >= pick[tid][1] + ph.carry * tick - TOL_S
            assert t.end_s == pytest.approx(t.site_end_s + ph.post * tick, abs=TOL_S)
    for i, js in enumerate(pickup_conflicts(tasks, clearance_m)):
        for j in js:
            a, b = pick[tasks[i].id], pick[tasks[j].id]
            assert a[1] <= b[0] + TOL_S or b[1] <= a[0] + TOL_S, (tasks[i].id, tasks[j].id)
    homes = {u.name: u.home_m for u in fleet}
    usable = math.floor(battery.usable_s / tick) * tick
    on_pad = math.ceil(battery.on_pad_s(cruise_altitude_m, 0.0) / tick - 1e-9) * tick
    chain = chain_costs(tasks, DEFAULT_TIMING, cruise_altitude_m, tick)  # the default model's chain term
    for u in s.uavs:
        home = homes[u.name]
        events = sorted([(w, "") for w in u.swaps_s] + [(t.start_s, t.id) for t in u.tasks])
        where, flown, free, prev = home, 0.0, 0.0, -1
        for at, tid in events:
            if not tid:
                assert at >= free - TOL_S
                where, flown, free, prev = home, 0.0, at + on_pad, -1
                continue
            task = p.task(tid)
            leg = math.floor(empty_flight_s(where, task_start_m(task)) / tick) * tick
            leg += chain.extra(prev, index[tid]) * tick  # an unchained segment's climb out and first descent
            assert at >= free + leg - TOL_S, (u.name, tid)
            flown += leg + dur[index[tid]] * tick
            assert flown <= usable + TOL_S, (u.name, tid, flown)
            where, free, prev = task_end_m(task), planned[tid].end_s, index[tid]


@seed(27)
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow], print_blob=True)
@given(
    per_course=st.integers(3, 6),
    bricks=st.integers(1, 3),
    pack_s=st.sampled_from([120.0, 200.0, 1200.0]),
    decomposition=st.sampled_from(["none", "course"]),
)
def test_physical_schedules_keep_every_physical_term(per_course, bricks, pack_s, decomposition):
    bp0 = running_bond(3, per_course, placed_courses=1)
    fleet = fleet_for(bp0, bricks, 1)
    bp = with_fleet(bp0, fleet)
    battery = BatteryModel(pack_s=pack_s)
    p, s = _solve(bp, physical="all", battery=battery, time_limit_s=2.0, decomposition=decomposition, seed=0)
    assert s.status in ("optimal", "feasible")
    check_physical(p, fleet, s, bp.cruise_altitude_m, battery, bp.clearance_m)


def test_cli_physical_option():
    case_study = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
    runner = CliRunner()
    res = runner.invoke(app, ["schedule", str(case_study), "--physical", "pallet,wind"])
    assert res.exit_code == 2 and "--physical" in res.stderr and "wind" in res.stderr
    res = runner.invoke(
        app, ["schedule", str(case_study), "--physical", "all", "--workers", "1", "--format", "json"]
    )
    assert res.exit_code == 0, res.output
    doc = json.loads(res.stdout)
    assert doc["physical"] == ["pallet", "battery", "visit"] and all(u["swaps_s"] == [] for u in doc["uavs"])
    res = runner.invoke(app, ["schedule", str(case_study), "--workers", "1", "--format", "json"])
    assert res.exit_code == 0 and "physical" not in json.loads(res.stdout)
