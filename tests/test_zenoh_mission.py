"""The Zenoh transport: two endpoints in one process, then a whole mission across three processes on loopback.

The multi-process test runs ``masonry mission-control`` and two ``masonry fly --sim --mission`` handler
processes (brick-1 and glue-1) for the paper's case study, with the simulated UAVs at 25x real time, on free
loopback ports, every wait bounded.
"""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from masonry.errors import MissionError
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, decode, encode
from masonry.mission.zenoh_transport import ZenohTransport, check_endpoint

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
MAIN = "from masonry.cli import main; main()"


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def wait_for(pred, timeout_s=5.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        got = pred()
        if got:
            return got
        time.sleep(0.02)
    return pred()


def test_two_endpoints_exchange_messages_over_loopback():
    port = free_port()
    with ZenohTransport(MISSION_CONTROL, listen=[f"tcp/127.0.0.1:{port}"], mission="t1") as mc, \
            ZenohTransport("brick-1", listen=[f"tcp/127.0.0.1:{free_port()}"], connect=[f"tcp/127.0.0.1:{port}"],
                           mission="t1") as uav:
        def ping():
            uav.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 1.0)))
            return mc.receive()

        got = wait_for(ping)
        assert got and decode(got[0], {"brick-1"}) == Heartbeat("brick-1", 1.0)
        mc.send("brick-1", encode(Heartbeat(MISSION_CONTROL, 2.0)))
        back = wait_for(uav.receive)
        assert [decode(m) for m in back] == [Heartbeat(MISSION_CONTROL, 2.0)]
        mc.send("glue-1", b"to nobody")  # like a network: nobody listening is not an error
    assert mc.config_json()["scouting/multicast/enabled"] is False
    assert mc.config_json()["mode"] == "peer"


@pytest.mark.parametrize("bad", ["7447", "tcp/host", "tcp/:7447", "http/host:80", "tcp/host:99999"])
def test_bad_endpoints_are_rejected(bad):
    with pytest.raises(MissionError, match="endpoint"):
        check_endpoint(bad)


def test_send_before_connect_is_an_error():
    with pytest.raises(MissionError, match="not connected"):
        ZenohTransport("brick-1").send(MISSION_CONTROL, b"x")


@pytest.mark.slow
def test_case_study_across_three_processes(tmp_path):
    port = free_port()
    endpoint = f"tcp/127.0.0.1:{port}"
    report = tmp_path / "report.json"
    common = ["--time-scale", "25"]
    mission_name = f"test-{port}"
    mc = subprocess.Popen(
        [sys.executable, "-c", MAIN, "mission-control", str(CASE_STUDY), "--listen", endpoint, "--format", "json",
         "--report", str(report), "--startup-timeout", "20", "--heartbeat-timeout", "3", "--max-time", "1500",
         "--mission-name", mission_name, *common],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    uavs = [
        subprocess.Popen(
            [sys.executable, "-c", MAIN, "fly", "--uav", role, "--name", name, "--sim", "--blueprint", str(CASE_STUDY),
             "--mission", endpoint, "--listen", f"tcp/127.0.0.1:{free_port()}", "--mission-name", mission_name,
             "--wait", "20", "--format", "json", *common],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        for role, name in (("brick", "brick-1"), ("adhesion", "glue-1"))
    ]
    procs = [mc, *uavs]
    try:
        mc_out, mc_err = mc.communicate(timeout=60)
        outs = [p.communicate(timeout=30) for p in uavs]
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()
    assert mc.returncode == 0, mc_err
    d = json.loads(mc_out)
    assert d == json.loads(report.read_text())
    assert d["completed"] is True
    order = [t["id"] for t in sorted(d["tasks"], key=lambda t: t["start_s"])]
    assert order == ["A0", "B0", "A1", "B1"]
    assert d["conflict_violations"] == 0 and d["dependency_violations"] == 0
    assert all(u["status"] == "ok" for u in d["uavs"])
    flown = {}
    for p, (out, err) in zip(uavs, outs):
        assert p.returncode == 0, err
        run = json.loads(out)
        assert run["mission_ended"] is True and run["mission_completed"] is True
        flown[run["uav"]] = [t["task"] for t in run["tasks"] if t["status"] == "done"]
    assert flown == {"brick-1": ["B0", "B1"], "glue-1": ["A0", "A1"]}
