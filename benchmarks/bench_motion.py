"""Per-tick cost of the motion core: MinJerk re-planning and evaluation, and one PID step. Prints the figures.

python benchmarks/bench_motion.py [--ticks 20000]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from masonry.motion import PID, MinJerk


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=20000)
    args = parser.parse_args()
    n = args.ticks
    traj = MinJerk([0, 0, 1.2], [0, 0, 0], [0, 0, 0], [0.3, -0.2, 0.15], [0, 0, 0], [0, 0, 0], 7.0)
    r, v, a = traj.state(1.0)

    t0 = time.perf_counter()
    for i in range(n):
        traj.replan(r, v, a, 6.0 - i * 1e-5)
    t_replan = (time.perf_counter() - t0) / n * 1e6

    t0 = time.perf_counter()
    for i in range(n):
        traj.state(i * 7.0 / n)
    t_state = (time.perf_counter() - t0) / n * 1e6

    times = np.linspace(0.0, 7.0, 100_000)
    t0 = time.perf_counter()
    traj.position(times)
    t_vec = (time.perf_counter() - t0) / len(times) * 1e9

    pid = PID()
    pos, target = np.array([0.0, 0.0, 1.0]), np.array([0.3, -0.2, 0.15])
    t0 = time.perf_counter()
    for i in range(n):
        pid.step(i * 0.02, pos, target, velocity_ff_mps=(0.01, 0.0, -0.1), yaw_rad=0.1, target_yaw_rad=0.0)
    t_pid = (time.perf_counter() - t0) / n * 1e6

    print(f"MinJerk.replan (new trajectory)       {t_replan:7.1f} us")
    print(f"MinJerk.state(t) (r, v, a at one t)   {t_state:7.1f} us")
    print(f"MinJerk.position, vectorised          {t_vec:7.1f} ns per sample")
    print(f"PID.step (3 axes + yaw)               {t_pid:7.1f} us")
    print(f"one guidance tick (replan+state+PID)  {t_replan + t_state + t_pid:7.1f} us")


if __name__ == "__main__":
    main()
