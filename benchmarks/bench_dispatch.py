"""Dispatcher throughput on a large wall: events per second for each policy.

Builds a running-bond wall (20,000 bricks by default) with the planner (``masonry.blueprint_gen`` +
``masonry.planner.plan``; a direct Plan builder is the fallback when those are absent), then runs the whole
mission through the Dispatcher in model time: each assigned task completes after its estimated duration
(``estimate_durations_s``), a fraction of attempts fail (``--fail-rate``). Only the time spent inside the
Dispatcher (``assign``, ``complete``, ``fail``) is counted, as process CPU time (so other load on a shared machine
does not distort it); an event is one assignment, completion or failure.

    .venv/bin/python benchmarks/bench_dispatch.py                       # 40 courses x 500 bricks
    .venv/bin/python benchmarks/bench_dispatch.py --courses 10 --per-course 200 --policies nearest
"""

from __future__ import annotations

import argparse
import heapq
import math
import platform
import random
import resource
import sys
import time
from typing import Any

from masonry.blueprint import UavSpec
from masonry.planner.bounds import estimate_durations_s, lower_bound_s
from masonry.planner.dispatch import POLICIES, Dispatcher
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan


def planner_wall(
    courses: int, per_course: int, brick_uavs: int, adhesion_uavs: int
) -> tuple[Plan, list[UavSpec]]:
    from masonry.blueprint_gen import running_bond
    from masonry.planner import plan

    bp = running_bond(
        courses=courses,
        bricks_per_course=per_course,
        placed_courses=1,
        brick_uavs=brick_uavs,
        adhesion_uavs=adhesion_uavs,
    )
    return plan(bp, check_marker_ids=False), list(bp.fleet)  # up to 20,000 bricks: a planner-only study


def direct_wall(
    courses: int, per_course: int, brick_uavs: int, adhesion_uavs: int, clearance_m: float = 1.5
) -> tuple[Plan, list[UavSpec]]:
    """A running bond built straight into a Plan: bricks 0.30 x 0.15 x 0.10 m, course 0 pre-placed.

    Each brick above course 0 rests on the two bricks below it (one at the ends); an adhesion task per contact
    (after the lower brick, before the upper one); conflicts between tasks closer than ``clearance_m`` that
    are not ordered by a dependency path of length 1.
    """
    length, height = 0.30, 0.10
    tasks: list[Any] = []
    deps: list[tuple[str, str]] = []
    pos: dict[tuple[int, int], tuple[float, float, float]] = {}
    bid = 0
    ids: dict[tuple[int, int], str] = {}
    for c in range(courses):
        shift = length / 2.0 if c % 2 else 0.0
        for k in range(per_course):
            p = (k * length + shift, 0.0, c * height + height / 2.0)
            pos[(c, k)] = p
            ids[(c, k)] = f"B{bid}"
            pickup = ((k % 20) * 0.5, -2.5 - 0.45 * (bid % 7), 0.05)
            tasks.append(BrickTask(f"B{bid}", bid, c == 0, p, 0.0, None if c == 0 else pickup))
            bid += 1
    n_adh = 0
    for c in range(1, courses):
        for k in range(per_course):
            below = [k, k + 1] if c % 2 else [k - 1, k]
            for kb in below:
                if not 0 <= kb < per_course:
                    continue
                up, lo = pos[(c, k)], pos[(c - 1, kb)]
                x0, x1 = max(up[0], lo[0]) - length / 2.0, min(up[0], lo[0]) + length / 2.0
                z = c * height
                aid = f"A{n_adh}"
                n_adh += 1
                tasks.append(AdhesionTask(aid, bid, bid, (x0, 0.0, z), (x1, 0.0, z), x1 - x0))
                deps.append((ids[(c, k)], aid))
                if c - 1 > 0:
                    deps.append((aid, ids[(c - 1, kb)]))
    # Conflicts by a uniform grid of cell size clearance_m over the task locations.
    todo = [t for t in tasks if not t.done]
    direct = {frozenset(e) for e in deps}
    grid: dict[tuple[int, int], list[int]] = {}
    where = [t.location_m for t in todo]
    for i, p in enumerate(where):
        grid.setdefault((int(p[0] // clearance_m), int(p[2] // clearance_m)), []).append(i)
    conflicts: list[tuple[str, str]] = []
    for i, p in enumerate(where):
        cx, cz = int(p[0] // clearance_m), int(p[2] // clearance_m)
        for dx in (-1, 0, 1):
            for dz in (-1, 0, 1):
                for j in grid.get((cx + dx, cz + dz), ()):
                    if j > i and math.dist(p, where[j]) <= clearance_m:
                        a, b = todo[i].id, todo[j].id
                        if frozenset((a, b)) not in direct:
                            conflicts.append((a, b))
    fleet = [UavSpec(f"brick-{k + 1}", "brick", (k * 2.0, -8.0, 0.0)) for k in range(brick_uavs)] + [
        UavSpec(f"glue-{k + 1}", "adhesion", (k * 2.0, -10.0, 0.0)) for k in range(adhesion_uavs)
    ]
    return Plan(tuple(tasks), tuple(deps), tuple(conflicts)), fleet


def run(
    plan: Plan,
    fleet: list[UavSpec],
    policy: str,
    durations: dict[str, float] | None,
    model_durations: dict[str, float],
    fail_rate: float,
    seed: int,
) -> dict[str, float]:
    rng = random.Random(seed)
    t0 = time.perf_counter()
    d = Dispatcher(plan, fleet, policy, max_attempts=1000, durations_s=durations)
    build_s = time.perf_counter() - t0
    inside = 0.0
    per_event: list[float] = []  # seconds per event, one sample per call
    queue: list[tuple[float, int, str]] = []
    now, seq = 0.0, 0
    perf = time.process_time  # CPU time of this process: figures do not depend on other load on the machine
    while True:
        t = perf()
        new = d.assign()
        dt = perf() - t
        inside += dt
        if new:
            per_event.append(dt / len(new))
        for a in new:
            heapq.heappush(queue, (now + model_durations[a.task_id], seq, a.task_id))
            seq += 1
        if not queue:
            break
        now, _, tid = heapq.heappop(queue)
        failed = rng.random() < fail_rate
        t = perf()
        if failed:
            d.fail(tid)
        else:
            d.complete(tid)
        dt = perf() - t
        inside += dt
        per_event.append(dt)
    assert d.finished, "benchmark mission did not finish"
    per_event.sort()
    p50 = per_event[len(per_event) // 2]
    p99 = per_event[int(0.99 * (len(per_event) - 1))]
    return {
        "build_s": build_s,
        "events": d.events,
        "inside_s": inside,
        "makespan_s": now,
        "p50_s": p50,
        "p99_s": p99,
    }


def makespan_table(seed: int) -> None:
    """Model-time makespan / lower bound per policy on a few walls and fleets (flights at 1 m/s included)."""
    from masonry.blueprint_gen import running_bond
    from masonry.planner import plan as make_plan
    from masonry.planner.bounds import dispatch_makespan_s

    print(
        "makespan / lower bound in model time: task durations from estimate_durations_s without the approach,"
    )
    print("plus the flight from each UAV's position to the task's start at 1 m/s; no faults")
    print(f"{'wall':<22}{'fleet':>8}{'LB s':>9}" + "".join(f"{p:>15}" for p in POLICIES))
    for courses, per in ((4, 6), (10, 30), (20, 60)):
        for brick_uavs, adhesion_uavs in ((1, 1), (2, 1), (4, 2), (8, 4)):
            bp = running_bond(
                courses=courses,
                bricks_per_course=per,
                placed_courses=1,
                brick_uavs=brick_uavs,
                adhesion_uavs=adhesion_uavs,
            )
            plan = make_plan(bp, check_marker_ids=False)
            durations = estimate_durations_s(plan, bp.fleet, include_approach=False)
            bound = lower_bound_s(plan, bp.fleet, durations)
            ratios = [
                dispatch_makespan_s(plan, bp.fleet, durations, p, cruise_speed_mps=1.0) / bound
                for p in POLICIES
            ]
            print(
                f"{f'{courses}x{per} running bond':<22}{f'{brick_uavs}+{adhesion_uavs}':>8}{bound:>9.0f}"
                + "".join(f"{r:>15.3f}" for r in ratios)
            )


def journal_rate(records: int) -> None:
    """Durable journal records per second (assignment + completion pairs) in a temporary directory."""
    import tempfile
    from pathlib import Path

    from masonry.mission.journal import Journal, read_journal

    n = 2 * (records // 2)
    for sync in ("full", "normal"):
        with tempfile.TemporaryDirectory() as tmp:
            path = Path(tmp) / "bench.sqlite"
            with Journal(path, sync=sync) as journal:  # type: ignore[arg-type]
                t0 = time.perf_counter()
                for i in range(n // 2):
                    journal.record_assignment(float(i), f"B{i}", "brick-1", 1)
                    journal.record_completion(i + 0.5, f"B{i}", "brick-1", placement_error_m=0.01)
                dt = time.perf_counter() - t0
            t0 = time.perf_counter()
            state = read_journal(path)
            replay_s = time.perf_counter() - t0
        print(
            f"journal sync={sync}: {n} records in {dt:.2f} s = {n / dt:.0f} records/s "
            f"({1e3 * dt / n:.2f} ms each, one commit per record); "
            f"replay of {len(state.records)} records {1e3 * replay_s:.0f} ms"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--courses", type=int, default=40)
    ap.add_argument("--per-course", type=int, default=500)
    ap.add_argument("--brick-uavs", type=int, default=4)
    ap.add_argument("--adhesion-uavs", type=int, default=2)
    ap.add_argument("--policies", nargs="+", default=list(POLICIES), choices=POLICIES)
    ap.add_argument("--fail-rate", type=float, default=0.05)
    ap.add_argument("--unweighted", action="store_true", help="critical-path counts tasks instead of seconds")
    ap.add_argument("--direct", action="store_true", help="build the Plan directly, not with the planner")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--makespan", action="store_true", help="print the policy makespan table instead")
    ap.add_argument("--journal", type=int, metavar="N", help="time N durable journal records instead")
    args = ap.parse_args(argv)
    if args.makespan:
        makespan_table(args.seed)
        return 0
    if args.journal:
        journal_rate(args.journal)
        return 0

    print(
        f"python {platform.python_version()} on {platform.machine()}, {args.courses} courses x "
        f"{args.per_course} bricks, {args.brick_uavs} brick + {args.adhesion_uavs} adhesion UAVs, "
        f"fail rate {args.fail_rate}"
    )
    t0 = time.perf_counter()
    source = "direct"
    if not args.direct:
        try:
            plan, fleet = planner_wall(args.courses, args.per_course, args.brick_uavs, args.adhesion_uavs)
            source = "masonry.planner.plan"
        except ImportError:
            plan, fleet = direct_wall(args.courses, args.per_course, args.brick_uavs, args.adhesion_uavs)
    else:
        plan, fleet = direct_wall(args.courses, args.per_course, args.brick_uavs, args.adhesion_uavs)
    plan_s = time.perf_counter() - t0
    bricks = sum(1 for t in plan.tasks if isinstance(t, BrickTask))
    print(
        f"plan ({source}): {bricks} bricks, {len(plan.tasks)} tasks, {len(plan.dependencies)} dependencies, "
        f"{len(plan.conflicts)} conflicts, built in {plan_s:.1f} s"
    )
    durations = estimate_durations_s(plan, fleet)
    bound = lower_bound_s(plan, fleet, durations)
    print(f"lower bound {bound / 3600:.1f} h of model time")
    print(
        f"{'policy':<15}{'init s':>8}{'events':>9}{'events/s':>11}{'mean us':>9}{'p50 us':>8}{'p99 us':>8}"
        f"{'makespan/LB':>13}"
    )
    for policy in args.policies:
        r = run(
            plan, fleet, policy, None if args.unweighted else durations, durations, args.fail_rate, args.seed
        )
        rate = r["events"] / r["inside_s"]
        print(
            f"{policy:<15}{r['build_s']:>8.1f}{int(r['events']):>9}{rate:>11.0f}"
            f"{1e6 * r['inside_s'] / r['events']:>9.1f}{1e6 * r['p50_s']:>8.0f}{1e6 * r['p99_s']:>8.0f}"
            f"{r['makespan_s'] / bound:>13.3f}"
        )
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory {peak_mb:.0f} MB")
    return 0


if __name__ == "__main__":
    sys.exit(main())
