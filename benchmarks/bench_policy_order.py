"""fifo against critical-path when the blueprint lists its bricks course by course, and when it does not.

``fifo`` hands out available tasks in blueprint order; the generated walls list their bricks course by course,
which is already the critical path, so there the two policies are within the seed spread of each other. A
blueprint exported from a CAD model need not be in that order. This runs whole missions
(``masonry.mission.simulate``, separation on, geometric camera, 4 brick + 2 adhesion UAVs) on running bonds
listed course by course and column by column (by x, then bottom to top), fifo and critical-path, three seeds,
and prints the makespans and their means. Usage:

    .venv/bin/python benchmarks/bench_policy_order.py [--quick]
"""

from __future__ import annotations

import dataclasses
import statistics
import sys
import time

from masonry.blueprint import Blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import simulate


def column_order(bp: Blueprint) -> Blueprint:
    """The same wall with its bricks listed by x, then bottom to top (ids unchanged)."""
    return dataclasses.replace(
        bp, bricks=tuple(sorted(bp.bricks, key=lambda b: (round(b.position_m[0], 3), b.position_m[2])))
    )


def main() -> None:
    walls = [(2, 30)] if "--quick" in sys.argv else [(4, 25), (2, 30)]
    seeds = (0, 1, 2)
    print(
        f"{'wall':<6} {'listed':<8} {'policy':<13} | makespans (seeds {', '.join(map(str, seeds))}) | mean | wall s"
    )
    for courses, per in walls:
        base = running_bond(courses, per)
        for listed, bp in (("courses", base), ("columns", column_order(base))):
            means = {}
            for policy in ("fifo", "critical-path"):
                t0 = time.perf_counter()
                ms = []
                for seed in seeds:
                    r = simulate(bp, brick_uavs=4, adhesion_uavs=2, policy=policy, seed=seed)
                    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
                    ms.append(r.makespan_s)
                means[policy] = statistics.mean(ms)
                print(
                    f"{courses}x{per:<4} {listed:<8} {policy:<13} | {' '.join(f'{m:8.1f}' for m in ms)} | "
                    f"{means[policy]:8.1f} | {time.perf_counter() - t0:.0f}",
                    flush=True,
                )
            gain = means["critical-path"] / means["fifo"] - 1.0
            print(f"{courses}x{per:<4} {listed:<8} critical-path against fifo: {gain:+.1%}", flush=True)


if __name__ == "__main__":
    main()
