"""Issue 29's 2 + 1 mission on three ArduCopter SITLs (hexacopters at ``--speedup 2``, tests/ardupilot_sitl.py):
a running bond whose six bricks two brick UAVs lay at once, by default. Skipped, with one reason, where
``MASONRY_ARDUPILOT_SITL`` does not name the binary; ``.ci/run`` sets it.

The wall is ``masonry blueprint running-bond --courses 2 --bricks-per-course 6 --placed-courses 1 --brick-uavs 2
--adhesion-uavs 1``: six bricks to lay in running bond on a course laid already (eleven beads), 1.8 m long, so two
sites r_c (1.5 m) apart exist and the default ``site`` reservation lets both brick UAVs work. On issue 29's first
wall (two courses of three, none laid, 0.9 m long) every site is within r_c of every other: brick-2, landed,
never took a task (benchmarks/bench_arducopter_bond.py ``--wall 2x3``; docs/performance/autopilots.md).
Mission control and three ``masonry fly --mission`` processes with default settings (each uav.yaml only
``estimate_wait_s``), mission time on the autopilots' clocks, as tests/test_ardupilot_sitl.py.
"""

from __future__ import annotations

import contextlib
import json
import os
from pathlib import Path

import pytest
from typer.testing import CliRunner

from ardupilot_sitl import SPEEDUP, arducopter, sitl_binary
from case_study_procs import fly_mission, free_tcp_port, masonry, reaped
from masonry.cli import app
from masonry.observe.mcap_log import read_log

#: ArduCopter SITL needs ~40 s (its clock) from the first connection to a GPS-based estimate; nothing else is set.
UAV_YAML = "estimate_wait_s: 150\n"
#: Mission control's and the UAVs' ``--heartbeat-timeout`` (tests/test_ardupilot_sitl.py's, for a loaded machine).
HEARTBEAT_TIMEOUT = "30"
#: The wall (``masonry blueprint running-bond``'s options) and its fleet, in the blueprint's order.
WALL = ["--courses", "2", "--bricks-per-course", "6", "--placed-courses", "1", "--brick-uavs", "2",
        "--adhesion-uavs", "1"]  # fmt: skip
FLEET = (("brick", "brick-1"), ("brick", "brick-2"), ("adhesion", "glue-1"))
#: The first of its three SITL instances (-I47..49, TCP 6230-6252: clear of the other SITL tests' 41-46);
#: ``MASONRY_ARDUPILOT_BOND_INSTANCE=N`` flies it on N..N+2 where those are taken (a machine shared with others).
FIRST_INSTANCE = int(os.environ.get("MASONRY_ARDUPILOT_BOND_INSTANCE") or 47)
#: Wall seconds mission control may take (pre-flights and ~40 s of the autopilots' clocks to a GPS estimate
#: included): the mission is ~250 s of mission time at x2.
MISSION_WALL_S = 900.0
#: ArduCopter's simulated battery (BATT_CAPACITY 3300 mAh by default) left the brick UAVs at 23-29 % ("battery low",
#: out of service) after ~370 s in the air holding and laying on a loaded machine: the mission's batteries hold
#: 10 Ah (the simulator's parameters, not masonry's; tests/test_px4_sitl.py's SIM_BAT_DRAIN alike).
BATTERY_PARAMS = {"BATT_CAPACITY": 10000.0, "SIM_BATT_CAP_AH": 10.0}
#: The separation two airborne UAVs keep (docs/safety.md; masonry.mission.chaos.SEPARATION_BOUND_M).
SEPARATION_M = 1.0


@pytest.mark.slow
def test_a_2_plus_1_running_bond_on_three_arducopter_sitls(tmp_path: Path) -> None:
    sitl_binary()
    blueprint = tmp_path / "bond.yaml"
    made = CliRunner().invoke(app, ["blueprint", "running-bond", *WALL, "-o", str(blueprint)])
    assert made.exit_code == 0, made.output
    config = tmp_path / "uav.yaml"
    config.write_text(UAV_YAML)
    endpoint = f"tcp/127.0.0.1:{free_tcp_port()}"
    name = ["--mission-name", f"bond-{endpoint.rsplit(':', 1)[1]}"]
    log = tmp_path / "mission-control.mcap"  # its events: every completion with its coverage
    with contextlib.ExitStack() as sitls:
        urls = [
            sitls.enter_context(
                arducopter(tmp_path / uav, FIRST_INSTANCE + i, FIRST_INSTANCE + 1 + i, params=BATTERY_PARAMS)
            )
            for i, (_, uav) in enumerate(FLEET)
        ]
        # (the default reservation, site)
        mc = masonry("mission-control", str(blueprint), "--listen", endpoint, "--format", "json", "--time-scale",
                     str(SPEEDUP), "--startup-timeout", "300", "--heartbeat-timeout", HEARTBEAT_TIMEOUT,
                     "--max-time", "1500", "--log", str(log), "--verbose", *name)  # fmt: skip
        flags = ["--wait", "60", "--heartbeat-timeout", HEARTBEAT_TIMEOUT, *name]
        uavs = [
            fly_mission(role, uav, url, endpoint, config, *flags, blueprint=str(blueprint))
            for (role, uav), url in zip(FLEET, urls, strict=True)
        ]
        with reaped([mc, *uavs]):
            mc_out, mc_err = mc.communicate(timeout=MISSION_WALL_S)
            runs = [p.communicate(timeout=180) for p in uavs]
    assert mc.returncode == 0, mc_err[-3000:] + "".join(err[-2000:] for _, err in runs)
    report = json.loads(mc_out)
    assert report["completed"] is True
    by = {t["id"]: t["uav"] for t in report["tasks"]}
    assert all(t["status"] == "done" for t in report["tasks"]), report["tasks"]
    assert {tid for tid in by if tid.startswith("B")} == set(report["placement_error_m"]) and len(by) == 17
    assert all(uav == "glue-1" for tid, uav in by.items() if tid.startswith("A"))
    bricks_by = {
        uav: sorted(t for t, u in by.items() if u == uav and t.startswith("B"))
        for uav in ("brick-1", "brick-2")
    }
    assert all(bricks_by.values()), bricks_by  # both brick UAVs laid bricks
    assert all(e < 0.02 for e in report["placement_error_m"].values()), report["placement_error_m"]
    coverage = {e.task_id: e.fields["coverage"] for e in read_log(log).events if e.kind == "completed"}
    beads = {tid: c for tid, c in coverage.items() if tid.startswith("A")}
    assert len(beads) == 11 and all(c >= 0.9 for c in beads.values()), beads
    # from the traces: the attempts' and site intervals (masonry.mission.trace_checks), and the UAVs' positions
    # as mission control heard them (masonry.mission.heard_separation)
    assert report["conflict_violations"] == 0 and report["dependency_violations"] == 0
    assert report["min_separation_m"] is not None and report["min_separation_m"] >= SEPARATION_M, report
    for p, (out, err) in zip(uavs, runs, strict=True):
        assert p.returncode == 0, err[-2000:]
        assert json.loads(out)["mission_completed"]
    errors = ", ".join(f"{k} {v * 1000:.1f}" for k, v in report["placement_error_m"].items())
    print(
        f"2 + 1 running bond on three ArduCopter SITLs: makespan {report['makespan_s']} s (mission time); bricks "
        f"{bricks_by}; {errors} mm; beads {min(beads.values()):.0%}+; least separation "
        f"{report['min_separation_m']} m"
    )
