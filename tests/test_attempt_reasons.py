"""Every failed attempt's reason reaches the JSON report (``tasks[].attempts_detail``), mission control's log (what
``mission-control --verbose`` prints) and the UAV handler's log and executions (issue 19)."""

from __future__ import annotations

import logging

from masonry.mission.report import control_report
from masonry.planner.tasks import BrickTask, Plan
from test_mission_control import fleet_of, run_mission


def _stuck_b0():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    return plan, *run_mission(plan, fleet_of(1, 0), fail_p=1.0)


def test_the_json_report_lists_every_attempt_with_its_reason():
    plan, mc, _handlers, _ = _stuck_b0()
    task = control_report(mc, plan, policy="fifo").to_dict()["tasks"][0]
    assert task["attempts"] == 3
    detail = task["attempts_detail"]
    assert [d["outcome"] for d in detail] == ["failed"] * 3
    assert [d["reason"] for d in detail] == ["grasp failed"] * 3
    assert {d["uav"] for d in detail} == {"brick-1"}
    starts = [d["start_s"] for d in detail]
    assert starts == sorted(starts) and all(d["end_s"] >= d["start_s"] for d in detail)


def test_a_done_attempt_has_no_reason_in_the_report():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    mc, _handlers, _ = run_mission(plan, fleet_of(1, 0))
    (detail,) = control_report(mc, plan, policy="fifo").to_dict()["tasks"][0]["attempts_detail"]
    assert detail["outcome"] == "done" and detail["reason"] is None


def test_mission_control_and_the_handler_log_each_failure_with_its_reason(caplog):
    with caplog.at_level(logging.INFO, logger="masonry.mission"):
        _plan, mc, handlers, _ = _stuck_b0()
    control = [r.getMessage() for r in caplog.records if r.name == "masonry.mission.control"]
    handler = [r.getMessage() for r in caplog.records if r.name == "masonry.mission.handler"]
    assert sum("B0 failed on brick-1" in m and m.endswith(": grasp failed") for m in control) == 3
    assert sum("B0 assigned to brick-1" in m for m in control) == 3
    assert sum(m.startswith("brick-1: B0 attempt") and m.endswith(": grasp failed") for m in handler) == 3
    assert [e.reason for e in handlers["brick-1"].executions] == ["grasp failed"] * 3
    assert mc.blocked


def test_the_mission_process_echoes_each_failed_attempt_once():
    from masonry.mission.remote import _echo_failures

    _plan, _mc, handlers, _ = _stuck_b0()
    lines: list[str] = []
    shown = _echo_failures(handlers["brick-1"], 0, 99.0, lines.append)
    assert shown == 3 and len(lines) == 3
    assert lines[0].endswith("B0 (attempt 1) failed: grasp failed")
    assert _echo_failures(handlers["brick-1"], shown, 99.0, lines.append) == 3 and len(lines) == 3
