"""``masonry sim`` and ``masonry mission-control`` through typer's CliRunner."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.cli import app

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = str(ROOT / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()


def sim(*args: str):
    return runner.invoke(app, ["sim", CASE_STUDY, *args])


def test_sim_json_is_exactly_the_report(tmp_path):
    report = tmp_path / "r.json"
    res = sim("--format", "json", "--report", str(report), "--reservation", "task")
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert list(d) == [
        "completed",
        "makespan_s",
        "lower_bound_s",
        "lower_bound_kind",
        "policy",
        "seed",
        "uavs",
        "tasks",
        "placement_error_m",
        "as_built",
        "min_separation_m",
        "envelope_excursion",
        "conflict_violations",
        "dependency_violations",
    ]
    assert json.loads(report.read_text()) == d
    assert [t["id"] for t in sorted(d["tasks"], key=lambda t: t["start_s"])] == ["A0", "B0", "A1", "B1"]


def test_sim_text_summary_gantt_and_plot3d(tmp_path):
    gantt_png, gantt_svg, plot = tmp_path / "g.png", tmp_path / "g.svg", tmp_path / "p.png"
    res = sim("--gantt", str(gantt_png), "--plot3d", str(plot))
    assert res.exit_code == 0, res.output
    assert "mission completed: 4/4 tasks" in res.stdout
    assert "conflict violations 0, dependency violations 0" in res.stdout
    assert gantt_png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and plot.read_bytes()[:4] == b"\x89PNG"
    res = sim("--gantt", str(gantt_svg), "--policy", "fifo", "--seed", "3")
    assert res.exit_code == 0, res.output
    svg = gantt_svg.read_text()
    assert svg.lstrip().startswith("<?xml") and "brick-1" in svg and "glue-1" in svg


def test_sim_fleet_override_and_faults():
    res = sim(
        "--brick-uavs", "2", "--adhesion-uavs", "1", "--fault", "grasp=0.3", "--seed", "2", "--format", "json"
    )
    assert res.exit_code == 0, res.output
    d = json.loads(res.stdout)
    assert [u["name"] for u in d["uavs"]] == ["brick-1", "brick-2", "glue-1"]
    assert d["conflict_violations"] == 0 and d["dependency_violations"] == 0


def test_sim_incomplete_mission_lists_stuck_tasks_and_exits_1():
    res = sim("--fault", "uav-loss=brick-1@5", "--format", "json")
    assert res.exit_code == 1
    d = json.loads(res.stdout)
    assert d["completed"] is False and set(d["stuck"]) >= {"B0", "B1"}
    assert {u["name"]: u["status"] for u in d["uavs"]}["brick-1"] == "lost"


def test_sim_journal_and_resume(tmp_path):
    journal = tmp_path / "m.db"
    first = sim("--journal", str(journal), "--format", "json")
    assert first.exit_code == 0, first.output
    again = sim("--journal", str(journal), "--format", "json")
    assert again.exit_code == 2 and "already holds a mission" in again.stderr
    resumed = sim("--journal", str(journal), "--resume", "--format", "json")
    assert resumed.exit_code == 0, resumed.output
    assert json.loads(resumed.stdout)["tasks"] == json.loads(first.stdout)["tasks"]


def test_a_journal_resumes_only_with_its_reservation(tmp_path):
    """Site intervals and running tasks in a journal follow its reservation's rule: resuming it with the other
    one is refused with one line naming the flag (the default is ``site``)."""
    journal = tmp_path / "m.db"
    first = sim("--journal", str(journal), "--reservation", "task", "--format", "json")
    assert first.exit_code == 0, first.output
    other = sim("--journal", str(journal), "--resume", "--format", "json")
    assert other.exit_code == 2, other.output
    err = other.stderr.strip()
    assert err == (
        f"error: journal {journal} was written with the task reservation, not site: resume it with "
        "--reservation task"
    )
    same = sim("--journal", str(journal), "--resume", "--reservation", "task", "--format", "json")
    assert same.exit_code == 0, same.output
    assert json.loads(same.stdout)["tasks"] == json.loads(first.stdout)["tasks"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--policy", "random"], "--policy must be one of"),
        (["--camera", "lidar"], "--camera must be geometric, render or mixed"),
        (["--fault", "grasp=2"], "grasp"),
        (["--fault", "uav-loss=brick-9@10"], "brick-9"),
        (["--format", "yaml"], "--format must be text or json"),
        (["--gantt", "chart.pdf"], "--gantt chart.pdf"),
        (["--resume"], "--resume needs --journal"),
        (["--table-dispatch", "nearest"], "--table-dispatch must be soonest or policy"),
    ],
)
def test_sim_bad_input_is_one_line_exit_2(args, message):
    res = sim(*args)
    assert res.exit_code == 2, res.output
    err = res.stderr.strip()
    assert err.startswith("error: ") and message in err and "\n" not in err
    assert "Traceback" not in res.output


def test_sim_missing_blueprint_is_exit_2(tmp_path):
    res = runner.invoke(app, ["sim", str(tmp_path / "nope.yaml")])
    assert res.exit_code == 2 and res.stderr.startswith("error: ")


def test_mission_control_bad_input(tmp_path):
    res = runner.invoke(app, ["mission-control", CASE_STUDY, "--resume"])
    assert res.exit_code == 2 and "--resume needs --journal" in res.stderr
    res = runner.invoke(app, ["mission-control", CASE_STUDY, "--listen", "localhost:7447"])
    assert res.exit_code == 2 and "tcp/HOST:PORT" in res.stderr  # a bad endpoint is bad input


def test_fly_mission_mode_bad_input():
    res = runner.invoke(
        app,
        [
            "fly",
            "--uav",
            "brick",
            "--sim",
            "--blueprint",
            CASE_STUDY,
            "--task",
            "B0",
            "--mission",
            "tcp/127.0.0.1:7447",
        ],
    )
    assert res.exit_code == 2 and "exclude each other" in res.stderr
    res = runner.invoke(app, ["fly", "--uav", "brick", "--sim", "--blueprint", CASE_STUDY])
    assert res.exit_code == 2 and "--task is required" in res.stderr


def test_sim_stops_a_mission_that_stalls_and_says_who_waits_for_whom():
    # 3 s with nothing changing happens early in any mission (glue-1 cruises, brick-1 waits on its pad for A0):
    # the watchdog stops it there
    res = sim("--stall-timeout", "3", "--format", "json")
    assert res.exit_code == 1, res.output
    d = json.loads(res.stdout)
    assert not d["completed"]
    stall = d["stall"]
    assert stall["timeout_s"] == 3.0 and stall["at_s"] - stall["since_s"] >= 3.0
    assert {w["uav"] for w in stall["waits"]} == {"brick-1", "glue-1"}
    assert all(set(w) >= {"state", "task", "airspace", "asked_for_m", "blocked_by"} for w in stall["waits"])
    text = sim("--stall-timeout", "3")
    assert text.exit_code == 1 and "stalled: no progress for 3 s" in text.stdout
    bad = sim("--stall-timeout", "-1")
    assert bad.exit_code == 2 and "--stall-timeout -1: out of range" in bad.output


def test_mission_control_checks_its_watchdog_and_reservation_options():
    res = runner.invoke(app, ["mission-control", CASE_STUDY, "--stall-timeout", "-3"])
    assert res.exit_code == 2 and "--stall-timeout -3: out of range, expected 0 to 864000 s" in res.output
    res = runner.invoke(app, ["mission-control", CASE_STUDY, "--reservation", "x"])
    assert res.exit_code == 2 and "--reservation must be site or task, got 'x'" in res.output
    res = sim("--reservation", "x")
    assert res.exit_code == 2 and "--reservation must be site or task, got 'x'" in res.output
