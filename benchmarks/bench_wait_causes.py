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

``--policies critical-path,schedule`` flies each run with each policy (``schedule``: the CP-SAT schedule of the
wall and fleet, ``--schedule-time-s`` seconds, solved once and cached as ``bench_fleet.py`` does), ``--seeds``
several seeds; a last table puts each run's makespan, the schedule's and the waits per role and cause side by
side (the causes summed over ``where``; ``airspace`` over every purpose).

Usage: python benchmarks/bench_wait_causes.py [--walls pyramid,12m] [--fleets 1+1,4+2]
       [--airspaces columns,table] [--seeds 1] [--policies critical-path[,schedule]]
       [--schedule-time-s 90] [--schedule-cache DIR]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import DEFAULT_SCHEDULE_TIME_S, WALLS, followed_note, policies_of, walls_and_fleets
from schedule_cache import cached_schedule

from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate
from masonry.planner.schedule_policy import SCHEDULE_POLICY

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


#: the columns of the last table: (role, cause) summed over where; ``airspace`` over its purposes
SUMMARY = (
    ("brick", "site"),
    ("brick", "airspace"),
    ("brick", "battery"),
    ("brick", "take-off"),
    ("brick", "dependency"),
    ("brick", "fleet"),
    ("adhesion", "site"),
    ("adhesion", "airspace"),
    ("adhesion", "battery"),
    ("adhesion", "take-off"),
    ("adhesion", "dependency"),
    ("adhesion", "fleet"),
)


def summary_cells(waits: Counter[tuple[str, str, str]]) -> list[float]:
    """The task-seconds of :data:`SUMMARY`'s (role, cause) pairs."""
    out: Counter[tuple[str, str]] = Counter()
    for (role, what, _where), v in waits.items():
        out[(role, what.split(":")[0])] += v
    return [out[k] for k in SUMMARY]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="pyramid,12m")
    ap.add_argument("--fleets", default="1+1,4+2")
    ap.add_argument("--airspaces", default="columns,table")
    ap.add_argument("--seeds", "--seed", default="1", help="comma-separated seeds")
    ap.add_argument(
        "--policies", default="critical-path", help="comma-separated, e.g. critical-path,schedule"
    )
    ap.add_argument("--schedule-time-s", type=float, default=DEFAULT_SCHEDULE_TIME_S)
    ap.add_argument("--schedule-cache", type=Path, default=None, help="directory of the cached schedules")
    args = ap.parse_args()
    policies = policies_of(ap, args.policies, args.schedule_time_s)
    seeds = [int(x) for x in args.seeds.split(",")]
    rows = []
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        fleet = f"{bricks}+{adhesion}"
        blueprint = WALLS[wall][1]()
        schedule = None
        if SCHEDULE_POLICY in policies:
            schedule, took, cached = cached_schedule(
                blueprint, bricks, adhesion, "site", args.schedule_time_s, args.schedule_cache
            )
            print(
                f"# {wall} {fleet}: schedule {schedule.makespan_s:,.0f} s ({schedule.status}), "
                f"{'from the cache' if cached else 'solved'} in {took:.0f} s"
            )
        for airspace in args.airspaces.split(","):
            for seed in seeds:
                for policy in policies:
                    t0 = time.perf_counter()
                    r = simulate(
                        blueprint,
                        brick_uavs=bricks,
                        adhesion_uavs=adhesion,
                        seed=seed,
                        policy=policy,
                        camera="geometric",
                        reservation="site",
                        airspace=airspace,
                        schedule=schedule if policy == SCHEDULE_POLICY else None,
                    )
                    d = r.to_dict()
                    print(
                        f"## {wall} {fleet} {airspace} seed {seed} {policy}: makespan {r.makespan_s:,.0f} s, "
                        f"completed {d['completed']}, min separation {d['min_separation_m']} m, violations "
                        f"{d['conflict_violations']} / {d['dependency_violations']} "
                        f"({time.perf_counter() - t0:.0f} s wall){followed_note(r)}",
                        flush=True,
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
                    sched = f"{schedule.makespan_s:,.0f} s" if schedule is not None else "-"
                    ratio = f"{r.makespan_s / schedule.makespan_s:.2f}" if schedule is not None else "-"
                    cells = " | ".join(f"{v:,.0f}" for v in summary_cells(waits))
                    rows.append(
                        f"| {wall} | {fleet} | {airspace} | {seed} | {policy} | {r.makespan_s:,.0f} s | {sched} "
                        f"| {ratio} | {union / span:.0%} | {cells} |"
                    )
    print()
    print(
        "| wall | fleet | airspace | seed | policy | makespan | schedule | ratio | site union | "
        + " | ".join(f"{role} {cause}" for role, cause in SUMMARY)
        + " |"
    )
    print("|---" * (9 + len(SUMMARY)) + "|")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
