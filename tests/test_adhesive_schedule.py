"""The adhesive's deadlines in the plan, its JSON, the bound and the CP-SAT schedule (issue 31)."""

from __future__ import annotations

import dataclasses
import json
import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.cli import app
from masonry.errors import PlanningError
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.planner import plan as make_plan
from masonry.planner.bound_terms import bound_terms
from masonry.planner.bounds import min_cycles_s, min_durations_s, min_site_s
from masonry.planner.deadlines import Deadline
from masonry.planner.export import plan_json, plan_to_dict
from masonry.planner.schedule import solve_schedule
from masonry.planner.schedule_values import OfflineSchedule
from masonry.planner.tasks import Plan

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
SMALL = ROOT / "blueprints" / "running_bond_small.yaml"
runner = CliRunner()


def _glued(bp: Blueprint, open_time_s: float | None, cure_time_s: float = 0.0) -> Blueprint:
    return dataclasses.replace(bp, adhesive=Adhesive(open_time_s=open_time_s, cure_time_s=cure_time_s))


def test_case_study_deadlines_are_edges_of_the_plan() -> None:
    bp = load_blueprint(CASE_STUDY)
    assert make_plan(bp).deadlines == ()
    p = make_plan(_glued(bp, 300.0, 120.0))
    # A0 under B0 and A1 under B1; the bricks under them are pre-placed: no glue to cure there
    assert p.deadlines == (Deadline("open", "A0", "B0", 300.0), Deadline("open", "A1", "B1", 300.0))
    p = make_plan(_glued(load_blueprint(SMALL), None, 120.0))
    cures = [d for d in p.deadlines if d.kind == "cure"]
    assert cures and all(d.kind == "cure" for d in p.deadlines)
    glued = {f"B{t.above}" for t in p.tasks if t.kind == "adhesion"}
    for d in cures:
        a = p.task(d.adhesion)
        assert f"B{a.below}" == d.brick and d.brick in glued and d.lag_s == 120.0  # type: ignore[union-attr]


def test_plan_json_lists_the_deadlines_and_not_without_adhesive(tmp_path: Path) -> None:
    text = CASE_STUDY.read_text()
    path = tmp_path / "glued.yaml"
    path.write_text(text + "adhesive: {open_time_s: 90, cure_time_s: 30}\n")
    result = runner.invoke(app, ["plan", str(path), "--format", "json"])
    assert result.exit_code == 0, result.output
    doc = json.loads(result.stdout)
    assert doc["deadlines"] == [
        {"kind": "open", "adhesion": "A0", "brick": "B0", "max_lag_s": 90.0},
        {"kind": "open", "adhesion": "A1", "brick": "B1", "max_lag_s": 90.0},
    ]
    plain = runner.invoke(app, ["plan", str(CASE_STUDY), "--format", "json"])
    assert "deadlines" not in json.loads(plain.stdout)
    summary = runner.invoke(app, ["plan", str(path)])
    assert "adhesive        open time 90 s (2 edges), cure time 30 s (0 edges)" in summary.stdout
    p = make_plan(_glued(load_blueprint(SMALL), 60.0, 120.0))
    assert json.loads(plan_json(p)) == plan_to_dict(p)
    assert {d["kind"] for d in plan_to_dict(p)["deadlines"]} == {"open", "cure"}


def _check_deadlines(p: Plan, s: OfflineSchedule, cruise_altitude_m: float) -> None:
    """Every open and cure edge, on the planned times (the site part of a brick at the end of its task)."""
    site = min_site_s(p, cruise_altitude_m=cruise_altitude_m)
    times = {t.id: t for u in s.uavs for t in u.tasks}
    tick = s.tick_s
    for d in p.deadlines:
        a, b = times[d.adhesion], times[d.brick]
        if d.kind == "open":
            site_start = b.site_start_s if b.site_start_s is not None else b.end_s - site[d.brick]
            assert site_start - a.end_s <= d.lag_s + tick, (d, a, b)
        else:
            assert a.start_s - b.end_s >= d.lag_s - tick, (d, a, b)


@pytest.mark.parametrize(
    ("path", "open_time_s", "cure_time_s"),
    [(CASE_STUDY, 30.0, 0.0), (SMALL, 300.0, 120.0), (SMALL, 600.0, 0.0)],
)
def test_cp_sat_respects_the_deadlines(path: Path, open_time_s: float, cure_time_s: float) -> None:
    bp = _glued(load_blueprint(path), open_time_s, cure_time_s)
    p = make_plan(bp)
    s = solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=8.0, workers=1)
    _check_deadlines(p, s, bp.cruise_altitude_m)
    plain = make_plan(load_blueprint(path))
    free = solve_schedule(
        plain, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=8.0, workers=1
    )
    # the bound with open times is a cheap term: valid for every mission, never above the schedule
    assert s.bound_kind != "cp-sat" and s.bound_s <= s.makespan_s
    if free.status == "optimal":
        assert free.makespan_s <= s.makespan_s + 1e-6


def test_an_open_time_no_schedule_can_meet_is_one_clear_error() -> None:
    bp = _glued(load_blueprint(CASE_STUDY), 20.0)
    with pytest.raises(PlanningError, match=r"open time 20 s is shorter than brick task B0 needs"):
        solve_schedule(make_plan(bp), bp.fleet, time_limit_s=1.0, workers=1)


def test_cli_schedule_with_an_unmeetable_open_time_exits_2(tmp_path: Path) -> None:
    path = tmp_path / "glued.yaml"
    path.write_text(CASE_STUDY.read_text() + "adhesive: {open_time_s: 20}\n")
    args = ["schedule", str(path), "--workers", "1", "--time-limit", "2"]
    result = runner.invoke(app, [*args, "--reservation", "task"])
    assert result.exit_code == 2 and "open time 20 s is shorter than brick task B0" in result.stderr
    # with ``site`` (the default) the brick is fetched while the glue is laid: 20 s can be met
    ok = runner.invoke(app, [*args, "--format", "json"])
    assert ok.exit_code == 0, ok.output
    times = {t["id"]: t for u in json.loads(ok.stdout)["uavs"] for t in u["tasks"]}
    for a, b in (("A0", "B0"), ("A1", "B1")):
        assert times[b]["site_start_s"] - times[a]["end_s"] <= 20.0 + 0.01


def test_cure_alone_keeps_the_cp_sat_bound() -> None:
    bp = _glued(load_blueprint(SMALL), None, 30.0)
    p = make_plan(bp)
    s = solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=5.0, workers=1)
    _check_deadlines(p, s, bp.cruise_altitude_m)
    assert s.bound_s <= s.makespan_s


@settings(max_examples=4, deadline=None, derandomize=True)
@given(st.integers(0, 2**32 - 1), st.sampled_from([120.0, 300.0]), st.sampled_from([0.0, 60.0]))
def test_bound_below_the_schedule_with_deadlines(seed: int, open_time_s: float, cure_time_s: float) -> None:
    bp = random_layout(
        random.Random(seed), LayoutLimits(max_courses=3, max_per_course=3, max_uavs_per_role=2)
    )
    fleet = fleet_for(bp)
    bp = _glued(with_fleet(bp, fleet) if fleet != bp.fleet else bp, open_time_s, cure_time_s)
    p = make_plan(bp)
    if not any(not t.done for t in p.tasks):
        return
    s = solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=2.0, workers=1)
    _check_deadlines(p, s, bp.cruise_altitude_m)
    md = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
    terms = bound_terms(p, bp.fleet, md, work_s=min_cycles_s(p, bp.fleet, md))
    slack = 2 * sum(1 for t in p.tasks if not t.done) * s.tick_s
    assert terms.value_s <= s.makespan_s + slack, (seed, terms, s.makespan_s)
    assert s.bound_s <= s.makespan_s + slack


def test_policy_schedule_follows_a_schedule_with_deadlines() -> None:
    from masonry.mission.schedule_file import stamp_schedule
    from masonry.mission.simulate import simulate

    bp = _glued(load_blueprint(CASE_STUDY), 60.0)
    p = make_plan(bp)
    s = stamp_schedule(
        solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=2.0, workers=1), bp
    )
    r = simulate(bp, policy="schedule", schedule=s, seed=0, reservation="task")
    assert r.completed and r.open_time_violations == 0 and r.schedule_followed == r.schedule_assignments
    assert r.lower_bound_s <= r.makespan_s and s.bound_s <= r.makespan_s
