"""Velocity setpoints from masonry's PID against position + velocity + acceleration setpoints, on ArduCopter SITL.

Issue 19 asks to choose, by measurement on the real autopilot, between two ways of flying the planned
trajectory: the outer PID (masonry.motion, the ``arducopter`` control preset) sending velocity setpoints, or the
trajectory's position, velocity and acceleration sent together (SET_POSITION_TARGET_LOCAL_NED, type mask
0x800: everything but the yaw rate) so that ArduCopter's own position controller closes the loop.

Both fly the same commands in one flight, as ``bench_vehicle_fit.py`` does: a hover, then a 1 m minimum-jerk leg
along x (the navigator's planned duration) and back, ``--hover`` seconds of hover after each; per leg it prints
the settle time (from the leg's planned end into the 3 cm / 0.08 m/s gate for 0.5 s), the hover error (rms
horizontal distance to the leg's end over the last half of the hover) and the swing (largest distance after the
planned end), and how far the UAV trailed its reference during the leg (``track``: the largest horizontal
distance to the reference position before the planned end).

It talks MAVLink itself (pymavlink), so that neither mode goes through the adapter's setpoint stream:

    ./arducopter --model hexa --speedup 1 -I0 --sysid 1 -w --defaults copter.parm,copter-hexa.parm \\
        --home -35.363261,149.165230,584,353          # in an empty folder (../shared/sitl/README.md)
    .venv/bin/python benchmarks/bench_setpoints.py --fc tcp:127.0.0.1:5760
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from pymavlink import mavutil

from masonry.blueprint import UavSpec
from masonry.fsm import UavConfig
from masonry.fsm.navigator import Navigator
from masonry.fsm.tuning import uav_settings
from masonry.motion import MinJerk
from masonry.ports import Telemetry

sys.path.insert(0, str(Path(__file__).resolve().parent))
from bench_vehicle_fit import Leg, _measure  # the same measures as the fit's

MASK_VELOCITY_YAW_RATE = 1 | 2 | 4 | 64 | 128 | 256 | 1024  # velocity only, yaw rate
MASK_POS_VEL_ACC_YAW = 2048  # position, velocity, acceleration and yaw (ignore the yaw rate)
EKF_READY = 0x33F  # ArduPilot EKF_STATUS_REPORT flags once it uses GPS (../shared/sitl/README.md)
DT_S = 0.1  # the state machines' control period


class Sitl:
    """One ArduCopter over MAVLink: its latest local position (ENU, its local origin) on its own clock."""

    def __init__(self, url: str) -> None:
        self.mav: Any = mavutil.mavlink_connection(url, source_system=245, source_component=190)
        self.mav.wait_heartbeat(timeout=30)
        self.t_s = -1.0
        self.p = np.zeros(3)
        self.v = np.zeros(3)
        self.yaw_rad = 0.0
        self.armed = False
        self.ekf = 0
        for msg_id, hz in ((32, 20.0), (30, 20.0), (193, 2.0)):  # LOCAL_POSITION_NED, ATTITUDE, EKF_STATUS
            self.mav.mav.command_long_send(
                self.mav.target_system, self.mav.target_component,
                mavutil.mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, msg_id, 1e6 / hz, 0, 0, 0, 0, 0,
            )  # fmt: skip

    def pump(self, until_s: float | None = None, wall_timeout_s: float = 5.0) -> None:
        """Read messages (until its clock passes ``until_s``, or once through what is waiting)."""
        wall_end = time.monotonic() + wall_timeout_s
        while True:
            msg = self.mav.recv_match(blocking=until_s is not None, timeout=0.05)
            if msg is not None:
                kind = msg.get_type()
                if kind == "LOCAL_POSITION_NED":
                    self.t_s = msg.time_boot_ms / 1000.0
                    self.p = np.array([msg.y, msg.x, -msg.z])
                    self.v = np.array([msg.vy, msg.vx, -msg.vz])
                elif kind == "ATTITUDE":
                    self.yaw_rad = math.pi / 2.0 - msg.yaw
                elif kind == "HEARTBEAT" and msg.get_srcComponent() == 1:
                    self.armed = bool(msg.base_mode & mavutil.mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
                elif kind == "EKF_STATUS_REPORT":
                    self.ekf = msg.flags
            elif until_s is None:
                return
            if until_s is not None and self.t_s >= until_s:
                return
            if time.monotonic() > wall_end:
                raise SystemExit(f"no telemetry from the SITL for {wall_timeout_s} s")

    def telemetry(self) -> Telemetry:
        return Telemetry(
            self.t_s, tuple(self.p), tuple(self.v), (0.0, 0.0, self.yaw_rad), self.armed, "GUIDED", 1.0, True,
            True, False,
        )  # fmt: skip

    def command(self, cmd: int, *params: float) -> None:
        p = (list(params) + [0.0] * 7)[:7]
        self.mav.mav.command_long_send(self.mav.target_system, self.mav.target_component, cmd, 0, *p)

    def send(self, mask: int, p: Any = (0, 0, 0), v: Any = (0, 0, 0), a: Any = (0, 0, 0), yaw_rate: float = 0.0,
             yaw_rad: float = 0.0) -> None:  # fmt: skip
        """A SET_POSITION_TARGET_LOCAL_NED from ENU values."""
        self.mav.mav.set_position_target_local_ned_send(
            0, self.mav.target_system, self.mav.target_component, mavutil.mavlink.MAV_FRAME_LOCAL_NED, mask,
            p[1], p[0], -p[2], v[1], v[0], -v[2], a[1], a[0], -a[2], math.pi / 2.0 - yaw_rad, -yaw_rate,
        )  # fmt: skip

    def take_off(self, altitude_m: float) -> None:
        deadline = time.monotonic() + 200.0
        while not (self.ekf & EKF_READY == EKF_READY and self.t_s > 0):
            if time.monotonic() > deadline:
                raise SystemExit(f"EKF not ready (flags {self.ekf:#x})")
            self.pump(self.t_s + 1.0, 30.0)
        self.mav.set_mode("GUIDED")
        asked = -1e9
        while not self.armed:
            if self.t_s - asked > 2.0:
                self.command(mavutil.mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
                asked = self.t_s
            if time.monotonic() > deadline:
                raise SystemExit("did not arm")
            self.pump(self.t_s + 0.2)
        self.command(mavutil.mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, altitude_m)
        while not (self.p[2] > altitude_m - 0.15 and abs(self.v[2]) < 0.1):
            if time.monotonic() > deadline:
                raise SystemExit(f"take-off not done: z {self.p[2]:.2f} m")
            self.pump(self.t_s + DT_S)


def fly(sitl: Sitl, mode: str, hover_s: float) -> list[tuple[Leg, float]]:
    """Hover, then the 1 m leg and back in ``mode`` (``velocity``: the PID; ``position``: pos + vel + acc)."""
    config = UavConfig.from_spec(UavSpec("u", "brick", (0.0, 0.0, 0.0)), **uav_settings("arducopter"))
    nav = Navigator(config)
    nav.hold(sitl.t_s, sitl.telemetry())
    yaw = sitl.yaw_rad
    traj: MinJerk | None = None
    t0 = sitl.t_s

    def run(seconds: float) -> list[tuple[float, Any, Any, float]]:
        out = []
        end = sitl.t_s + seconds
        while sitl.t_s < end:
            now = sitl.t_s
            tel = sitl.telemetry()
            if traj is None or now - t0 >= traj.duration_s:
                ref_p = np.asarray(nav.target_m, dtype=float)
                ref_v = ref_a = np.zeros(3)
            else:
                s = now - t0
                ref_p, ref_v, ref_a = traj.position(s), traj.velocity(s), traj.acceleration(s)
            if mode == "velocity":
                sp = nav.step(now, tel)
                sitl.send(MASK_VELOCITY_YAW_RATE, v=sp.velocity_mps, yaw_rate=sp.yaw_rate_radps)
            else:
                sitl.send(MASK_POS_VEL_ACC_YAW, p=ref_p, v=ref_v, a=ref_a, yaw_rad=yaw)
            out.append((now, sitl.p.copy(), sitl.v.copy(), float(np.linalg.norm((sitl.p - ref_p)[:2]))))
            sitl.pump(now + DT_S)
        return out

    run(3.0)
    legs = []
    for dx in (1.0, -1.0):
        start = np.asarray(nav.target_m, dtype=float)
        target = start + np.array([dx, 0.0, 0.0])
        nav.fly_to(sitl.t_s, sitl.telemetry(), target)
        t0 = sitl.t_s
        traj = MinJerk(start, np.zeros(3), np.zeros(3), target, np.zeros(3), np.zeros(3), nav.end_s - t0)
        samples = run((nav.end_s - sitl.t_s) + hover_s)
        track = max((d for t, *_, d in samples if t < nav.end_s), default=math.nan)
        legs.append((_measure([(t, p, v) for t, p, v, _ in samples], nav.end_s, target, hover_s), track))
    return legs


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--fc", required=True, help="the SITL's MAVLink URL (tcp:127.0.0.1:5760)")
    ap.add_argument("--hover", type=float, default=10.0, help="seconds of hover after each leg")
    ap.add_argument("--repeats", type=int, default=2, help="times each mode is flown (alternating)")
    args = ap.parse_args()
    sitl = Sitl(args.fc)
    sitl.take_off(1.5)
    results: dict[str, list[tuple[Leg, float]]] = {"velocity": [], "position": []}
    for _ in range(args.repeats):
        for mode in ("velocity", "position"):
            legs = fly(sitl, mode, args.hover)
            results[mode] += legs
            for leg, track in legs:
                settle = "-" if leg.settle_s is None else f"{leg.settle_s:5.2f} s"
                print(
                    f"{mode:<9} settle {settle:>8}, hover error {leg.hover_error_m * 100:5.2f} cm, "
                    f"swing {leg.swing_m * 100:5.1f} cm, track {track * 100:5.1f} cm",
                    flush=True,
                )
    for mode, legs in results.items():
        settles = [leg.settle_s for leg, _ in legs if leg.settle_s is not None]
        print(
            f"{mode}: settled {len(settles)}/{len(legs)}, mean settle "
            f"{(sum(settles) / len(settles)) if settles else math.nan:.2f} s, mean hover error "
            f"{np.mean([leg.hover_error_m for leg, _ in legs]) * 100:.2f} cm, max swing "
            f"{max(leg.swing_m for leg, _ in legs) * 100:.1f} cm, max track {max(t for _, t in legs) * 100:.1f} cm"
        )
    sitl.command(mavutil.mavlink.MAV_CMD_NAV_LAND)


if __name__ == "__main__":
    main()
