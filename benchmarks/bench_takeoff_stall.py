"""ArduPilot's take-off on the project's SITL with the caller left unrun right after NAV_TAKEOFF's ACK (issue 29).

Flies ``tests/test_sitl.py``'s take-off (the SITL free at ``--time-scale``, telemetry at 50 Hz), holding the
calling thread ``STALL`` s of wall right after the take-off command returns (as a loaded machine may: the setpoint
stream's thread and the SITL run on), for each ``--stalls`` value, ``--runs`` times; then lets the climb settle and
prints where the vehicle stopped (true height), whether its climb is still under way, the last setpoint it applied
and the load average. With ``--stalls 0`` and many ``--runs`` it is the plain take-off in a loop (``--busy`` spins a
process on one core). Asserts nothing.

Usage: python benchmarks/bench_takeoff_stall.py [--stalls 0 0.05 0.1 0.15 0.2 0.5] [--time-scale 1] [--runs 1]
       [--busy]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from test_sitl import flight


def take_off(stall_s: float, time_scale: float) -> str:
    with flight(home_m=(1.0, 2.0, 0.0), time_scale=time_scale, telemetry_rate_hz=50.0) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(timeout_s=5.0)
        fc.arm()
        command = fc.command

        def held_after_the_ack(name: str, number: int, params: tuple[float, ...] = ()) -> None:
            command(name, number, params)
            if name == "takeoff" and stall_s > 0.0:
                time.sleep(stall_s)  # the caller left unrun: what the bench measures

        fc.command = held_after_the_ack  # type: ignore[method-assign]
        fc.takeoff(1.2)
        settle_s = 6.0 / time_scale + 1.0  # the climb takes about 3 s of the SITL's time
        end = time.monotonic() + settle_s
        while time.monotonic() < end:
            time.sleep(0.05)
        v = sitl.vehicle
        return (
            f"stopped at {v.position_m[2]:.3f} m (taking off {v.taking_off}), {sitl.setpoints_received} setpoints "
            f"applied, the last {sitl.last_setpoint_mps}"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stalls", type=float, nargs="*", default=[0.0, 0.05, 0.1, 0.15, 0.2, 0.5])
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--busy", action="store_true", help="a process spinning on one core throughout")
    args = ap.parse_args()
    busy = subprocess.Popen([sys.executable, "-c", "while True: pass"]) if args.busy else None
    try:
        for stall_s in args.stalls:
            for run in range(1, args.runs + 1):
                line = take_off(stall_s, args.time_scale)
                load = " ".join(f"{x:.1f}" for x in os.getloadavg())
                print(
                    f"x{args.time_scale:g}, held {stall_s:g} s after the ACK, run {run}: {line}; load {load}"
                )
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()


if __name__ == "__main__":
    main()
