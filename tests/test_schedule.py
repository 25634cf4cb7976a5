"""The offline schedule (masonry.planner.schedule): its constraints, its file, the bound terms, the CLI."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.cli import app
from masonry.errors import InputError, PlanningError
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.schedule_file import check_schedule, read_schedule, stamp_schedule
from masonry.planner import plan as make_plan
from masonry.planner.bound_terms import bound_terms, conflict_clique_s
from masonry.planner.bounds import empty_flight_s, min_cycles_s, min_durations_s, min_site_s
from masonry.planner.dispatch_values import task_end_m, task_start_m
from masonry.planner.schedule import ScheduleUnavailable, solve_schedule
from masonry.planner.schedule_chain import chain_costs
from masonry.planner.schedule_values import schedule_from_dict
from masonry.timing import DEFAULT_TIMING

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
TOL_S = 1e-6


def _solve(bp, **kw):
    p = make_plan(bp)
    kw.setdefault("time_limit_s", 5.0)
    kw.setdefault("workers", 1)
    return p, solve_schedule(p, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m, **kw)


def check_feasible(p, fleet, s, cruise_altitude_m, chaining=True):
    """Every constraint of the model, checked on the planned times (independently of the solver); with
    ``chaining`` (the default model's) a segment not sprayed right after the one ending at its start is also
    its climb out and first descent later."""
    md = min_durations_s(p, cruise_altitude_m=cruise_altitude_m)
    todo = [t for t in p.tasks if not t.done]
    index = {t.id: i for i, t in enumerate(todo)}
    chain = chain_costs(todo, DEFAULT_TIMING, cruise_altitude_m, s.tick_s) if chaining else None
    site = min_site_s(p, cruise_altitude_m=cruise_altitude_m)
    tick = s.tick_s
    planned = {}
    roles = {u.name: u.role for u in fleet}
    homes = {u.name: u.home_m for u in fleet}
    for u in s.uavs:
        assert roles[u.name] == u.role
        where, free, prev = homes[u.name], 0.0, -1
        for t in u.tasks:
            task = p.task(t.id)
            assert task.kind == u.role
            assert t.id not in planned, f"{t.id} scheduled twice"
            planned[t.id] = t
            # duration: the minimum one, rounded down to the tick
            assert t.end_s - t.start_s == pytest.approx(math.floor(md[t.id] / tick) * tick, abs=1e-6)
            flight = math.floor(empty_flight_s(where, task_start_m(task)) / tick) * tick
            if chain is not None:
                flight += chain.extra(prev, index[t.id]) * tick
            assert t.start_s >= free + flight - TOL_S, f"{u.name}: {t.id} starts before the flight to it ends"
            where, free, prev = task_end_m(task), t.end_s, index[t.id]
    assert set(planned) == {t.id for t in p.tasks if not t.done}
    for a, b in p.conflicts:
        if a in planned and b in planned:
            x, y = planned[a], planned[b]
            if s.reservation == "task":
                assert x.end_s <= y.start_s + TOL_S or y.end_s <= x.start_s + TOL_S, (a, b)
            else:
                assert x.site_end_s <= y.site_start_s + TOL_S or y.site_end_s <= x.site_start_s + TOL_S, (
                    a,
                    b,
                )
    for u, v in p.dependencies:
        if u in planned and v in planned:
            if s.reservation == "task":
                assert planned[u].start_s >= planned[v].end_s - TOL_S, (u, v)
            else:
                assert planned[u].site_start_s >= planned[v].end_s - TOL_S, (u, v)
    if s.reservation == "site":
        for tid, t in planned.items():
            assert t.start_s - TOL_S <= t.site_start_s and t.site_end_s <= t.end_s + TOL_S
            assert t.site_end_s - t.site_start_s == pytest.approx(
                min(math.floor(site[tid] / tick), math.floor(md[tid] / tick)) * tick, abs=1e-6
            )
    assert s.makespan_s == pytest.approx(max(t.end_s for t in planned.values()), abs=1e-6)
    assert s.bound_s <= s.makespan_s + TOL_S


def test_case_study_is_optimal_and_feasible():
    bp = load_blueprint(CASE_STUDY)
    p, s = _solve(bp)
    assert s.status == "optimal" and s.gap == 0.0 and s.decomposition == "none"
    check_feasible(p, bp.fleet, s, bp.cruise_altitude_m)
    # the bound is at least the cheap terms (CP-SAT's proof or the terms themselves)
    md = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
    terms = bound_terms(p, bp.fleet, md, work_s=min_cycles_s(p, bp.fleet, md))
    assert s.bound_s >= min(terms.value_s, s.makespan_s) - TOL_S


def test_same_seed_one_worker_same_schedule():
    bp = with_fleet(load_blueprint(CASE_STUDY), fleet_for(load_blueprint(CASE_STUDY), 2, 1))
    a = _solve(bp, seed=3)[1]
    b = _solve(bp, seed=3)[1]
    assert a.status == b.status == "optimal"
    assert a.order_of() == b.order_of() and a.makespan_s == b.makespan_s


@pytest.mark.parametrize("reservation", ["task", "site"])
def test_small_wall_full_and_course_by_course(reservation):
    bp = running_bond(2, 4)
    fleet = fleet_for(bp, 2, 1)
    bp = with_fleet(bp, fleet)
    p, full = _solve(bp, reservation=reservation, time_limit_s=3.0)
    check_feasible(p, fleet, full, bp.cruise_altitude_m)
    _, parts = _solve(bp, reservation=reservation, time_limit_s=3.0, decomposition="course", part_tasks=4)
    check_feasible(p, fleet, parts, bp.cruise_altitude_m)
    assert parts.decomposition == "course" and len(parts.parts) >= 2
    # the decomposed bound is the report's cheap terms: valid for both
    assert parts.bound_kind in ("chain", "role", "conflict-clique")
    assert parts.bound_s <= full.makespan_s + TOL_S


def test_site_reservation_is_never_longer_than_task():
    bp = with_fleet(running_bond(2, 4), fleet_for(running_bond(2, 4), 2, 1))
    _, task = _solve(bp, reservation="task", time_limit_s=3.0)
    _, site = _solve(bp, reservation="site", time_limit_s=3.0)
    # a task-feasible schedule is site-feasible, so the site optimum is at most the task one (when proven)
    if task.status == site.status == "optimal":
        assert site.makespan_s <= task.makespan_s + TOL_S
    assert site.reservation == "site" and all(t.site_start_s is not None for u in site.uavs for t in u.tasks)


def test_bad_arguments_and_missing_role():
    bp = load_blueprint(CASE_STUDY)
    p = make_plan(bp)
    with pytest.raises(PlanningError, match="reservation"):
        solve_schedule(p, bp.fleet, reservation="column")
    with pytest.raises(PlanningError, match="time_limit_s"):
        solve_schedule(p, bp.fleet, time_limit_s=0)
    with pytest.raises(PlanningError, match="no adhesion UAV"):
        solve_schedule(p, [u for u in bp.fleet if u.role == "brick"])


def test_without_ortools_one_clear_error(monkeypatch):
    monkeypatch.setitem(sys.modules, "ortools", None)
    monkeypatch.setitem(sys.modules, "ortools.sat.python.cp_model", None)
    bp = load_blueprint(CASE_STUDY)
    with pytest.raises(ScheduleUnavailable, match="masonry\\[schedule\\]"):
        solve_schedule(make_plan(bp), bp.fleet)
    res = CliRunner().invoke(app, ["schedule", str(CASE_STUDY)])
    assert res.exit_code == 2
    assert res.stderr.strip().count("\n") == 0 and "OR-Tools" in res.stderr


def test_empty_flight_is_the_min_cycles_argument():
    assert empty_flight_s((0, 0, 0), (0.05, 0, 0)) == 0.0
    far = empty_flight_s((0, 0, 0), (10.0, 0, 5.0))
    assert far == pytest.approx(max(0.0, (10.0 - 0.16) / 1.0 - 1.0), abs=0.3)
    assert empty_flight_s((0, 0, 0), (20.0, 0, 0)) > far


# --------------------------------------------------------------------------- the file


def _stamped():
    bp = load_blueprint(CASE_STUDY)
    return bp, stamp_schedule(_solve(bp)[1], bp)


def test_file_round_trip_and_digests(tmp_path):
    bp, s = _stamped()
    f = tmp_path / "s.json"
    f.write_text(json.dumps(s.to_dict()))
    back = read_schedule(f)
    assert back.order_of() == s.order_of() and back.wall_digest == s.wall_digest
    check_schedule(back, bp, "task")
    with pytest.raises(InputError, match="another fleet"):
        check_schedule(back, with_fleet(bp, fleet_for(bp, 2, 1)), "task")
    with pytest.raises(InputError, match="another wall"):
        check_schedule(back, running_bond(2, 3), "task")
    with pytest.raises(InputError, match="reservation"):
        check_schedule(back, bp, "site")


@pytest.mark.parametrize(
    ("edit", "field"),
    [
        (lambda d: d.pop("makespan_s"), "makespan_s"),
        (lambda d: d.update(status="great"), "status"),
        (lambda d: d["uavs"][0]["tasks"][0].update(start_s="soon"), "start_s"),
        (lambda d: d["uavs"][0]["tasks"][0].update(end_s=-1), "end_s"),
        (lambda d: d["uavs"][1]["tasks"].append(dict(d["uavs"][0]["tasks"][0])), "id"),
        (lambda d: d.update(format="gantt"), "format"),
    ],
)
def test_bad_file_names_file_and_field(tmp_path, edit, field):
    _, s = _stamped()
    d = s.to_dict()
    edit(d)
    f = tmp_path / "bad.json"
    f.write_text(json.dumps(d))
    with pytest.raises(InputError) as err:
        read_schedule(f)
    msg = str(err.value)
    assert str(f) in msg and f"`{field}`" in msg and "\n" not in msg
    with pytest.raises(InputError, match="not a JSON object"):
        schedule_from_dict([1, 2])


# --------------------------------------------------------------------------- bound terms


def test_clique_term_counts_conflicts_and_dependencies():
    bp = load_blueprint(CASE_STUDY)
    p = make_plan(bp)
    md = min_durations_s(p, cruise_altitude_m=bp.cruise_altitude_m)
    # on the case study every pair of tasks conflicts or is ordered: the clique is all of them
    assert conflict_clique_s(p, md) == pytest.approx(sum(md.values()), abs=0.01)
    terms = bound_terms(p, bp.fleet, md, work_s=min_cycles_s(p, bp.fleet, md))
    assert terms.kind == "conflict-clique" and terms.value_s == terms.clique_s
    assert bound_terms(p, bp.fleet, md, cp_sat_s=1e6).kind == "cp-sat"


# --------------------------------------------------------------------------- CLI


TASK = ("--reservation", "task")


def test_cli_schedule_then_sim_policy_schedule(tmp_path):
    out, gantt = tmp_path / "s.json", tmp_path / "g.svg"
    runner = CliRunner()
    res = runner.invoke(
        app,
        [
            "schedule",
            str(CASE_STUDY),
            "--time-limit",
            "5",
            "--workers",
            "1",
            "-o",
            str(out),
            "--gantt",
            str(gantt),
            "--reservation",
            "task",  # CP-SAT's proven bound joins the report's bound under the paper's rule (docs/schedule.md)
        ],
    )
    assert res.exit_code == 0, res.output
    assert "schedule optimal" in res.stdout and "<svg" in gantt.read_text()
    doc = json.loads(out.read_text())
    assert doc["status"] == "optimal" and doc["decomposition"] == "none"
    assert [u["name"] for u in doc["uavs"]] == ["brick-1", "glue-1"]
    res = runner.invoke(
        app, ["schedule", str(CASE_STUDY), "--format", "json", "--workers", "1", "--reservation", "task"]
    )
    assert res.exit_code == 0 and json.loads(res.stdout)["makespan_s"] == doc["makespan_s"]
    res = runner.invoke(
        app,
        [
            *("sim", str(CASE_STUDY), "--policy", "schedule", "--schedule", str(out), "--format", "json"),
            *TASK,
        ],
    )
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout)
    assert report["policy"] == "schedule" and report["schedule"] == {"followed": 4, "assignments": 4}
    assert report["lower_bound_kind"] == "cp-sat" and report["lower_bound_s"] == pytest.approx(
        doc["bound_s"], abs=0.01
    )
    assert report["conflict_violations"] == 0 and report["dependency_violations"] == 0
    # another fleet: refused in one line
    res = runner.invoke(
        app,
        [
            *("sim", str(CASE_STUDY), "--policy", "schedule", "--schedule", str(out), "--brick-uavs", "2"),
            *TASK,
        ],
    )
    assert res.exit_code == 2 and "another fleet" in res.stderr
    # computed for the paper's rule, flown under the default (site): refused in one line
    res = runner.invoke(app, ["sim", str(CASE_STUDY), "--policy", "schedule", "--schedule", str(out)])
    assert res.exit_code == 2 and "reservation" in res.stderr and "\n" not in res.stderr.strip()
    res = runner.invoke(app, ["sim", str(CASE_STUDY), "--policy", "schedule"])
    assert res.exit_code == 2 and "--schedule" in res.stderr


def test_cli_schedule_bad_options(tmp_path):
    runner = CliRunner()
    for args, word in (
        (["--time-limit", "0"], "--time-limit"),
        (["--reservation", "x"], "--reservation"),
        (["--format", "yaml"], "--format"),
        (["--gantt", str(tmp_path / "g.txt")], "--gantt"),
    ):
        res = runner.invoke(app, ["schedule", str(CASE_STUDY), *args])
        assert res.exit_code == 2 and word in res.stderr, (args, res.output)


def test_nothing_to_do_is_an_empty_optimal_schedule():
    bp = running_bond(2, 2, placed_courses=2)
    s = solve_schedule(make_plan(bp), bp.fleet, workers=1)
    assert s.status == "optimal" and s.makespan_s == 0.0 and all(not u.tasks for u in s.uavs)
