"""The ``flown`` physical term (masonry.planner.schedule_flown, issue 27): a site visit and a task as the state
machines fly them, recomputed here from the machines' phases and the runtime's layer 0."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.fsm.battery import LEG_SETTLE_S
from masonry.mission.altitudes import layer_base_m
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.planner import plan as make_plan
from masonry.planner.bounds import min_durations_s
from masonry.planner.schedule import solve_schedule
from masonry.planner.schedule_flown import brick_extra_s, brick_visit, layer0_m
from masonry.planner.schedule_physical import physical_terms
from masonry.planner.tasks import BrickTask
from masonry.timing import DEFAULT_TIMING

#: a timing other than the default, so no default constant can stand in for a derived one
TIMING = replace(
    DEFAULT_TIMING, vertical_speed_mps=0.6, cruise_speed_mps=1.4, descent_duration_s=5.0, release_dwell_s=0.8
)


def _leg_s(d_m: float, peak_mps: float) -> float:
    """A rest-to-rest minimum-jerk leg: mean speed = peak / 1.875, at least 1 s."""
    return max(1.0, d_m / (peak_mps / 1.875))


def _settled_s(d_m: float, peak_mps: float) -> float:
    return _leg_s(d_m, peak_mps) + LEG_SETTLE_S if d_m > 1e-9 else 0.0


def _placing_s(drop_m: float, radius_m: float, t_f: float) -> float:
    """When the placing descent's minimum-jerk reference is within ``radius_m`` of its end (a fine scan)."""
    n = 200_000
    for k in range(n + 1):
        tau = k / n
        if drop_m * (1.0 - (10 * tau**3 - 15 * tau**4 + 6 * tau**5)) <= radius_m:
            return t_f * tau
    return t_f


def test_the_brick_visit_is_its_flown_phases():
    bp = running_bond(9, 4, placed_courses=1)
    p = make_plan(bp)
    layer = layer_base_m(bp, timing=TIMING)  # the runtime's layer 0 (masonry.mission.altitudes)
    assert layer0_m(p.tasks, TIMING, bp.cruise_altitude_m) == pytest.approx(layer)
    eff_z = TIMING.effector_offset_m[2]
    slack = 2 * TIMING.arrive_tolerance_m + math.hypot(*TIMING.effector_offset_m[:2])
    descents = 0
    for t in p.tasks:
        if not isinstance(t, BrickTask) or t.done:
            continue
        h = t.size_m[2]
        top = t.position_m[2] + h / 2.0
        carry = max(bp.cruise_altitude_m, top - eff_z + h + TIMING.clearance_m)  # over the drop-off
        release = top - eff_z  # the body at the release
        want = {
            "flight_in_s": _leg_s(bp.clearance_m - slack, TIMING.cruise_speed_mps),
            "layer_descent_s": _settled_s(layer - carry, TIMING.vertical_speed_mps),
            "align_s": 1.0,
            "placing_s": _placing_s(carry - release, TIMING.placement_radius_m, TIMING.descent_duration_s),
            "release_s": TIMING.release_dwell_s + TIMING.control_period_s,
            "climb_out_s": _settled_s(
                max(layer, carry) - release - TIMING.placement_radius_m, TIMING.vertical_speed_mps
            ),
        }
        v = brick_visit(t, TIMING, bp.cruise_altitude_m, layer, bp.clearance_m)
        for name, s in want.items():
            assert getattr(v, name) == pytest.approx(s, abs=1e-3), (t.id, name)
        assert v.total_s == pytest.approx(sum(want.values()), abs=5e-3)
        descents += want["layer_descent_s"] > 0
        # the task: its minimum, its climbs to the layer and its descent from it each settled
        pickup = t.pickup_m if t.pickup_m is not None else t.position_m
        grasp = max(pickup[2] + h / 2.0, h) - TIMING.grasp_press_m - eff_z
        hi = max(layer, carry)
        flown_climbs = (
            _settled_s(hi - grasp, TIMING.vertical_speed_mps)
            + _settled_s(hi - carry, TIMING.vertical_speed_mps)
            + _settled_s(hi - release - TIMING.placement_radius_m, TIMING.vertical_speed_mps)
        )
        min_climbs = _leg_s(carry - grasp, TIMING.vertical_speed_mps) + _leg_s(
            carry - release - TIMING.placement_radius_m, TIMING.vertical_speed_mps
        )
        extra = brick_extra_s(t, TIMING, bp.cruise_altitude_m, layer)
        assert extra == pytest.approx(flown_climbs - min_climbs, abs=1e-6)
        assert extra >= 2 * LEG_SETTLE_S
    assert descents > 0  # the lower courses are worked from above layer 0's carry altitude


def test_flown_is_named_on_its_own():
    assert physical_terms("all") == ("pallet", "battery", "visit")
    assert physical_terms("all+flown") == ("pallet", "battery", "visit", "flown")
    assert physical_terms("flown") == ("flown",)


def test_a_flown_schedule_gives_each_brick_its_flown_visit_and_task():
    bp0 = running_bond(3, 5, placed_courses=1)
    bp = with_fleet(bp0, fleet_for(bp0, 2, 1))
    p = make_plan(bp)
    kw = {"cruise_altitude_m": bp.cruise_altitude_m, "clearance_m": bp.clearance_m, "reservation": "site"}
    kw.update(time_limit_s=5.0, workers=1, seed=0)
    s = solve_schedule(p, bp.fleet, physical="flown", timing=TIMING, **kw)
    visit = solve_schedule(p, bp.fleet, physical="visit", timing=TIMING, **kw)
    assert s.physical == ("flown",)
    md = min_durations_s(p, timing=TIMING, cruise_altitude_m=bp.cruise_altitude_m)
    layer = layer_base_m(bp, timing=TIMING)
    by_id = {t.id: t for t in p.tasks}
    tick = s.tick_s
    seen = 0
    for u in s.uavs:
        for st in u.tasks:
            t = by_id[st.id]
            if not isinstance(t, BrickTask):
                continue
            seen += 1
            want = brick_visit(t, TIMING, bp.cruise_altitude_m, layer, bp.clearance_m).total_s
            assert st.site_start_s is not None and st.site_end_s is not None
            assert st.site_end_s - st.site_start_s >= want - tick - 1e-6
            extra = brick_extra_s(t, TIMING, bp.cruise_altitude_m, layer)
            assert st.end_s - st.start_s >= md[t.id] + extra - 2 * tick - 1e-6
    assert seen == sum(isinstance(t, BrickTask) and not t.done for t in p.tasks)
    assert s.makespan_s > visit.makespan_s


def test_cli_writes_the_flown_term():
    case_study = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
    args = ["schedule", str(case_study), "--workers", "1", "--format", "json", "--time-limit", "5"]
    runner = CliRunner()
    res = runner.invoke(app, [*args, "--physical", "all+flown"])
    assert res.exit_code == 0, res.output
    flown = json.loads(res.stdout)
    assert flown["physical"] == ["pallet", "battery", "visit", "flown"]
    res = runner.invoke(app, [*args, "--physical", "all"])
    assert res.exit_code == 0, res.output
    floor = json.loads(res.stdout)
    assert floor["physical"] == ["pallet", "battery", "visit"]
    assert flown["makespan_s"] > floor["makespan_s"]
