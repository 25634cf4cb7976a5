"""When the brick UAVs hold (issue 27 section 4): the brick attempts by when they were given, and the waits of the
brick tasks by cause and by the role of the UAV in the way; prints Markdown, asserts nothing.

Flies each wall and fleet as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``, geometric camera,
:func:`bench_fleet.simulate_fleet`) and reads the JSON report's attempts and waits:

1. per window of ``--window-s`` (200 s) by when each brick attempt was given: how many, the mean attempt, its
   ``holding`` + ``waiting`` phases and its ``transit``; then the excess hold of the first ``--early-s`` (400 s)
   over the mean hold of the attempts given from ``--late-s`` (600 s) on, in brick-UAV seconds and divided by
   the brick UAVs (the makespan it is worth if the brick UAVs are the pace, as they are on the 12 m wall at 4 + 2
   from ~100 s: docs/performance/fleet.md, "Where the 12 m wall's 4 + 2 loses its time");
2. the brick tasks' waits while assigned (``site``, ``airspace`` with what of the other UAV held them,
   ``battery``) summed in task-seconds by the role of the UAV in the way.

Usage: python benchmarks/bench_brick_hold.py [--walls 12m] [--fleets 4+2] [--seeds 1,2,3]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet, walls_and_fleets

from masonry.mission.report import MissionReport


def windows(report: MissionReport, window_s: float) -> dict[int, tuple[int, float, float, float]]:
    """Window index -> (brick attempts given in it, their summed duration, hold (holding + waiting), transit)."""
    out: dict[int, tuple[int, float, float, float]] = {}
    for a in report.attempts:
        if a.kind != "brick" or a.phases is None:
            continue
        k = int(a.start_s // window_s)
        n, total, hold, transit = out.get(k, (0, 0.0, 0.0, 0.0))
        p = a.phases
        out[k] = (n + 1, total + p.total_s, hold + p.holding + p.waiting, transit + p.transit)
    return out


def excess_hold_s(report: MissionReport, early_s: float, late_s: float) -> tuple[float, float, int]:
    """(the late attempts' mean hold, the early attempts' hold over it summed, the early attempts)."""
    early, late = [], []
    for a in report.attempts:
        if a.kind != "brick" or a.phases is None:
            continue
        hold = a.phases.holding + a.phases.waiting
        if a.start_s < early_s:
            early.append(hold)
        elif a.start_s >= late_s:
            late.append(hold)
    base = sum(late) / len(late) if late else 0.0
    return base, sum(h - base for h in early), len(early)


def brick_waits(report: MissionReport) -> Counter[tuple[str, str, str]]:
    """(cause, what held it, the role in the way) -> task-seconds, over the brick tasks' waits while assigned."""
    out: Counter[tuple[str, str, str]] = Counter()
    for t in report.tasks:
        if t.kind != "brick":
            continue
        for w in t.waits:
            if w.cause.uav is None:
                continue  # not assigned yet: a prerequisite, or no free UAV of its role
            role = (w.cause.blocking_uav or "-").split("-")[0]
            out[(w.cause.what, w.cause.holds or "-", role)] += w.duration_s
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2")
    ap.add_argument("--seeds", default="1,2,3")
    ap.add_argument("--window-s", type=float, default=200.0)
    ap.add_argument("--early-s", type=float, default=400.0)
    ap.add_argument("--late-s", type=float, default=600.0)
    args = ap.parse_args()
    seeds = [int(s) for s in args.seeds.split(",")]
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        title, make = WALLS[wall]
        for seed in seeds:
            r = simulate_fleet(make(), bricks, adhesion, seed)
            print(f"\n## {title}, {bricks} + {adhesion}, seed {seed}: makespan {r.makespan_s:,.0f} s\n")
            print("| brick attempts given | attempts | mean attempt | hold (holding + waiting) | transit |")
            print("|---|---|---|---|---|")
            for k, (n, total, hold, transit) in sorted(windows(r, args.window_s).items()):
                span = f"{k * args.window_s:,.0f}-{(k + 1) * args.window_s:,.0f} s"
                print(f"| {span} | {n} | {total / n:.1f} s | {hold / n:.1f} s | {transit / n:.1f} s |")
            base, excess, n = excess_hold_s(r, args.early_s, args.late_s)
            print(
                f"\n- given before {args.early_s:,.0f} s ({n} attempts): {excess:,.0f} brick-UAV seconds held over "
                f"the {base:.1f} s of those given from {args.late_s:,.0f} s on, {excess / bricks:,.0f} s per "
                "brick UAV"
            )
            print(
                "- brick tasks' waits while assigned (task-seconds), by cause, what held them, the role in the way:"
            )
            for (what, holds, role), s in brick_waits(r).most_common():
                print(f"  - {what} {holds} {role}: {s:,.0f}")


if __name__ == "__main__":
    main()
