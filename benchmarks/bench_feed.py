"""Do the sprayers feed the brick UAVs? (issue 27 section 4) Per window of the mission: how many UAVs of each role
hold a task, how many bricks have all their glue and wait unassigned, and each UAV's gaps between tasks; prints
Markdown, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) and prints per wall, fleet and seed:

1. per ``--window-s`` window: brick and adhesion UAVs holding a task (attempt-seconds / window, failed attempts
   too); the bricks *ready* at the window's start (every prerequisite done by then, not yet assigned: a brick UAV
   could take them), the bricks freed in the window (their last prerequisite done) and the adhesion tasks done;
2. per UAV: its attempts and every gap of more than ``GAP_S`` between one attempt's end and the next one's start
   (the start, a battery swap, nothing to do), with the first brick's assignment.

A brick UAV short of the window while bricks are ready waits for something other than glue (its battery, the
admission rule); one short while none is ready waits for the sprayers.

Usage: python benchmarks/bench_feed.py [--walls 12m] [--fleets 4+2] [--seeds 1] [--window-s 100]
"""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet, walls_and_fleets

from masonry.mission.report import MissionReport
from masonry.planner import plan as make_plan
from masonry.planner.tasks import Plan

#: a pause between two attempts of one UAV longer than this is printed
GAP_S = 3.0


def windows(report: MissionReport, plan: Plan, window_s: float) -> list[str]:
    """The table's rows, one per window of ``window_s``."""
    kind = {t.id: t.kind for t in report.tasks}
    start = {t.id: t.start_s for t in report.tasks}
    end = {t.id: t.end_s for t in report.tasks}
    prerequisites: dict[str, list[str]] = defaultdict(list)
    for u, v in plan.dependencies:
        prerequisites[u].append(v)
    n = int(report.makespan_s // window_s) + 1
    busy: dict[str, list[float]] = {"brick": [0.0] * n, "adhesion": [0.0] * n}
    for a in report.attempts:
        a_end = report.makespan_s if a.end_s is None else a.end_s
        for k in range(int(a.start_s // window_s), min(n, int(a_end // window_s) + 1)):
            lo, hi = k * window_s, (k + 1) * window_s
            busy["brick" if a.kind == "brick" else "adhesion"][k] += max(
                0.0, min(a_end, hi) - max(a.start_s, lo)
            )
    freed: dict[str, float] = {}  # brick -> when its last prerequisite was done
    for t in plan.tasks:
        if t.done or kind.get(t.id) != "brick" or start.get(t.id) is None:
            continue
        ends = [e for p in prerequisites[t.id] if (e := end.get(p)) is not None]
        freed[t.id] = max(ends, default=0.0)
    rows = []
    for k in range(n):
        lo, hi = k * window_s, (k + 1) * window_s
        ready = sum(1 for tid, f in freed.items() if f <= lo and (start[tid] or 0.0) > lo)
        came = sum(1 for f in freed.values() if lo <= f < hi)
        sprayed = sum(1 for tid, e in end.items() if kind[tid] != "brick" and e is not None and lo <= e < hi)
        rows.append(
            f"| {lo:,.0f} | {busy['brick'][k] / window_s:.2f} | {busy['adhesion'][k] / window_s:.2f} | {ready} | "
            f"{came} | {sprayed} |"
        )
    return rows


def gaps(report: MissionReport) -> list[str]:
    """Per UAV: its attempts and its gaps longer than :data:`GAP_S` (from, seconds)."""
    by_uav: dict[str, list[tuple[float, float]]] = defaultdict(list)
    for a in report.attempts:
        by_uav[a.uav].append((a.start_s, report.makespan_s if a.end_s is None else a.end_s))
    out = []
    for uav, spans in sorted(by_uav.items()):
        spans.sort()
        last, found = 0.0, []
        for s, e in spans:
            if s - last > GAP_S:
                found.append(f"{last:,.0f} s: {s - last:,.0f} s")
            last = max(last, e)
        out.append(f"| {uav} | {len(spans)} | {spans[0][0]:,.1f} s | {'; '.join(found) or '-'} |")
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2")
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--window-s", type=float, default=100.0)
    args = ap.parse_args()
    if args.window_s <= 0:
        ap.error("--window-s must be > 0")
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        blueprint = WALLS[wall][1]()
        plan = make_plan(blueprint)
        for seed in (int(s) for s in args.seeds.split(",")):
            report = simulate_fleet(
                blueprint,
                bricks,
                adhesion,
                seed,
                airspace="columns",
            )
            print(f"\n## {WALLS[wall][0]}, {bricks} + {adhesion}, seed {seed}: {report.makespan_s:,.1f} s\n")
            print(
                f"| from (s, {args.window_s:g} s windows) | brick UAVs on a task | adhesion UAVs on a task | "
                "bricks ready, unassigned | bricks freed | adhesion tasks done |"
            )
            print("|---|---|---|---|---|---|")
            print("\n".join(windows(report, plan, args.window_s)))
            print("\n| UAV | attempts | first assigned | gaps between attempts (from: length) |")
            print("|---|---|---|---|")
            print("\n".join(gaps(report)), flush=True)


if __name__ == "__main__":
    main()
