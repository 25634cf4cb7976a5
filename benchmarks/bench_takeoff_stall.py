"""ArduPilot's take-off on the project's SITL with the caller left unrun right after NAV_TAKEOFF's ACK (issue 29).

Flies ``tests/test_sitl.py``'s take-off (the SITL free at ``--time-scale``, telemetry at 50 Hz), holding the
calling thread ``STALL`` s of wall right after the take-off command returns (as a loaded machine may: the setpoint
stream's thread and the SITL run on), for each ``--stalls`` value, ``--runs`` times; then lets the climb settle and
prints where the vehicle stopped (true height), whether its climb is still under way, the last setpoint it applied
and the load average. With ``--stalls 0`` and many ``--runs`` it is the plain take-off in a loop (``--busy`` spins a
process on one core). Asserts nothing.

``--ardupilot``: the same hold against ArduCopter's own SITL (``MASONRY_ARDUPILOT_SITL``, tests/ardupilot_sitl.py,
instance ``--instance``, at ``--speedup``): one SITL, its estimate waited for once, then for each stall ``--runs``
take-offs to 1.2 m (arm in GUIDED, NAV_TAKEOFF, the hold, ``--settle`` s of its clock, LAND, disarmed); prints
each take-off's highest and last height above where it armed and a count of those that reached 1.1 m. Run it
with ``PYTHONPATH`` an older ``src/`` to compare adapters.

Usage: python benchmarks/bench_takeoff_stall.py [--stalls 0 0.05 0.1 0.15 0.2 0.5] [--time-scale 1] [--runs 1]
       [--busy]
       MASONRY_ARDUPILOT_SITL=$(realpath ../shared/sitl/arducopter) python benchmarks/bench_takeoff_stall.py
       --ardupilot [--stalls 0.1 0.2 0.5] [--runs 10] [--speedup 2] [--settle 10] [--instance 46]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from ardupilot_sitl import REACHED_M, arducopter, ardupilot_take_off, hold_after_the_ack
from masonry.adapters.mavlink import MavlinkFlightController
from test_sitl import flight


def take_off(stall_s: float, time_scale: float) -> str:
    with flight(home_m=(1.0, 2.0, 0.0), time_scale=time_scale, telemetry_rate_hz=50.0) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(timeout_s=5.0)
        fc.arm()
        hold_after_the_ack(fc, stall_s)
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


def ardupilot_main(args: argparse.Namespace) -> None:
    with (
        TemporaryDirectory() as tmp,
        arducopter(Path(tmp), args.instance, args.instance + 1, speedup=args.speedup) as url,
    ):
        fc = MavlinkFlightController(url, heartbeat_timeout_s=5.0, estimate_timeout_s=300.0)
        fc.connect()
        try:
            fc.wait_for_estimate()
            for stall_s in args.stalls:
                reached = 0
                for run in range(1, args.runs + 1):
                    ok, line = ardupilot_take_off(fc, stall_s, args.settle)
                    reached += ok
                    load = " ".join(f"{x:.1f}" for x in os.getloadavg())
                    print(
                        f"ArduCopter x{args.speedup}, held {stall_s:g} s after the ACK, run {run}: {line}; "
                        f"load {load}",
                        flush=True,
                    )
                print(
                    f"ArduCopter x{args.speedup}, held {stall_s:g} s: {reached} of {args.runs} reached {REACHED_M} m"
                )
        finally:
            fc.close()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--stalls", type=float, nargs="*", default=[0.0, 0.05, 0.1, 0.15, 0.2, 0.5])
    ap.add_argument("--time-scale", type=float, default=1.0)
    ap.add_argument("--runs", type=int, default=1)
    ap.add_argument("--busy", action="store_true", help="a process spinning on one core throughout")
    ap.add_argument(
        "--ardupilot", action="store_true", help="against ArduCopter's SITL (MASONRY_ARDUPILOT_SITL)"
    )
    ap.add_argument("--speedup", type=int, default=2, help="--ardupilot: the SITL's speed-up")
    ap.add_argument(
        "--settle", type=float, default=10.0, help="--ardupilot: s of its clock after the take-off"
    )
    ap.add_argument("--instance", type=int, default=46, help="--ardupilot: the SITL's -I (TCP 5760 + 10 N)")
    args = ap.parse_args()
    if args.ardupilot:
        ardupilot_main(args)
        return
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
