"""The take-off on the real PX4 v1.16 SITL, flown as ``masonry fly`` flies it, run by run (issue 29).

A0 and the one-brick scenario on a PX4 whose EKF2 holds its height on SIH's range finder (``EKF2_HGT_REF`` 2,
``EKF2_RNG_CTRL`` 2) failed twice in 51 flights with "take-off stalled at -0.06 m". This flies only the take-off, on
a fresh PX4 each run, as PX4 starts (as the tests do): the adapter ``masonry fly`` builds (defaults,
``estimate_wait_s`` 150), arm, ``takeoff(1.2 m)`` within 30 s, then a landing. Beside it it listens on PX4's
ground-station link (UDP 14550) for EKF2's LOCAL_POSITION_NED, SIH's HIL_STATE_QUATERNION (its truth),
DISTANCE_SENSOR, EXTENDED_SYS_STATE (the land detector), ESTIMATOR_STATUS and STATUSTEXT, and prints per run the
outcome and, where the climb did not end reached, the timeline and which of PX4's threads were busy; ``--keep DIR``
keeps each run's recording, PX4's log and, for such a climb, PX4's threads where they wait (/proc, and gdb where
installed); ``--ulog`` turns PX4's .ulg log on (``SDLOG_MODE`` 0). Traced with it (docs/performance/autopilots.md,
"The take-off's stall on the range finder, traced"): EKF2's height reset at lift-off, which
``EKF2_MIN_RNG=0 SIH_DISTSNSR_MIN=-0.05`` (the tests' ``RANGE_FINDER_PX4_PARAMS``) ends, and PX4's own simulated
sensors stopping at arming ("Preflight Fail: No valid data from" in its log).

    python3 -c "while True: pass" &
    python benchmarks/bench_px4_takeoff.py --run-sh ../shared/px4/run.sh --runs 25 \
        --params EKF2_HGT_REF=2 EKF2_RNG_CTRL=2 EKF2_MIN_RNG=0 SIH_DISTSNSR_MIN=-0.05 --ulog --keep /tmp/takeoff
"""

from __future__ import annotations

import argparse
import json
import math
import os
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from case_study_procs import CASE_STUDY
from masonry.adapters.mavlink_protocol import MAV_CMD_SET_MESSAGE_INTERVAL, MAV_MODE_FLAG_SAFETY_ARMED
from masonry.adapters.wiring import hardware_config
from masonry.blueprint import load_blueprint
from masonry.cli.fly import select_adapters
from masonry.sim import Faults
from px4_sitl import ENV, SIH_STARVED, one_flight_at_a_time, px4, px4_pid

GCS_URL = "udpin:0.0.0.0:14550"
#: LOCAL_POSITION_NED, HIL_STATE_QUATERNION, DISTANCE_SENSOR, EXTENDED_SYS_STATE, ESTIMATOR_STATUS: 30 Hz
STREAMS = (32, 115, 132, 245, 230)
ALTITUDE_M, TIMEOUT_S = 1.2, 30.0


class Recorder(threading.Thread):
    """PX4 instance ``instance``'s messages on the ground-station link, stamped on arrival (wall s)."""

    def __init__(self, instance: int) -> None:
        super().__init__(daemon=True)
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(GCS_URL, source_system=250)
        self.sysid = instance + 1
        self.rows: list[dict[str, Any]] = []
        self.stop = threading.Event()

    def run(self) -> None:
        asked_s = -math.inf
        while not self.stop.is_set():
            msg = self.conn.recv_match(blocking=True, timeout=0.2)
            if msg is None or msg.get_srcSystem() != self.sysid:
                continue
            now = time.monotonic()
            kind = msg.get_type()
            row: dict[str, Any] | None = None
            if kind == "HEARTBEAT" and msg.get_srcComponent() == 1:
                row = {"armed": bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED), "mode": msg.custom_mode}
                if now - asked_s > 5.0:  # (again every 5 s: a request lost on UDP)
                    asked_s = now
                    for msg_id in STREAMS:
                        self.conn.mav.command_long_send(
                            self.sysid, 1, MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 1e6 / 30.0, 0, 0, 0, 0, 0
                        )
            elif kind == "LOCAL_POSITION_NED":
                row = {"t_boot_s": msg.time_boot_ms / 1000.0, "ekf_up_m": -msg.z, "ekf_vup_mps": -msg.vz}
            elif kind == "HIL_STATE_QUATERNION":
                row = {"true_alt_m": msg.alt / 1000.0, "true_vup_mps": -msg.vz / 100.0}
            elif kind == "DISTANCE_SENSOR":
                row = {"range_m": msg.current_distance / 100.0}
            elif kind == "EXTENDED_SYS_STATE":
                row = {"landed_state": msg.landed_state}
            elif kind == "ESTIMATOR_STATUS":
                row = {"ekf_flags": msg.flags, "vert_ratio": round(msg.pos_vert_ratio, 3)}
            elif kind == "STATUSTEXT":
                row = {"text": msg.text}
            if row is not None:
                self.rows.append({"w": round(now, 3), **row})

    def close(self) -> None:
        self.stop.set()
        self.join(timeout=2.0)
        self.conn.close()


def threads(pid: int) -> dict[str, tuple[str, int]]:
    """PX4's threads: name -> (state, CPU ticks so far), from /proc."""
    out: dict[str, tuple[str, int]] = {}
    for task in Path(f"/proc/{pid}/task").glob("*"):
        try:
            stat = (task / "stat").read_text()
        except OSError:
            continue
        name = stat[stat.index("(") + 1 : stat.rindex(")")]
        fields = stat[stat.rindex(")") + 2 :].split()
        out[f"{name}/{task.name}"] = (fields[0], int(fields[11]) + int(fields[12]))
    return out


def busy_threads(pid: int, over_s: float = 2.0) -> list[str]:
    """PX4's threads that used CPU over ``over_s`` of wall time: 'name/tid state share'."""
    before = threads(pid)
    time.sleep(over_s)
    after = threads(pid)
    tick = os.sysconf("SC_CLK_TCK")
    rows = []
    for key, (state, ticks) in after.items():
        share = (ticks - before.get(key, (state, ticks))[1]) / tick / over_s
        if share > 0.02:
            rows.append((share, f"{key} {state} {share:.0%}"))
    return [r for _, r in sorted(rows, reverse=True)]


def dump_threads(pid: int, folder: Path) -> None:
    """PX4's threads where they wait: ``threads-PID.txt`` (name, state, kernel wait) and ``gdb-PID.txt`` (each
    thread's stack; PX4's own frames unnamed, the binary is stripped)."""
    lines = []
    for task in sorted(Path(f"/proc/{pid}/task").glob("*")):
        try:
            comm = (task / "comm").read_text().strip()
            wchan = (task / "wchan").read_text().strip()
            state = (task / "stat").read_text().split(")")[-1].split()[0]
        except OSError:
            continue
        lines.append(f"{task.name} {comm} {state} {wchan}")
    (folder / f"threads-{pid}.txt").write_text("\n".join(lines) + "\n")
    if shutil.which("gdb"):
        with (folder / f"gdb-{pid}.txt").open("w") as out:
            gdb = ["gdb", "-p", str(pid), "-batch", "-ex", "thread apply all bt 12"]
            subprocess.run(gdb, stdout=out, stderr=subprocess.STDOUT, timeout=60, check=False)


def fly_takeoff(url: str, dump_to: Path | None = None) -> dict[str, Any]:
    """The adapter ``masonry fly`` builds on ``url`` (a brick UAV of the case study, defaults but the estimate
    wait): arm, take off 1.2 m, wait for the climb's end (at most 30 s of PX4's clock), land."""
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "brick")
    hw = hardware_config({"fc": url, "actuators": "sim", "camera": "sim"}, {"estimate_wait_s": 150})
    ports = select_adapters(sim=False, blueprint=bp, spec=spec, seed=0, camera="sim", faults=Faults(),
                            hardware=hw)  # fmt: skip
    fc: Any = ports.fc
    try:
        fc.arm()
        armed_w = time.monotonic()
        ground = fc.telemetry().position_m[2]
        fc.takeoff(ALTITUDE_M, timeout_s=TIMEOUT_S)
        start = fc.clock.now_s()
        reached = None
        while fc.clock.now_s() - start < TIMEOUT_S:
            tel = fc.telemetry()
            # what the machine waits for (masonry.fsm.common.do_takeoff: within 5 cm, settled)
            if (
                not tel.on_ground
                and tel.position_m[2] >= ground + ALTITUDE_M - 0.05
                and abs(tel.velocity_mps[2]) <= 0.1
            ):
                reached = fc.clock.now_s() - start
                break
            fc.clock.sleep(0.05)
        altitude = fc.telemetry().position_m[2] - ground
        problem = fc.takeoff_problem
        busy = busy_threads(px4_pid(url)) if reached is None else None
        if reached is None and dump_to is not None:
            dump_threads(px4_pid(url), dump_to)
        fc.land()
        fc.clock.sleep(2.0)
        return {"reached_s": None if reached is None else round(reached, 1), "altitude_m": round(altitude, 2),
                "problem": problem, "armed_w": armed_w, "ground_m": round(fc.ground_offset_m or 0.0, 3), "busy": busy}  # fmt: skip
    finally:
        ports.close()


def timeline(
    rows: list[dict[str, Any]], armed_w: float, span_s: float = 14.0, step_s: float = 0.5
) -> list[str]:
    """The recording from the arming on, one line per ``step_s``: the latest of each field."""
    latest: dict[str, Any] = {}
    lines, next_w, i = [], armed_w - 1.0, 0
    while next_w <= armed_w + span_s:
        while i < len(rows) and rows[i]["w"] <= next_w:
            if "text" in rows[i]:
                lines.append(f"  {rows[i]['w'] - armed_w:+6.2f} s  PX4: {rows[i]['text']}")
            latest.update({k: v for k, v in rows[i].items() if k not in ("w", "text")})
            i += 1
        fields = (
            "ekf_up_m",
            "ekf_vup_mps",
            "true_alt_m",
            "true_vup_mps",
            "range_m",
            "landed_state",
            "ekf_flags",
        )
        cells = " ".join(
            f"{k}={latest[k]:.3f}" if isinstance(latest.get(k), float) else f"{k}={latest.get(k)}"
            for k in fields
        )
        lines.append(f"  {next_w - armed_w:+6.2f} s  {cells}")
        next_w += step_s
    return lines


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-sh", type=Path, default=Path(__file__).resolve().parents[2] / "shared/px4/run.sh")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument("--instance", type=int, default=6, help="PX4 instance (offboard link on 14540 + N)")
    ap.add_argument("--params", nargs="*", default=[], help="PX4 parameters at boot, NAME=VALUE")
    ap.add_argument("--keep", type=Path, default=None, help="keep each run's recording and .ulg here")
    ap.add_argument("--ulog", action="store_true", help="PX4's .ulg log on (SDLOG_MODE 0)")
    args = ap.parse_args()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
    os.environ[ENV] = str(args.run_sh.resolve())
    params = dict(p.split("=", 1) for p in args.params)
    if args.ulog:
        params.setdefault("SDLOG_MODE", "0")
    rows = []
    for run in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp, one_flight_at_a_time():
            recorder = Recorder(args.instance)
            recorder.start()
            load = os.getloadavg()[0]
            try:
                with px4(Path(tmp) / "px4", args.instance, params) as url:
                    try:
                        result = fly_takeoff(url, args.keep)
                    except Exception as exc:  # (a bench: the run's failure is its row)
                        result = {"problem": f"{type(exc).__name__}: {exc}", "reached_s": None}
            finally:
                recorder.close()
            log = Path(tmp) / "px4" / "px4.log"
            stopped = log.is_file() and SIH_STARVED in log.read_text(errors="replace")
            if args.keep is not None:
                dest = args.keep / f"run-{run}"
                shutil.copytree(
                    Path(tmp) / "px4", dest, ignore=shutil.ignore_patterns("bin"), dirs_exist_ok=True
                )
                (dest / "mavlink.json").write_text(json.dumps(recorder.rows))
                (dest / "result.json").write_text(json.dumps(result))
        row = {"run": run, "load": round(load, 1), "reached_s": result.get("reached_s"),
               "altitude_m": result.get("altitude_m"), "problem": result.get("problem"),
               "sensors_stopped": stopped or None}  # fmt: skip
        rows.append(row)
        print(" ".join(f"{k}={v}" for k, v in row.items() if v is not None), flush=True)
        if result.get("busy") is not None:
            print("  PX4's threads busy: " + (", ".join(result["busy"]) or "none"), flush=True)
        if result.get("reached_s") is None and "armed_w" in result:
            print("\n".join(timeline(recorder.rows, result["armed_w"])), flush=True)
    done = sum(r["reached_s"] is not None for r in rows)
    times = sorted(r["reached_s"] for r in rows if r["reached_s"] is not None)
    stops = sum(bool(r["sensors_stopped"]) for r in rows)
    print(json.dumps({"params": params, "runs": len(rows), "reached": done, "sensors_stopped": stops,
                      "reached_s": [times[0], times[len(times) // 2], times[-1]] if times else None}))  # fmt: skip


if __name__ == "__main__":
    main()
