"""The offline schedule against the reactive fleet: prints a table, asserts nothing (docs/performance/schedule.md).

Per wall and fleet: ``masonry schedule``'s makespan and proven bound (CP-SAT, ``task`` reservation), its status
and solve time, then the simulated makespans of ``fifo``, ``critical-path`` and ``schedule`` (following it),
each as a ratio to the bound the report gives for that fleet (the best of its terms, CP-SAT's included).

Usage: python benchmarks/bench_schedule.py [--quick] [--time-limit S] [--workers N] [--walls a,b] [--fleets 1+1,2+1]
       [--no-sim]
"""

from __future__ import annotations

import argparse
import os
import time

from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.schedule_file import stamp_schedule
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.schedule import solve_schedule

HERE = os.path.dirname(os.path.abspath(__file__))
BUNDLED = ("paper_case_study", "towers", "running_bond_small", "pyramid", "running_bond_200")


def wall(name: str) -> Blueprint:
    if name == "12m":
        return running_bond(courses=3, bricks_per_course=40, placed_courses=1)
    return load_blueprint(os.path.join(HERE, "..", "blueprints", f"{name}.yaml"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--quick", action="store_true", help="case study and towers, 1+1 and 2+1, 5 s")
    ap.add_argument("--time-limit", type=float, default=30.0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--walls", default=",".join((*BUNDLED, "12m")))
    ap.add_argument("--fleets", default="1+1,2+1,4+2")
    ap.add_argument("--no-sim", action="store_true", help="the schedules only")
    args = ap.parse_args()
    walls = args.walls.split(",")
    fleets = [tuple(int(x) for x in f.split("+")) for f in args.fleets.split(",")]
    limit = args.time_limit
    if args.quick:
        walls, fleets, limit = ["paper_case_study", "towers"], [(1, 1), (2, 1)], 5.0
    print(
        f"time limit {limit:g} s, {args.workers} worker(s), cpu count {os.cpu_count()}, load {os.getloadavg()[0]:.1f}"
    )
    header = (
        f"{'wall':<20} {'tasks':>5} {'fleet':>5} {'status':<8} {'decomp':<6} {'solve':>6} {'cp-sat':>8} "
        f"{'bound':>8} {'kind':<15} {'fifo':>13} {'crit-path':>13} {'schedule':>13} {'followed':>9}"
    )
    print(header)
    for name in walls:
        bp0 = wall(name)
        for nb, na in fleets:
            fleet = fleet_for(bp0, nb, na)
            bp = with_fleet(bp0, fleet) if fleet != bp0.fleet else bp0
            p = make_plan(bp)
            n = sum(1 for t in p.tasks if not t.done)
            sched = stamp_schedule(
                solve_schedule(
                    p, fleet, cruise_altitude_m=bp.cruise_altitude_m, time_limit_s=limit, workers=args.workers
                ),
                bp,
            )
            row = (
                f"{name:<20} {n:>5} {nb}+{na:<3} {sched.status:<8} {sched.decomposition:<6} "
                f"{sched.solve_time_s:>5.1f}s {sched.makespan_s:>7.1f}s"
            )
            if args.no_sim:
                print(f"{row} {sched.bound_s:>7.1f}s {sched.bound_kind:<15}", flush=True)
                continue
            cells = []
            bound, kind, followed = 0.0, "", ""
            for policy in ("fifo", "critical-path", "schedule"):
                t0 = time.perf_counter()
                r = simulate(
                    bp, policy=policy, schedule=sched if policy == "schedule" else None, progress=None, seed=0
                )
                wall_s = time.perf_counter() - t0
                if policy == "schedule":
                    bound, kind = r.lower_bound_s, r.lower_bound_kind
                    followed = f"{r.schedule_followed}/{r.schedule_assignments}"
                done = "" if r.completed else "!"
                cells.append((r.makespan_s, done, wall_s))
            ratios = " ".join(f"{m:>6.0f}s {m / bound:>4.2f}{d}" for m, d, _ in cells)
            print(
                f"{row} {bound:>7.1f}s {kind:<15} {ratios} {followed:>9}  (sims {sum(c[2] for c in cells):.0f} s)",
                flush=True,
            )


if __name__ == "__main__":
    main()
