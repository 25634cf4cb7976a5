"""Per-tick cost of the motion core: MinJerk re-planning and evaluation, and one PID step. Prints the figures.

Also the per-tick fast paths of the UAV machine against what they replace: ``MinJerk.sample_floats`` (one
sample as float tuples) against ``MinJerk.state`` (numpy) and against the hand-inlined Horner sums that
``fsm/model.py`` carried before, and ``geometry.body_to_world_floats`` against ``R_world_body(...) @ v``.

Each figure is the best of several rounds (the machine is shared; the minimum is the undisturbed cost).

    python benchmarks/bench_motion.py [--ticks 4000] [--rounds 7]
"""

from __future__ import annotations

import argparse
import math
import time
from collections.abc import Callable

import numpy as np

from masonry.geometry import R_world_body, body_to_world_floats
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

    t_floats = best_us(lambda i: traj.sample_floats(i * 7.0 / n), n, rounds)
    coef = traj.coefficients.T.tolist()
    t_inlined = best_us(lambda i: _inlined(coef, i * 7.0 / n, 7.0), n, rounds)
    att, off = (0.02, -0.03, 0.7), (0.0, 0.0, -0.25)
    t_rot_np = best_us(lambda i: R_world_body(*att) @ np.asarray(off), n, rounds)
    t_rot_fl = best_us(lambda i: body_to_world_floats(att, off), n, rounds)

    print(f"MinJerk.replan (new trajectory)       {t_replan:7.1f} us")
    print(f"MinJerk.state(t) (r, v, a at one t)   {t_state:7.1f} us")
    print(f"MinJerk.position, vectorised          {t_vec:7.1f} ns per sample")
    print(f"PID.step (3 axes + yaw)               {t_pid:7.1f} us")
    print(f"one guidance tick (replan+state+PID)  {t_replan + t_state + t_pid:7.1f} us")
    print(f"MinJerk.sample_floats (r, v, a)       {t_floats:7.2f} us  (state: x{t_state / t_floats:.1f})")
    print(f"  hand-inlined in fsm/model.py before {t_inlined:7.2f} us")
    print(f"R_world_body @ v (numpy)              {t_rot_np:7.2f} us")
    print(f"body_to_world_floats                  {t_rot_fl:7.2f} us  (x{t_rot_np / t_rot_fl:.1f})")


def _inlined(
    coef: list[list[float]], t: float, duration: float
) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """The Horner sums fsm/model.py wrote out per tick before ``sample_floats`` (reference and feed-forward)."""
    if t < 0.0:  # noqa: PLR1730
        t = 0.0
    if duration < t:  # noqa: PLR1730
        t = duration
    (a0, a1, a2, a3, a4, a5), (b0, b1, b2, b3, b4, b5), (c0, c1, c2, c3, c4, c5) = coef
    lag = 0.3
    ref = (
        ((((a5 * t + a4) * t + a3) * t + a2) * t + a1) * t + a0,
        ((((b5 * t + b4) * t + b3) * t + b2) * t + b1) * t + b0,
        ((((c5 * t + c4) * t + c3) * t + c2) * t + c1) * t + c0,
    )
    ff = (
        (((5.0 * a5 * t + 4.0 * a4) * t + 3.0 * a3) * t + 2.0 * a2) * t
        + a1
        + lag * (((20.0 * a5 * t + 12.0 * a4) * t + 6.0 * a3) * t + 2.0 * a2),
        (((5.0 * b5 * t + 4.0 * b4) * t + 3.0 * b3) * t + 2.0 * b2) * t
        + b1
        + lag * (((20.0 * b5 * t + 12.0 * b4) * t + 6.0 * b3) * t + 2.0 * b2),
        (((5.0 * c5 * t + 4.0 * c4) * t + 3.0 * c3) * t + 2.0 * c2) * t
        + c1
        + lag * (((20.0 * c5 * t + 12.0 * c4) * t + 6.0 * c3) * t + 2.0 * c2),
    )
    return ref, ff


if __name__ == "__main__":
    main()
