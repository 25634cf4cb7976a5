"""A0 (the case study's first bead) on the real PX4 v1.16 SITL: SIH's truth beside EKF2's estimate, run by run.

Issue 29: A0 failed on the real PX4 under load in its spray descent and its spray pass. This flies A0 as
``tests/test_px4_sitl.py`` does (``masonry fly --uav adhesion --task A0 --fc udpin:0.0.0.0:14540+N --actuators sim
--camera sim``, uav.yaml only ``estimate_wait_s: 150``) on ``../shared/px4/run.sh``, and listens on PX4's ground
station link (UDP 14550) for EKF2's LOCAL_POSITION_NED and SIH's HIL_STATE_QUATERNION (its ground truth) at 30 Hz.
Per run it prints the task's result and, from take-off to landing, how far EKF2's height sat from the truth (each
from its value at rest before the take-off) and for how long SIH's airframe stood on its ground while EKF2 put it
0.3 m or more above it (the airframe pinned there: the spray cannot move it). ``--params`` sets PX4 parameters at
boot (``--params EKF2_HGT_REF=2 EKF2_RNG_CTRL=2``: height on SIH's downward rangefinder, as the test flies A0).
Run it beside a busy loop for the loaded figure (``python3 -c "while True: pass" &``).

    python benchmarks/bench_px4_spray.py --run-sh ../shared/px4/run.sh --runs 3
    python benchmarks/bench_px4_spray.py --run-sh ../shared/px4/run.sh --runs 3 --params EKF2_HGT_REF=2 EKF2_RNG_CTRL=2
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from case_study_procs import CASE_STUDY, masonry
from masonry.adapters.mavlink_protocol import MAV_CMD_SET_MESSAGE_INTERVAL, MAV_MODE_FLAG_SAFETY_ARMED
from px4_sitl import ENV, give_the_cpu, one_flight_at_a_time, px4

#: PX4's ground station link: every instance sends there (README of ../shared/px4)
GCS_URL = "udpin:0.0.0.0:14550"
MSG_LOCAL_POSITION_NED, MSG_HIL_STATE_QUATERNION = 32, 115
#: the airframe "stands on SIH's ground": truth within this of its height at rest, EKF2 this far above it
GROUND_M, ABOVE_M = 0.03, 0.3


class Recorder(threading.Thread):
    """EKF2's height and SIH's truth from PX4 instance ``instance`` on the ground station link, stamped on arrival."""

    def __init__(self, instance: int) -> None:
        super().__init__(daemon=True)
        from pymavlink import mavutil

        self.conn = mavutil.mavlink_connection(GCS_URL, source_system=250)
        self.sysid = instance + 1
        self.estimate: list[tuple[float, float]] = []  # (wall s, EKF2 up m)
        self.truth: list[tuple[float, float]] = []  # (wall s, SIH altitude m)
        self.armed_s: float | None = None  # (wall s) its first armed HEARTBEAT
        self.stop = threading.Event()

    def run(self) -> None:
        asked_s = -math.inf
        while not self.stop.is_set():
            msg = self.conn.recv_match(blocking=True, timeout=0.2)
            if msg is None or msg.get_srcSystem() != self.sysid:
                continue
            now = time.monotonic()
            kind = msg.get_type()
            if kind == "HEARTBEAT" and self.armed_s is None and msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED:
                self.armed_s = now
            if kind == "HEARTBEAT" and now - asked_s > 5.0:  # (again every 5 s: a request lost on UDP)
                asked_s = now
                for msg_id in (MSG_LOCAL_POSITION_NED, MSG_HIL_STATE_QUATERNION):
                    self.conn.mav.command_long_send(
                        self.sysid, 1, MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 1e6 / 30.0, 0, 0, 0, 0, 0
                    )
            elif kind == "LOCAL_POSITION_NED":
                self.estimate.append((now, -float(msg.z)))
            elif kind == "HIL_STATE_QUATERNION":
                self.truth.append((now, float(msg.alt) / 1000.0))

    def close(self) -> None:
        self.stop.set()
        self.join(timeout=2.0)
        self.conn.close()


def height_figures(
    estimate: list[tuple[float, float]], truth: list[tuple[float, float]], armed_s: float | None = None
) -> dict[str, Any]:
    """EKF2's height minus the truth's over the flight (the truth 0.3 m up first to last): EKF2's from its mean over
    the third of a second before ``armed_s`` (as masonry measures the ground when it arms: the last ten reports
    disarmed; without it, half a second before the take-off), the truth's from its first sample (at rest); and the
    seconds the airframe stood on SIH's ground meanwhile with EKF2 0.3 m or more above it."""
    if len(estimate) < 2 or len(truth) < 2:
        return {"samples": (len(estimate), len(truth))}
    t0 = truth[0][1]
    up = [i for i, (_, alt) in enumerate(truth) if alt - t0 > 0.3]
    if not up:
        return {"airborne": False}
    until_w = armed_s if armed_s is not None else next(w for w, alt in truth if alt - t0 > 0.05) - 0.5
    ground = [e for w, e in estimate if until_w - 1.0 / 3.0 <= w <= until_w] or [estimate[0][1]]
    e0 = sum(ground) / len(ground)
    errors, grounded_s, j = [], 0.0, 0
    for (w, alt), (w_next, _) in zip(truth[up[0] : up[-1]], truth[up[0] + 1 : up[-1] + 1], strict=True):
        while j + 1 < len(estimate) and estimate[j + 1][0] <= w:
            j += 1
        ekf_up, true_up = estimate[j][1] - e0, alt - t0
        errors.append(ekf_up - true_up)
        if true_up < GROUND_M and ekf_up > ABOVE_M:
            grounded_s += w_next - w
    rms = math.sqrt(sum(e * e for e in errors) / len(errors))
    return {"height_error_rms_m": round(rms, 3), "height_error_max_m": round(max(errors), 3),
            "height_error_min_m": round(min(errors), 3), "grounded_s": round(grounded_s, 1)}  # fmt: skip


def fly_a0(url: str, folder: Path, wall_s: float) -> dict[str, Any]:
    """``masonry fly --uav adhesion --task A0`` as the test flies it: its JSON result (or the reason there is none)."""
    config = folder / "uav.yaml"
    config.write_text("estimate_wait_s: 150\n")
    proc = masonry("fly", "--uav", "adhesion", "--task", "A0", "--blueprint", CASE_STUDY, "--fc", url,
                   "--actuators", "sim", "--camera", "sim", "--config", str(config), "--format", "json",
                   own_session=True)  # fmt: skip
    give_the_cpu(proc.pid)
    try:
        out, err = proc.communicate(timeout=wall_s)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        return {"status": "no result", "reason": f"no result within {wall_s:g} s of wall time"}
    (folder / "fly.err").write_text(err)
    results = [line for line in out.splitlines() if line.startswith("{")]
    if not results:
        return {"status": "no result", "reason": err.strip().splitlines()[-1:] or f"exit {proc.returncode}"}
    result: dict[str, Any] = json.loads(results[-1])
    return result


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-sh", type=Path, default=Path(__file__).resolve().parents[2] / "shared/px4/run.sh")
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--instance", type=int, default=7, help="PX4 instance (offboard link on 14540 + N)")
    ap.add_argument("--params", nargs="*", default=[], help="PX4 parameters at boot, NAME=VALUE")
    ap.add_argument("--wall", type=float, default=420.0, help="wall seconds a flight may take")
    args = ap.parse_args()
    os.environ[ENV] = str(args.run_sh.resolve())
    params = dict(p.split("=", 1) for p in args.params)
    rows = []
    for run in range(args.runs):
        with (
            tempfile.TemporaryDirectory() as tmp,
            one_flight_at_a_time(),
        ):  # (the tests' PX4s fly one at a time)
            recorder = Recorder(args.instance)
            recorder.start()
            try:
                with px4(Path(tmp) / "px4", args.instance, params) as url:
                    result = fly_a0(url, Path(tmp), args.wall)
            finally:
                recorder.close()
            figures = height_figures(recorder.estimate, recorder.truth, recorder.armed_s)
        row = {"run": run, "status": result.get("status"), "coverage": result.get("coverage"),
               "duration_s": result.get("duration_s"), "reason": result.get("reason"), **figures}  # fmt: skip
        rows.append(row)
        print(" ".join(f"{k}={v}" for k, v in row.items() if v is not None), flush=True)
    done = sum(r["status"] == "done" and (r["coverage"] or 0.0) >= 0.9 for r in rows)
    print(json.dumps({"params": params, "runs": len(rows), "done": done, "rows": rows}))


if __name__ == "__main__":
    main()
