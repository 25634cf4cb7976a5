"""Per-tick cost of the motion core: MinJerk re-planning and evaluation, and one PID step. Prints the figures.

Each figure is the best of several rounds (the machine is shared; the minimum is the undisturbed cost).

    python benchmarks/bench_motion.py [--ticks 4000] [--rounds 7]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np

from masonry.motion import PID, MinJerk


def best_us(fn: Callable[[int], object], ticks: int, rounds: int) -> float:
    best = math.inf
    for _ in range(rounds):
        t0 = time.perf_counter()
        for i in range(ticks):
            fn(i)
        best = min(best, (time.perf_counter() - t0) / ticks * 1e6)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--ticks", type=int, default=4000)
    parser.add_argument("--rounds", type=int, default=7)
    args = parser.parse_args()
    n, rounds = args.ticks, args.rounds
    traj = MinJerk([0, 0, 1.2], [0, 0, 0], [0, 0, 0], [0.3, -0.2, 0.15], [0, 0, 0], [0, 0, 0], 7.0)
    r, v, a = traj.state(1.0)
    pid = PID()
    pos, target = np.array([0.0, 0.0, 1.0]), np.array([0.3, -0.2, 0.15])

    t_replan = best_us(lambda i: traj.replan(r, v, a, 6.0 - i * 1e-5), n, rounds)
    t_state = best_us(lambda i: traj.state(i * 7.0 / n), n, rounds)
    t_pid = best_us(
        lambda i: pid.step(
            i * 0.02, pos, target, velocity_ff_mps=(0.01, 0.0, -0.1), yaw_rad=0.1, target_yaw_rad=0.0
        ),
        n,
        rounds,
    )
    times = np.linspace(0.0, 7.0, 100_000)
    t_vec = best_us(lambda i: traj.position(times), 1, rounds) / len(times) * 1e3

    print(f"MinJerk.replan (new trajectory)       {t_replan:7.1f} us")
    print(f"MinJerk.state(t) (r, v, a at one t)   {t_state:7.1f} us")
    print(f"MinJerk.position, vectorised          {t_vec:7.1f} ns per sample")
    print(f"PID.step (3 axes + yaw)               {t_pid:7.1f} us")
    print(f"one guidance tick (replan+state+PID)  {t_replan + t_state + t_pid:7.1f} us")


if __name__ == "__main__":
    main()
