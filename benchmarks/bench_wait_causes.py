"""Where a mission's time goes: the waits of the JSON report (``tasks[].waits``) per role, cause and where the UAV
waited, and the site intervals (the busy site a compact wall's fleet queues for); prints its figures, asserts
nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (seed 1, ``critical-path``, ``site``, geometric
camera) for each wall, fleet and airspace asked for, and prints per run:

1. the makespan, completion, minimum separation and violations;
2. the task-seconds of waiting per (role, cause, where): ``dependency`` and ``fleet`` (no UAV of the role free)
   are the task model's, ``site`` the site rule (conflicting tasks' site intervals), ``airspace:<purpose>`` the
   reservation (or column) of another UAV its flight waited for, by that reservation's purpose (``stay``: where
   another UAV stays, open-ended; ``climb``, ``transit``, ``descend``: a leg of its flight), ``battery``;
3. the site intervals (from the grant of a UAV's flight down to its task's site to its next request): their sum,
   the time at least one is open (their union), both as a share of the makespan, and the mean per role. On a
   wall whose conflict radius r_c spans it (the bundled pyramid) the intervals are nearly serial: their union is
   the floor of the makespan, and whatever lengthens one interval lengthens the mission.

Usage: python benchmarks/bench_wait_causes.py [--walls pyramid,12m] [--fleets 1+1,4+2]
       [--airspaces columns,table] [--seed 1]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets

from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate

#: causes that are the task model's (a task not yet ready, or no UAV of its role free), summed apart
MODEL_CAUSES = ("dependency", "fleet")


def wait_breakdown(report: MissionReport) -> Counter[tuple[str, str, str]]:
    """Task-seconds of waiting per (role, cause, where): role ``brick`` or ``adhesion``; cause ``site``,
    ``airspace:<purpose>``, ``dependency``, ``fleet``, ...; where ``air``, ``ground`` or ``-`` (not flying)."""
    out: Counter[tuple[str, str, str]] = Counter()
    for t in report.tasks:
        for w in t.waits:
            c = w.cause
            what = f"airspace:{c.holds}" if c.what == "airspace" else c.what
            out[(t.kind, what, c.where or "-")] += w.duration_s
    return out


def site_intervals(report: MissionReport) -> tuple[float, float, dict[str, float]]:
    """The sum of the tasks' site intervals, the length of their union, and the mean interval per role."""
    spans = sorted(
        (t.site_start_s, t.site_end_s, t.id)
        for t in report.tasks
        if t.site_start_s is not None and t.site_end_s is not None
    )
    total = sum(b - a for a, b, _ in spans)
    union, cur = 0.0, None
    for a, b, _ in spans:
        if cur is None or a > cur[1]:
            union += 0.0 if cur is None else cur[1] - cur[0]
            cur = [a, b]
        else:
            cur[1] = max(cur[1], b)
    union += 0.0 if cur is None else cur[1] - cur[0]
    means: dict[str, float] = {}
    kinds = {t.id: t.kind for t in report.tasks}
    for role in ("brick", "adhesion"):
        xs = [b - a for a, b, i in spans if kinds[i] == role]
        means[role] = sum(xs) / len(xs) if xs else 0.0
    return total, union, means


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="pyramid,12m")
    ap.add_argument("--fleets", default="1+1,4+2")
    ap.add_argument("--airspaces", default="columns,table")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        fleet = f"{bricks}+{adhesion}"
        for airspace in args.airspaces.split(","):
            t0 = time.perf_counter()
            r = simulate(
                WALLS[wall][1](),
                brick_uavs=bricks,
                adhesion_uavs=adhesion,
                seed=args.seed,
                policy="critical-path",
                camera="geometric",
                reservation="site",
                airspace=airspace,
            )
            d = r.to_dict()
            print(
                f"## {wall} {fleet} {airspace}: makespan {r.makespan_s:,.0f} s, completed {d['completed']}, "
                f"min separation {d['min_separation_m']} m, violations {d['conflict_violations']} / "
                f"{d['dependency_violations']} ({time.perf_counter() - t0:.0f} s wall)"
            )
            waits = wait_breakdown(r)
            model = sum(v for k, v in waits.items() if k[1] in MODEL_CAUSES)
            rest = sum(v for k, v in waits.items() if k[1] not in MODEL_CAUSES)
            print(f"  waits (task-seconds): task model {model:,.0f}, the rest {rest:,.0f}")
            for (role, what, where), v in sorted(waits.items(), key=lambda kv: -kv[1]):
                if what not in MODEL_CAUSES and v >= 1.0:
                    print(f"    {role:<9} {what:<22} {where:<6} {v:8,.0f}")
            total, union, means = site_intervals(r)
            span = r.makespan_s or 1.0
            print(
                f"  site intervals: sum {total:,.0f} s ({total / span:.0%} of the makespan), union "
                f"{union:,.0f} s ({union / span:.0%}); mean brick {means['brick']:.1f} s, adhesion "
                f"{means['adhesion']:.1f} s"
            )


if __name__ == "__main__":
    main()
