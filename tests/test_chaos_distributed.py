"""The distributed chaos case: a UAV handler process killed (SIGKILL) mid-task over Zenoh, then restarted.

``masonry mission-control`` and two ``masonry fly --sim --mission`` handlers (brick-1, glue-1) fly the paper's
case study on loopback at 25x real time. When mission control assigns B0 to brick-1, brick-1's process is
killed with SIGKILL; mission control declares it lost (the heartbeat timeout), releases B0, and a new brick-1
process started after that rejoins (its heartbeat holds no task) and takes B0 and B1. The mission completes,
no task is done twice, and the conflict and dependency checks hold. Every process is killed at the end whatever
happens, and nothing depends on how fast the loaded machine runs: each step waits for the line that says the
previous one happened, or for the process to exit (then its output says why), never for a number of seconds;
and a process started mid-mission (the new brick-1, the resumed mission control) is started with the others and
held after its imports (``tests/cli_procs.py``): let go at its step, its start-up no longer races the mission's
windows or the handlers' patience with a silent mission control (a 60 s wait for "heard again" failed at load
13: the mission had ended as stalled, 300 mission s or 12 wall s after the loss, while the new process was still
importing; then a ``--stall-timeout 750`` here; now the stall watchdog itself does not count while a lost UAV's
rejoin window, --startup-timeout's 30 wall s = 750 mission s at x25, is open: ``tests/test_stall.py``).
"""

from __future__ import annotations

import json
import os
import signal
from pathlib import Path

import pytest

from cli_procs import CASE_STUDY, Cli, free_port, spawn, spawn_fly


def fly(name: str, role: str, endpoint: str, mission: str, *extra: str) -> Cli:
    return spawn_fly(role, name, endpoint, mission, "--time-scale", "25", *extra)


def mission_control(endpoint: str, mission: str, report: Path, *extra: str) -> Cli:
    return spawn(
        "mission-control",
        str(CASE_STUDY),
        "--listen",
        endpoint,
        "--format",
        "json",
        "--report",
        str(report),
        "--startup-timeout",
        "30",
        "--heartbeat-timeout",
        "3",
        "--max-time",
        "3000",
        "--mission-name",
        mission,
        "--reservation",
        "task",
        "--time-scale",
        "25",
        "--verbose",
        *extra,
    )


@pytest.mark.slow
def test_mission_control_killed_mid_task_and_resumed_keeps_the_task_with_its_uav(tmp_path):
    """Mission control is killed (SIGKILL) while brick-1 flies B0 and started again with ``--resume``; the
    handlers, patient for 20 s of silence, fly on. The resumed mission control keeps B0 with brick-1 (its
    heartbeats name it, or its completion, said again ahead of them, is taken), gives it to nobody else, and the
    mission completes with every task done once."""
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    mission = f"mc-kill-{port}"
    journal = tmp_path / "mission.db"
    report = tmp_path / "report.json"
    first = mission_control(endpoint, mission, tmp_path / "first.json", "--journal", str(journal))
    procs = [first]
    try:
        glue = fly("glue-1", "adhesion", endpoint, mission, "--heartbeat-timeout", "20")
        brick = fly("brick-1", "brick", endpoint, mission, "--heartbeat-timeout", "20")
        # imported now, let go once the first is killed: inside the handlers' 20 s of patience whatever the load
        second = mission_control(endpoint, mission, report, "--journal", str(journal), "--resume")
        procs += [glue, brick, second]
        for p in (first, glue, brick):
            p.go()
        seen: list[str] = []
        first.wait_line("B0 assigned to brick-1", seen)
        first.wait_line("B0 under way on brick-1", seen)  # journaled, sent, and brick-1 is on it
        os.kill(first.popen.pid, signal.SIGKILL)
        assert first.popen.wait(timeout=10) == -signal.SIGKILL
        second.go()
        second.wait_line("B0 kept on brick-1 (attempt 1) from before the resume", seen)
        out, err = second.finish()
        outs = [p.finish() for p in (glue, brick)]
    finally:
        for p in procs:
            p.kill()
    assert second.popen.returncode == 0, (
        "".join(seen[-30:]) + err[-3000:] + outs[1][0][-3000:] + outs[1][1][-3000:]
    )
    d = json.loads(out)
    assert d["completed"] is True
    assert d["conflict_violations"] == 0 and d["dependency_violations"] == 0
    b0 = next(t for t in d["tasks"] if t["id"] == "B0")
    assert [(a["uav"], a["outcome"]) for a in b0["attempts_detail"]] == [("brick-1", "done")], (
        b0["attempts_detail"],
        "".join(seen[-40:]),
    )
    flown: dict[str, list[str]] = {}
    for p, (stdout, err) in zip((glue, brick), outs):
        assert p.popen.returncode == 0, err[-2000:]
        run = json.loads(stdout)
        flown[run["uav"]] = [t["task"] for t in run["tasks"] if t["status"] == "done"]
    # one process per UAV flew the whole mission, across the restart: each task once
    assert sorted(flown["brick-1"]) == ["B0", "B1"] and sorted(flown["glue-1"]) == ["A0", "A1"]


@pytest.mark.slow
def test_a_handler_killed_mid_task_and_restarted_rejoins_and_the_mission_completes(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    mission = f"chaos-{port}"
    report = tmp_path / "report.json"
    mc = mission_control(endpoint, mission, report)
    procs = [mc]
    try:
        glue = fly("glue-1", "adhesion", endpoint, mission)
        first = fly("brick-1", "brick", endpoint, mission)
        # imported now, let go once brick-1 is declared lost: inside mission control's rejoin window (its
        # --startup-timeout) whatever the load
        second = fly("brick-1", "brick", endpoint, mission)
        procs += [glue, first, second]
        for p in (mc, glue, first):
            p.go()
        seen: list[str] = []
        mc.wait_line("B0 assigned to brick-1", seen)
        mc.wait_line("B0 under way on brick-1", seen)  # B0 takes a minute of mission time (over 2 s here)
        os.kill(first.popen.pid, signal.SIGKILL)
        assert first.popen.wait(timeout=10) == -signal.SIGKILL
        mc.wait_line("UAV brick-1 silent", seen)  # declared lost: B0 is released
        second.go()
        mc.wait_line("UAV brick-1 heard again", seen)
        out, err = mc.finish()
        outs = [p.finish() for p in (glue, second)]
    finally:
        for p in procs:
            p.kill()
    assert mc.popen.returncode == 0, "".join(seen[-30:]) + err[-3000:]
    d = json.loads(out)
    assert d["completed"] is True
    assert d["conflict_violations"] == 0 and d["dependency_violations"] == 0
    b0 = next(t for t in d["tasks"] if t["id"] == "B0")
    outcomes = [(a["uav"], a["outcome"], a["reason"]) for a in b0["attempts_detail"]]
    assert outcomes[0] == ("brick-1", "failed", "uav lost") and outcomes[-1][:2] == ("brick-1", "done")
    assert {u["name"]: u["status"] for u in d["uavs"]} == {"brick-1": "ok", "glue-1": "ok"}
    flown: dict[str, list[str]] = {}
    for p, (stdout, err) in zip((glue, second), outs):
        assert p.popen.returncode == 0, err[-2000:]
        run = json.loads(stdout)
        flown[run["uav"]] = [t["task"] for t in run["tasks"] if t["status"] == "done"]
    # the killed process placed nothing (killed in B0); each task was done once, by the processes that lived
    assert sorted(flown["brick-1"]) == ["B0", "B1"] and sorted(flown["glue-1"]) == ["A0", "A1"]
