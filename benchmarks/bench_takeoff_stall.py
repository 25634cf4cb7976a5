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

from ardupilot_sitl import arducopter
from masonry.adapters.mavlink import MavlinkFlightController
from test_sitl import flight

#: A take-off on ArduCopter counts as reaching its 1.2 m from this height above where it armed.
REACHED_M = 1.1


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


def _hold_after_the_ack(fc: MavlinkFlightController, stall_s: float) -> None:
    command = fc.command

    def held_after_the_ack(name: str, number: int, params: tuple[float, ...] = ()) -> None:
        command(name, number, params)
        if name == "takeoff" and stall_s > 0.0:
            time.sleep(stall_s)  # the caller left unrun: what the bench measures

    fc.command = held_after_the_ack  # type: ignore[method-assign]


def _wait_autopilot_s(fc: MavlinkFlightController, span_s: float, wall_limit_s: float) -> float:
    """Wait ``span_s`` of the autopilot's clock (at most ``wall_limit_s`` of wall); the highest height seen."""
    start, end, top = fc.clock.now_s(), time.monotonic() + wall_limit_s, -float("inf")
    while fc.clock.now_s() - start < span_s and time.monotonic() < end:
        top = max(top, fc.telemetry().position_m[2])
        time.sleep(0.02)
    return top


def ardupilot_take_off(fc: MavlinkFlightController, stall_s: float, settle_s: float) -> tuple[bool, str]:
    """One take-off to 1.2 m on ArduCopter held ``stall_s`` after the ACK, then LAND: (reached, its line)."""
    vars(fc).pop("command", None)  # the last take-off's hold
    fc.arm()
    ground = fc.telemetry().position_m[2]
    _hold_after_the_ack(fc, stall_s)
    fc.takeoff(1.2)
    top = _wait_autopilot_s(fc, settle_s, wall_limit_s=60.0) - ground
    tel = fc.telemetry()
    last = tel.position_m[2] - ground
    fc.land()
    _wait_disarmed(fc)
    reached = last >= REACHED_M
    return reached, f"highest {top:.3f} m, last {last:.3f} m, armed {tel.armed}, mode {tel.mode}"


def _wait_disarmed(fc: MavlinkFlightController, wall_limit_s: float = 90.0) -> None:
    end = time.monotonic() + wall_limit_s
    while fc.telemetry().armed and time.monotonic() < end:
        time.sleep(0.05)
    if fc.telemetry().armed:
        raise RuntimeError("ArduCopter did not disarm after LAND")


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
