"""What the record of waits (issue 27, ``tasks[].waits``) costs a whole mission, and what it says: prints its
figures, asserts nothing.

Runs ``masonry.mission.simulate`` on a running bond, alternately with mission control's ``WaitWatch.observe``
switched off and on (the same process, so the same machine load as far as it can be), and prints each run's CPU
(process) time, then the waits of the last run summed per cause (task-seconds) and each UAV's waiting figures.

Usage: python benchmarks/bench_waits.py [--courses 3] [--per-course 30] [--brick-uavs 4] [--adhesion-uavs 2]
       [--runs 2] [--seed 0]
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

from masonry.blueprint_gen import running_bond
from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate
from masonry.mission.wait_causes import WaitWatch


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--courses", type=int, default=3)
    ap.add_argument("--per-course", type=int, default=30)
    ap.add_argument("--brick-uavs", type=int, default=4)
    ap.add_argument("--adhesion-uavs", type=int, default=2)
    ap.add_argument("--runs", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    bp = running_bond(
        args.courses, args.per_course, brick_uavs=args.brick_uavs, adhesion_uavs=args.adhesion_uavs
    )
    observe = WaitWatch.observe
    print(
        f"wall {args.courses}x{args.per_course}, {args.brick_uavs}+{args.adhesion_uavs} UAVs, seed {args.seed}, "
        "separation off"
    )
    report: MissionReport | None = None
    cpu: dict[str, list[float]] = {"without": [], "with": []}
    for _ in range(args.runs):
        for label in ("without", "with"):
            WaitWatch.observe = observe if label == "with" else _no_record  # type: ignore[method-assign]
            t0 = time.process_time()
            r = simulate(bp, seed=args.seed, separation=False)
            cpu[label].append(time.process_time() - t0)
            print(f"  {label:7s} the record: CPU {cpu[label][-1]:6.2f} s, makespan {r.makespan_s:.1f} s")
            if label == "with":
                report = r
    WaitWatch.observe = observe  # type: ignore[method-assign]
    for label, values in cpu.items():
        print(f"  {label:7s} the record: CPU " + ", ".join(f"{v:.2f}" for v in values) + " s")
    assert report is not None
    by_cause: Counter[str] = Counter()
    for t in report.tasks:
        for w in t.waits:
            by_cause[w.cause.what] += w.duration_s
    print("  waits (task-seconds): " + ", ".join(f"{k} {v:.0f}" for k, v in by_cause.most_common()))
    for u in report.uavs:
        print(
            f"  {u.name:<8} waiting_s {u.waiting_s:7.1f} (ground {u.waiting_ground_s:.1f}, air "
            f"{u.waiting_air_s:.1f}), idle_s {u.idle_s:7.1f}"
        )


def _no_record(self: WaitWatch, mc: object, now_s: float) -> None:
    """``WaitWatch.observe`` switched off."""


if __name__ == "__main__":
    main()
