"""tests/test_sitl.py's minimum-jerk descent, free on the wall and in lock-step, N runs: its figures under load.

The test (``test_connect_arm_takeoff_minimum_jerk_descent_land``) takes off to 1.2 m on the project's SITL and
tracks a minimum-jerk descent of 0.6 m in 3 s with feedforward + P every 0.02 s, asserting the worst distance
from the trajectory (< 0.1 m) and the end's from the goal (< 0.025 m). ``--mode free`` flies it as the test did
before issue 29's lock-step (the SITL free at ``--time-scale``, the loop paced by ``time.sleep(0.02)``); ``--mode
lockstep`` as it does now (the SITL held between the loop's grants of 0.02 s, ``test_sitl.minimum_jerk_descent``).
A process spins on one core unless ``--no-busy``. Prints one line per run (worst, end, the loop's steps, the wall
seconds, the load average) and the spread of each figure; asserts nothing.

Usage: python benchmarks/bench_sitl_descent.py [--mode free|lockstep] [--runs 10] [--time-scale 1] [--no-busy]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from masonry.motion import MinJerk
from test_sitl import (
    LOCKSTEP_WAIT_S,
    LockstepClock,
    flight,
    minimum_jerk_descent,
    step_until,
    take_off,
    take_off_granted,
    wait_until,
)

HOME_M = (1.0, 2.0, 0.0)


def free(time_scale: float) -> dict[str, float]:
    """The test's flight before lock-step: the loop on the wall."""
    with flight(home_m=HOME_M, time_scale=time_scale, telemetry_rate_hz=50.0) as (_sitl, fc):
        fc.connect()
        fc.wait_for_estimate(timeout_s=2.0)
        take_off(fc, 1.2)
        start = np.array(fc.telemetry().position_m)
        goal = start - np.array([0.0, 0.0, 0.6])
        traj = MinJerk(start, np.zeros(3), np.zeros(3), goal, np.zeros(3), np.zeros(3), 3.0)
        t0, worst, steps = fc.clock.now_s(), 0.0, 0
        while (t := fc.clock.now_s() - t0) < traj.duration_s + 3.0:
            p = np.array(fc.telemetry().position_m)
            if t < traj.duration_s:
                worst = max(worst, float(np.linalg.norm(traj.position(t) - p)))
            elif np.linalg.norm(goal - p) < 0.02:
                break
            tt = min(t, traj.duration_s)
            fc.send_velocity(tuple(traj.velocity(tt) + 1.5 * (traj.position(tt) - p)), 0.0)
            steps += 1
            time.sleep(0.02)
        end = float(np.linalg.norm(np.array(fc.telemetry().position_m) - goal))
        return {"worst_m": worst, "end_m": end, "steps": steps}


def lockstep(time_scale: float) -> dict[str, float]:
    """The test's flight now: every wait on the SITL's time, granted."""
    with flight(
        home_m=HOME_M, time_scale=time_scale, telemetry_rate_hz=50.0, lockstep_wait_s=LOCKSTEP_WAIT_S
    ) as (
        sitl,
        fc,
    ):
        clock = LockstepClock(fc)
        fc.connect()
        wait_until(lambda: clock.sleep(0.0) or clock.lockstep, 10.0, "the SITL's lock-step announcement")
        step_until(clock, lambda: fc.telemetry().position_ok, 2.0, "the position estimate")
        take_off_granted(fc, clock, 1.2)
        grants = clock.grants
        worst, end = minimum_jerk_descent(fc, clock)
        free_runs = sitl.lockstep.free_runs if sitl.lockstep is not None else -1
        return {
            "worst_m": worst,
            "end_m": end,
            "steps": clock.grants - grants,
            "late_replies": clock.late_replies,
            "free_runs": free_runs,
        }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mode", choices=("free", "lockstep"), default="lockstep")
    ap.add_argument("--runs", type=int, default=10)
    ap.add_argument(
        "--time-scale", type=float, default=None, help="default: 1 free (the test's x1), 8 lockstep"
    )
    ap.add_argument("--no-busy", action="store_true", help="no process spinning on a core")
    args = ap.parse_args()
    scale = args.time_scale if args.time_scale is not None else (1.0 if args.mode == "free" else 8.0)
    busy = None if args.no_busy else subprocess.Popen([sys.executable, "-c", "while True: pass"])
    figures: dict[str, list[float]] = {"worst_m": [], "end_m": []}
    try:
        for run in range(1, args.runs + 1):
            started = time.monotonic()
            out = (free if args.mode == "free" else lockstep)(scale)
            wall_s = time.monotonic() - started
            for k in figures:
                figures[k].append(out[k])
            load = " ".join(f"{x:.1f}" for x in os.getloadavg())
            shown = {k: (round(v, 5) if isinstance(v, float) else v) for k, v in out.items()}
            print(
                f"run {run:2d} ({args.mode}, x{scale:g}): {json.dumps(shown)}, {wall_s:.2f} s of wall, load {load}"
            )
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    for k, v in figures.items():
        print(f"{k}: {min(v):.5f}-{max(v):.5f} over {len(v)} runs ({len(set(v))} distinct)")


if __name__ == "__main__":
    main()
