"""Where a simulated mission loses against the CP-SAT schedule (issue 27): per role, the seconds of the done
attempts per phase against the schedule model's minimum for the same tasks, each UAV's time between its tasks
(on its pad or in the air), and the two orders; prints, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) and solves ``masonry schedule`` for the same wall and fleet (CP-SAT, ``--schedule-time-s``,
2 workers, seed 0). The minimum of a brick task (``masonry.planner.bounds.min_durations_s``, which the schedule's
task intervals are) is split into the simulator's phases: ``transit`` the approach leg and the carry,
``estimating`` the settle and the frames, ``aligning`` the two aligns, ``descending`` the grasp descent and the
placing descent to the release radius, ``grasping`` / ``placing`` the dwells and their verify ticks,
``ascending`` the two climbs. An adhesion task's: ``transit`` the approach leg, ``aligning`` the stable hover,
``descending`` the chained descent, ``spraying`` the segment and the valve close. ``queued`` (held for a battery
swap), ``takeoff``, ``waiting`` and ``holding`` have no minimum: the schedule models none of them.

``--per-task`` adds the brick UAVs' tasks one by one: each task's minimum, its done attempt flown without a
hold (every phase but ``queued``, ``takeoff``, ``waiting``, ``holding``), its holds (``waiting`` + ``holding``,
and of them the seconds mission control said were the ``site`` rule or the ``airspace``), its battery swap
(``queued`` + ``takeoff``), and the makespan rebuilt from them against the schedule's. ``--vehicle`` flies
another simulated vehicle (``ideal``: the first-order lag the project was tuned on; default ``arducopter``).

Usage: python benchmarks/bench_schedule_gap.py [--walls pyramid,12m] [--fleet 1+1] [--seed 1]
       [--schedule-time-s 60] [--per-task] [--vehicle arducopter]
"""

from __future__ import annotations

import argparse
import math
import sys
from collections import Counter
from itertools import pairwise
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS

from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.report import MissionReport
from masonry.mission.sim_options import SimOptions
from masonry.mission.simulate import SimulatedMission
from masonry.planner import plan as make_plan
from masonry.planner.bounds import _min_jerk_time_to_within, min_durations_s
from masonry.planner.schedule import solve_schedule
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import PHASES
from masonry.timing import DEFAULT_TIMING, MIN_JERK_PEAK_TO_MEAN_SPEED, MIN_LEG_S

T = DEFAULT_TIMING


def _lat(d_m: float) -> float:
    return max(MIN_LEG_S, MIN_JERK_PEAK_TO_MEAN_SPEED * d_m / T.cruise_speed_mps)


def _vert(dz_m: float) -> float:
    return max(MIN_LEG_S, MIN_JERK_PEAK_TO_MEAN_SPEED * max(dz_m, 0.0) / T.vertical_speed_mps)


def min_phases_s(plan: Plan, cruise_altitude_m: float) -> dict[str, Counter[str]]:
    """Each task's ``min_durations_s`` split into the simulator's phases (their sum is that minimum)."""
    out: dict[str, Counter[str]] = {}
    tick = T.control_period_s
    for t in plan.tasks:
        if t.done:
            continue
        c: Counter[str] = Counter()
        if isinstance(t, BrickTask):
            h = t.size_m[2]
            pickup = t.pickup_m if t.pickup_m is not None else t.position_m
            top_drop = t.position_m[2] + h / 2.0
            transit = max(cruise_altitude_m, T.carry_altitude_m(top_drop, h))
            grasp_z = max(pickup[2] + h / 2.0, h) - T.grasp_press_m - T.effector_offset_m[2]
            drop = transit - (top_drop - T.effector_offset_m[2])
            carry_m = math.hypot(t.position_m[0] - pickup[0], t.position_m[1] - pickup[1])
            c["transit"] = MIN_LEG_S + _lat(carry_m)
            c["estimating"] = T.settle_time_s + (T.min_estimates - 1) * tick
            c["aligning"] = 2 * MIN_LEG_S
            c["descending"] = T.descent_duration_s * (
                1.0 + _min_jerk_time_to_within(drop, T.placement_radius_m)
            )
            c["grasping"] = T.grasp_dwell_s + tick
            c["placing"] = T.release_dwell_s + tick
            c["ascending"] = _vert(transit - grasp_z) + _vert(drop - T.placement_radius_m)
        else:
            c["transit"] = MIN_LEG_S
            c["aligning"] = T.stable_time_s
            c["descending"] = min(T.spray_descent_s, T.chain_descent_s)
            c["spraying"] = t.length_m / T.spray_speed_mps + T.close_dwell_s
        out[t.id] = c
    return out


_HOLDS = ("waiting", "holding")
_SWAP = ("queued", "takeoff")


def per_task(rep: MissionReport, mins: dict[str, float], schedule_makespan_s: float, s_busy_s: float) -> None:
    """The brick tasks one by one (minimum, flown without a hold, holds, swap) and the makespan rebuilt."""
    print("| task | minimum | flown, no hold | excess | holds (site / airspace) | swap | task |")
    print("|---|---|---|---|---|---|---|")
    tot: Counter[str] = Counter()
    bricks = sorted(
        (t for t in rep.tasks if t.kind == "brick" and t.phases is not None and t.start_s is not None),
        key=lambda t: t.start_s or 0.0,
    )
    for t in bricks:
        assert t.phases is not None and t.start_s is not None and t.end_s is not None
        ph = t.phases.as_dict()
        holds = sum(ph[k] for k in _HOLDS)
        swap = sum(ph[k] for k in _SWAP)
        flown = sum(ph.values()) - holds - swap
        by: Counter[str] = Counter()
        for w in t.waits:
            if w.cause.uav is not None and w.cause.what in ("site", "airspace"):
                by[w.cause.what] += w.duration_s
        row = {"min": mins[t.id], "flown": flown, "holds": holds, "site": by["site"], "air": by["airspace"]}
        row |= {"swap": swap, "task": t.end_s - t.start_s}
        tot.update(row)
        print(
            f"| {t.id} | {row['min']:.1f} s | {flown:.1f} s | {flown - row['min']:+.1f} s | {holds:.1f} s "
            f"({by['site']:.1f} / {by['airspace']:.1f}) | {swap:.1f} s | {row['task']:.1f} s |"
        )
    print(
        f"| all {len(bricks)} | {tot['min']:,.1f} s | {tot['flown']:,.1f} s | {tot['flown'] - tot['min']:+,.1f} s "
        f"| {tot['holds']:,.1f} s ({tot['site']:,.1f} / {tot['air']:,.1f}) | {tot['swap']:,.1f} s "
        f"| {tot['task']:,.1f} s |"
    )
    first = min((t.start_s for t in bricks if t.start_s is not None), default=0.0)
    rest = rep.makespan_s - first - tot["task"]
    print()
    print(
        f"makespan {rep.makespan_s:,.1f} s = first start {first:,.1f} + minimum {tot['min']:,.1f} + flown over "
        f"the minimum {tot['flown'] - tot['min']:+,.1f} + holds {tot['holds']:,.1f} + swap {tot['swap']:,.1f} "
        f"+ between and after its tasks {rest:,.1f}; schedule {schedule_makespan_s:,.1f} s = tasks {s_busy_s:,.1f} "
        f"+ first start and empty flights {schedule_makespan_s - s_busy_s:,.1f}"
    )
    print()


def run(
    wall: str,
    bricks: int,
    adhesion: int,
    seed: int,
    time_limit_s: float,
    show_tasks: bool = False,
    vehicle: str | None = None,
) -> None:
    bp = WALLS[wall][1]()
    fleet = fleet_for(bp, bricks, adhesion)
    bp = bp if fleet == bp.fleet else with_fleet(bp, fleet)
    plan = make_plan(bp)
    m = SimulatedMission.from_blueprint(
        bp,
        SimOptions(
            brick_uavs=bricks,
            adhesion_uavs=adhesion,
            seed=seed,
            camera="geometric",
            reservation="site",
            vehicle=vehicle,
        ),
    )
    rep = m.run()
    mins = min_durations_s(plan, cruise_altitude_m=bp.cruise_altitude_m)
    split = min_phases_s(plan, bp.cruise_altitude_m)
    assert all(abs(sum(split[k].values()) - v) < 1e-6 for k, v in mins.items())
    sched = solve_schedule(
        plan,
        fleet,
        cruise_altitude_m=bp.cruise_altitude_m,
        reservation="site",
        time_limit_s=time_limit_s,
        seed=0,
        workers=2,
        decomposition="auto",
    )
    s_tasks = {t.id: t for u in sched.uavs for t in u.tasks}
    print(f"## {wall}, {bricks} + {adhesion}, seed {seed}, vehicle {vehicle or 'arducopter (default)'}")
    print(
        f"simulated {rep.makespan_s:,.1f} s, schedule {sched.makespan_s:,.1f} s ({sched.status}, {time_limit_s:g} s)"
    )
    print()
    print("| role | phase | simulated (done attempts) | schedule minimum | excess |")
    print("|---|---|---|---|---|")
    for role in ("brick", "adhesion"):
        done = [t for t in rep.tasks if t.kind == role and t.phases is not None]
        sim: Counter[str] = Counter()
        low: Counter[str] = Counter()
        for t in done:
            assert t.phases is not None
            sim.update(t.phases.as_dict())
            low.update(split[t.id])
        for ph in (*PHASES, "all"):
            a = sum(sim.values()) if ph == "all" else sim[ph]
            b = sum(low.values()) if ph == "all" else low[ph]
            if a > 0.05 or b > 0.05:
                print(f"| {role} | {ph} | {a:,.0f} s | {b:,.0f} s | {a - b:+,.0f} s |")
    print()
    if show_tasks:
        brick_busy_s = sum(x.end_s - x.start_s for u in sched.uavs for x in u.tasks if x.id.startswith("B"))
        per_task(rep, mins, sched.makespan_s, brick_busy_s)
    print(
        "| UAV | first start (schedule) | sum of its tasks (schedule) | between tasks on its pad | in the air | "
        "after its last task | lingering |"
    )
    print("|---|---|---|---|---|---|---|")
    for u in rep.uavs:
        mine = sorted(
            (t for t in rep.tasks if t.uav == u.name and t.start_s is not None), key=lambda t: t.start_s
        )
        path = m.world.uavs[u.name].path_m()
        pad_s = air_s = 0.0
        for a, b in pairwise(mine):
            assert a.end_s is not None and b.start_s is not None
            sel = (path[:, 0] >= a.end_s) & (path[:, 0] < b.start_s)
            if b.start_s - a.end_s <= 0.0:
                continue
            frac = float(np.mean(path[sel, 3] < 0.1)) if sel.any() else 0.0
            pad_s += frac * (b.start_s - a.end_s)
            air_s += (1.0 - frac) * (b.start_s - a.end_s)
        st = sorted(
            (s_tasks[t.id] for t in plan.tasks if t.id in s_tasks and t.id in {x.id for x in mine}),
            key=lambda x: x.start_s,
        )
        busy = sum((t.end_s or 0.0) - (t.start_s or 0.0) for t in mine)
        s_busy = sum(x.end_s - x.start_s for x in st)
        last = mine[-1].end_s if mine and mine[-1].end_s is not None else 0.0
        print(
            f"| {u.name} | {mine[0].start_s:,.0f} s ({st[0].start_s:,.0f} s) | {busy:,.0f} s ({s_busy:,.0f} s) "
            f"| {pad_s:,.0f} s | {air_s:,.0f} s | {rep.makespan_s - last:,.0f} s | {u.lingering_s:,.0f} s |"
        )
    print()
    for role, prefix in (("brick", "B"), ("adhesion", "A")):
        sim_order = [
            t.id for t in sorted(rep.tasks, key=lambda t: t.start_s or 0.0) if t.id.startswith(prefix)
        ]
        s_order = [
            k for k, _ in sorted(s_tasks.items(), key=lambda kv: kv[1].start_s) if k.startswith(prefix)
        ]
        same = sum(1 for a, b in zip(sim_order, s_order, strict=False) if a == b)
        print(f"{role} order, simulated: {' '.join(sim_order)}")
        print(f"{role} order, schedule:  {' '.join(s_order)}  ({same} of {len(s_order)} at the same rank)")
    print()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="pyramid,12m")
    ap.add_argument("--fleet", default="1+1")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--schedule-time-s", type=float, default=60.0)
    ap.add_argument(
        "--per-task", action="store_true", help="the brick tasks one by one, the makespan rebuilt"
    )
    ap.add_argument("--vehicle", default=None, help="simulated vehicle preset (default: arducopter)")
    args = ap.parse_args()
    b, a = (int(x) for x in args.fleet.split("+"))
    for wall in args.walls.split(","):
        run(wall, b, a, args.seed, args.schedule_time_s, args.per_task, args.vehicle)


if __name__ == "__main__":
    main()
