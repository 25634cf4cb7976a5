"""The distributed chaos case: a UAV handler process killed (SIGKILL) mid-task over Zenoh, then restarted.

``masonry mission-control`` and two ``masonry fly --sim --mission`` handlers (brick-1, glue-1) fly the paper's
case study on loopback at 25x real time. When mission control assigns B0 to brick-1, brick-1's process is
killed with SIGKILL; mission control declares it lost (the heartbeat timeout), releases B0, and a new brick-1
process started after that rejoins (its heartbeat holds no task) and takes B0 and B1. The mission completes,
no task is done twice, and the conflict and dependency checks hold. Every wait is bounded, every process is
killed at the end whatever happens, and nothing depends on how fast the loaded machine runs: each step waits
for the line that says the previous one happened.
"""

from __future__ import annotations

import json
import os
import queue
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
MAIN = "from masonry.cli import main; main()"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def lines_of(stream) -> queue.Queue[str]:
    """Every line of ``stream``, read by a thread (a pipe left unread would block its writer)."""
    q: queue.Queue[str] = queue.Queue()

    def pump() -> None:
        for line in stream:
            q.put(line)

    threading.Thread(target=pump, daemon=True).start()
    return q


def wait_line(q: queue.Queue[str], text: str, timeout_s: float, seen: list[str]) -> str:
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        try:
            line = q.get(timeout=0.2)
        except queue.Empty:
            continue
        seen.append(line)
        if text in line:
            return line
    raise AssertionError(f"no line with {text!r} within {timeout_s:.0f} s; last lines: {''.join(seen[-15:])}")


def fly(name: str, role: str, endpoint: str, mission: str, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [
            sys.executable,
            "-c",
            MAIN,
            "fly",
            "--uav",
            role,
            "--name",
            name,
            "--sim",
            "--blueprint",
            str(CASE_STUDY),
            "--mission",
            endpoint,
            "--listen",
            f"tcp/127.0.0.1:{free_port()}",
            "--mission-name",
            mission,
            "--wait",
            "30",
            "--format",
            "json",
            "--time-scale",
            "25",
            *extra,
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def mission_control(endpoint: str, mission: str, report: Path, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [
            sys.executable,
            "-c",
            MAIN,
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
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
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
        procs += [glue, brick]
        assert first.stderr is not None
        seen: list[str] = []
        wait_line(lines_of(first.stderr), "B0 assigned to brick-1", 120, seen)
        time.sleep(0.3)  # journaled and sent (B0 takes about 2 s here): brick-1 is on it
        os.kill(first.pid, signal.SIGKILL)
        assert first.wait(timeout=10) == -signal.SIGKILL
        second = mission_control(endpoint, mission, report, "--journal", str(journal), "--resume")
        procs.append(second)
        assert second.stderr is not None
        log = lines_of(second.stderr)
        wait_line(log, "B0 kept on brick-1 (attempt 1) from before the resume", 60, seen)
        out, err = second.communicate(timeout=180)
        outs = [p.communicate(timeout=60) for p in (glue, brick)]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    assert second.returncode == 0, "".join(seen[-30:]) + err[-3000:] + outs[1][0][-3000:] + outs[1][1][-3000:]
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
        assert p.returncode == 0, err[-2000:]
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
        procs += [glue, first]
        assert mc.stderr is not None
        log = lines_of(mc.stderr)
        seen: list[str] = []
        wait_line(log, "B0 assigned to brick-1", 120, seen)
        time.sleep(0.3)  # B0 takes a minute of mission time (over 2 s here): brick-1 is on it
        os.kill(first.pid, signal.SIGKILL)
        assert first.wait(timeout=10) == -signal.SIGKILL
        wait_line(log, "UAV brick-1 silent", 60, seen)  # declared lost: B0 is released
        second = fly("brick-1", "brick", endpoint, mission)
        procs.append(second)
        wait_line(log, "UAV brick-1 heard again", 60, seen)
        out, _ = mc.communicate(timeout=180)
        outs = [p.communicate(timeout=60) for p in (glue, second)]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    assert mc.returncode == 0, "".join(seen[-30:])
    d = json.loads(out)
    assert d["completed"] is True
    assert d["conflict_violations"] == 0 and d["dependency_violations"] == 0
    b0 = next(t for t in d["tasks"] if t["id"] == "B0")
    outcomes = [(a["uav"], a["outcome"], a["reason"]) for a in b0["attempts_detail"]]
    assert outcomes[0] == ("brick-1", "failed", "uav lost") and outcomes[-1][:2] == ("brick-1", "done")
    assert {u["name"]: u["status"] for u in d["uavs"]} == {"brick-1": "ok", "glue-1": "ok"}
    flown: dict[str, list[str]] = {}
    for p, (stdout, err) in zip((glue, second), outs):
        assert p.returncode == 0, err[-2000:]
        run = json.loads(stdout)
        flown[run["uav"]] = [t["task"] for t in run["tasks"] if t["status"] == "done"]
    # the killed process placed nothing (killed in B0); each task was done once, by the processes that lived
    assert sorted(flown["brick-1"]) == ["B0", "B1"] and sorted(flown["glue-1"]) == ["A0", "A1"]
