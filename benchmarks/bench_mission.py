"""Mission simulation benchmarks (issue 5, section 4): prints its figures, asserts nothing.

1. A 1,000-brick running bond (20 courses x 50 bricks) with 4 brick and 2 adhesion UAVs, geometric camera:
   wall time and real-time factor of ``masonry.mission.simulate``.
2. Makespan / lower bound for each dispatch policy on a few walls and fleets.

Usage: python benchmarks/bench_mission.py [--quick] [--skip-big] [--courses C --per-course N]
"""

from __future__ import annotations

import argparse
import time

from masonry.blueprint_gen import running_bond, towers
from masonry.mission.simulate import simulate


def big_wall(courses: int, per_course: int) -> None:
    bp = running_bond(courses, per_course, brick_uavs=4, adhesion_uavs=2)
    t0 = time.perf_counter()
    r = simulate(bp, camera="geometric")
    wall = time.perf_counter() - t0
    done = sum(1 for t in r.tasks if t.status == "done")
    print(f"running bond {courses}x{per_course} = {len(bp.bricks)} bricks, 4 brick + 2 adhesion UAVs, geometric camera")
    print(f"  tasks done {done}/{len(r.tasks)}, completed {r.completed}")
    print(f"  simulated {r.sim_time_s:.0f} s in {wall:.1f} s wall: real-time factor x{r.sim_time_s / wall:.0f}")
    print(f"  makespan {r.makespan_s:.0f} s, lower bound {r.lower_bound_s:.0f} s, "
          f"ratio {r.makespan_s / max(r.lower_bound_s, 1e-9):.2f}")
    print(f"  messages {r.messages}, violations: conflict {r.conflict_violations}, "
          f"dependency {r.dependency_violations}")


def policies(quick: bool) -> None:
    walls = [
        ("running bond 2x8, 2+1 UAVs", running_bond(2, 8, brick_uavs=2, adhesion_uavs=1)),
        ("towers 3x3 (2 m apart), 3+2 UAVs", towers(3, 3, spacing_m=2.0, brick_uavs=3, adhesion_uavs=2)),
    ]
    if not quick:
        walls.append(("running bond 3x12, 4+2 UAVs", running_bond(3, 12, brick_uavs=4, adhesion_uavs=2)))
    print("makespan / lower bound per policy (seed 0):")
    print(f"  {'wall':<36} {'policy':<14} {'makespan s':>10} {'bound s':>8} {'ratio':>6} {'wall s':>7}")
    for label, bp in walls:
        for policy in ("fifo", "critical-path", "nearest"):
            t0 = time.perf_counter()
            r = simulate(bp, policy=policy)
            wall = time.perf_counter() - t0
            print(f"  {label:<36} {policy:<14} {r.makespan_s:10.1f} {r.lower_bound_s:8.1f} "
                  f"{r.makespan_s / max(r.lower_bound_s, 1e-9):6.2f} {wall:7.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer policy walls")
    ap.add_argument("--skip-big", action="store_true", help="skip the 1,000-brick wall")
    ap.add_argument("--courses", type=int, default=20)
    ap.add_argument("--per-course", type=int, default=50)
    args = ap.parse_args()
    policies(args.quick)
    if not args.skip_big:
        big_wall(args.courses, args.per_course)


if __name__ == "__main__":
    main()
