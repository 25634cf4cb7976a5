"""What PX4 v1.16 SITL answers to OFFBOARD without a setpoint stream (issue 29), with pymavlink alone.

Starts one PX4 (``../shared/px4/run.sh``, instance 8 by default), waits out its first-seconds arming refusals,
then prints: COM_OF_LOSS_T; the COMMAND_ACK of MAV_CMD_DO_SET_MODE OFFBOARD (main mode 6) disarmed with no
setpoint ever sent, and of the arming in it; for each gap after a 5-setpoint zero burst at 20 Hz (the client's),
the mode's and the arming's answers (from the longest gap down, until one arms); and, armed in POSCTL with the
stream stopped 1.5 s, the answer to OFFBOARD. Every STATUSTEXT heard on the link is printed too.

    python benchmarks/bench_px4_offboard.py --run-sh ../shared/px4/run.sh
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import threading
import time
from pathlib import Path

from pymavlink import mavutil

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from px4_sitl import ENV, px4

SET_MODE, ARM = 176, 400
OFFBOARD, POSCTL = 6, 3
ZERO_VELOCITY_MASK = 0b0000110111000111


class Probe:
    def __init__(self, url: str) -> None:
        self.m = mavutil.mavlink_connection(url, source_system=255)
        self.m.wait_heartbeat(timeout=60)
        self.streaming = threading.Event()
        self.texts: list[str] = []
        threading.Thread(target=self._stream, daemon=True).start()

    def _stream(self) -> None:
        while True:
            if self.streaming.is_set():
                self.zero()
            time.sleep(0.05)

    def zero(self) -> None:
        self.m.mav.set_position_target_local_ned_send(
            0, self.m.target_system, 1, 1, ZERO_VELOCITY_MASK, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0
        )

    def command(self, cmd: int, p1: float, p2: float = 0.0) -> int | None:
        self.m.mav.command_long_send(self.m.target_system, 1, cmd, 0, p1, p2, 0, 0, 0, 0, 0)
        end = time.monotonic() + 2.0
        while time.monotonic() < end:
            msg = self.m.recv_match(type=["COMMAND_ACK", "STATUSTEXT"], blocking=True, timeout=0.3)
            if msg is not None and msg.get_type() == "STATUSTEXT":
                self.texts.append(msg.text)
            elif msg is not None and msg.command == cmd:
                return int(msg.result)
        return None

    def param(self, name: str) -> float | None:
        for _ in range(5):  # asked again: a PARAM_VALUE can be lost
            self.m.mav.param_request_read_send(self.m.target_system, 1, name.encode(), -1)
            end = time.monotonic() + 1.0
            while time.monotonic() < end:
                msg = self.m.recv_match(type="PARAM_VALUE", blocking=True, timeout=0.5)
                if msg is not None and msg.param_id == name:
                    return float(msg.param_value)
        return None


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-sh", type=Path, default=Path(__file__).resolve().parents[2] / "shared/px4/run.sh")
    ap.add_argument("--instance", type=int, default=8, help="PX4 instance (offboard link on 14540 + N)")
    args = ap.parse_args()
    os.environ[ENV] = str(args.run_sh.resolve())
    out: dict[str, object] = {}
    with tempfile.TemporaryDirectory() as tmp, px4(Path(tmp), args.instance) as url:
        p = Probe(url)
        time.sleep(8.0)  # PX4 refuses every arming for about 3 s after its first HEARTBEAT
        out["COM_OF_LOSS_T"] = p.param("COM_OF_LOSS_T")
        out["offboard_disarmed_no_setpoints"] = p.command(SET_MODE, 1, OFFBOARD)
        out["arm_no_setpoints"] = p.command(ARM, 1)
        gaps = {}
        for gap_s in (1.5, 1.2, 1.0, 0.8, 0.6, 0.4, 0.2):
            p.command(SET_MODE, 1, POSCTL)
            for _ in range(5):
                p.zero()
                time.sleep(0.05)
            time.sleep(gap_s)
            gaps[gap_s] = (p.command(SET_MODE, 1, OFFBOARD), p.command(ARM, 1))
            print(
                f"zero burst, then {gap_s} s: set mode OFFBOARD -> {gaps[gap_s][0]}, arm -> {gaps[gap_s][1]}"
            )
            if gaps[gap_s][1] == 0:
                break
        out["burst_gap_s: (mode, arm)"] = {str(k): v for k, v in gaps.items()}
        if gaps[gap_s][1] == 0:  # armed in OFFBOARD: POSCTL, the stream stopped, OFFBOARD again
            p.streaming.set()
            p.command(SET_MODE, 1, POSCTL)
            p.streaming.clear()
            time.sleep(1.5)
            out["offboard_armed_stream_stopped_1.5s"] = p.command(SET_MODE, 1, OFFBOARD)
        p.command(ARM, 0)
        out["statustexts"] = p.texts
    print("MAV_RESULT: 0 ACCEPTED, 1 TEMPORARILY_REJECTED, 2 DENIED, 4 FAILED")
    print(json.dumps(out))


if __name__ == "__main__":
    main()
