"""Fly random site layouts (masonry.blueprint_random) and print what happened to each: the sweep behind the
property test tests/test_random_layouts.py, on more and larger layouts.

    python benchmarks/bench_layouts.py [--n 40] [--first-seed 0] [--large] [--faults] [--reservation site]
        [--airspace columns|table] [--compact] [--policy critical-path|fifo|nearest] [--sub-fleets]

A row per layout: seed, the wall, fleet, r_c, pad spacing, completed, stalled, conflict and dependency
violations, min separation, the worst envelope excursion in metres and seconds (``env_m``, ``env_s``: the report's
``envelope_excursion``, docs/safety.md), makespan, lower bound, wall seconds. The last lines count the failures and
give the worst excursion.

``--sub-fleets`` (issue 27 §4, "never slower with more UAVs of either role"): each layout is flown by its own
fleet and by every smaller one (b + a with 1 <= b, a up to the blueprint's, its first UAVs of each role), and a
line per layout gives each fleet's makespan and every *slower pair*: a fleet with at least as many UAVs of each
role as another, and more of one, whose makespan is longer by more than 0.05 s. The last lines count the layouts
with a slower pair and name the worst (docs/performance/fleet.md).
"""

from __future__ import annotations

import argparse
import math
import random
import time

from masonry.blueprint_random import LayoutLimits, random_layout
from masonry.mission.reserved import AIRSPACES, DEFAULT_AIRSPACE
from masonry.mission.simulate import simulate
from masonry.mission.table_dispatch import DEFAULT_TABLE_DISPATCH, TABLE_DISPATCHES
from masonry.planner.dispatch import DEFAULT_POLICY, DEFAULT_RESERVATION, POLICIES, RESERVATIONS
from masonry.separation import pad_separation_m
from masonry.sim import Faults

#: What the property test asserts (the airspace's 1.1-1.2 m less tracking error; docs/safety.md).
SEPARATION_BOUND_M = 1.0


def fly(
    seed: int,
    limits: LayoutLimits,
    faults: bool,
    reservation: str = "task",
    airspace: str = DEFAULT_AIRSPACE,
    policy: str = DEFAULT_POLICY,
    table_dispatch: str = DEFAULT_TABLE_DISPATCH,
) -> dict[str, object]:
    rng = random.Random(seed)
    bp = random_layout(rng, limits)
    f = Faults.mild(rng) if faults else Faults()
    homes = [u.home_m for u in bp.fleet]
    spacing = min(
        (math.dist(a[:2], b[:2]) for i, a in enumerate(homes) for b in homes[i + 1 :]), default=float("nan")
    )
    t0 = time.perf_counter()
    r = simulate(
        bp,
        seed=seed,
        faults=f,
        reservation=reservation,
        airspace=airspace,
        policy=policy,
        table_dispatch=table_dispatch,
    )
    return {
        "seed": seed,
        "wall": bp.name,
        "fleet": f"{len(bp.uavs('brick'))}+{len(bp.uavs('adhesion'))}",
        "r_c": bp.clearance_m,
        "pads_m": spacing,
        "completed": r.completed,
        "stalled": r.stall is not None,
        "conflicts": r.conflict_violations,
        "deps": r.dependency_violations,
        "min_sep": r.min_separation_m,
        "envelope": r.envelope_excursion,
        "makespan": r.makespan_s,
        "bound": r.lower_bound_s,
        "wall_s": time.perf_counter() - t0,
        "stuck": r.stuck,
        "stall": (r.stall or {}).get("line"),
        "held_up": sum("hold_patience_s" in (a.reason or "") for a in r.attempts),
    }


#: A larger fleet counts as slower only past this much (the report's makespan is to the control period).
SLOWER_BY_S = 0.05


def sub_fleets(
    seed: int,
    limits: LayoutLimits,
    reservation: str,
    airspace: str,
    policy: str,
    table_dispatch: str = DEFAULT_TABLE_DISPATCH,
) -> tuple[str, dict[tuple[int, int], float]]:
    """The layout of ``seed`` and the makespan of its fleet and of every smaller one (see the module docstring)."""
    bp = random_layout(random.Random(seed), limits)
    n_brick, n_glue = len(bp.uavs("brick")), len(bp.uavs("adhesion"))
    out: dict[tuple[int, int], float] = {}
    for b in range(1, n_brick + 1):
        for a in range(1, n_glue + 1):
            r = simulate(
                bp,
                seed=seed,
                reservation=reservation,
                airspace=airspace,
                policy=policy,
                table_dispatch=table_dispatch,
                brick_uavs=b,
                adhesion_uavs=a,
            )
            out[(b, a)] = r.makespan_s if r.completed else math.inf
    return bp.name, out


def slower_pairs(
    makespans_s: dict[tuple[int, int], float],
) -> list[tuple[tuple[int, int], tuple[int, int], float]]:
    """Every (larger, smaller, seconds slower) where the larger fleet has at least as many UAVs of each role as
    the smaller and takes longer by more than :data:`SLOWER_BY_S`; the most seconds first."""
    pairs = [
        (big, small, makespans_s[big] - makespans_s[small])
        for big in makespans_s
        for small in makespans_s
        if big != small and big[0] >= small[0] and big[1] >= small[1]
        if makespans_s[big] - makespans_s[small] > SLOWER_BY_S
    ]
    return sorted(pairs, key=lambda p: -p[2])


def fleet_scaling(args: argparse.Namespace, limits: LayoutLimits) -> None:
    """``--sub-fleets``: a line per layout, then the count of layouts with a slower pair and the worst."""
    worst: tuple[float, int, str] = (0.0, -1, "")
    slower = total_s = 0.0
    for seed in range(args.first_seed, args.first_seed + args.n):
        t0 = time.perf_counter()
        wall, spans = sub_fleets(
            seed, limits, args.reservation, args.airspace, args.policy, args.table_dispatch
        )
        pairs = slower_pairs(spans)
        total_s += sum(spans.values())
        cells = " ".join(f"{b}+{a} {s:.1f}" for (b, a), s in sorted(spans.items()))
        named = "; ".join(f"{b[0]}+{b[1]} over {s[0]}+{s[1]} +{d:.1f}" for b, s, d in pairs)
        print(
            f"{seed:<5} {wall:<26} {cells}   slower: {named or 'none'}   ({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
        if pairs:
            slower += 1
            big, small, d = pairs[0]
            if d > worst[0]:
                worst = (d, seed, f"{big[0]}+{big[1]} over {small[0]}+{small[1]}")
    print(f"{slower:.0f} of {args.n} layouts have a larger fleet slower; makespans summed {total_s:.1f} s")
    if worst[1] >= 0:
        print(f"worst: seed {worst[1]}, {worst[2]} +{worst[0]:.1f} s")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--large", action="store_true", help="walls up to 6 courses x 12 bricks")
    ap.add_argument("--faults", action="store_true", help="mild random faults")
    ap.add_argument("--reservation", choices=RESERVATIONS, default=DEFAULT_RESERVATION)
    ap.add_argument("--airspace", choices=AIRSPACES, default=DEFAULT_AIRSPACE)
    ap.add_argument("--compact", action="store_true", help="small walls, r_c 0.5-0.8 m (issue 27's layouts)")
    ap.add_argument("--policy", choices=POLICIES, default=DEFAULT_POLICY, help="the dispatch policy")
    ap.add_argument(
        "--sub-fleets", action="store_true", help="fly every smaller fleet too; print the slower pairs"
    )
    ap.add_argument(
        "--table-dispatch",
        choices=TABLE_DISPATCHES,
        default=DEFAULT_TABLE_DISPATCH,
        help="--airspace table: a brick UAV given the task it can finish soonest by the table, or the policy's pick",
    )
    args = ap.parse_args()
    limits = LayoutLimits(max_courses=6, max_per_course=12) if args.large else LayoutLimits()
    if args.compact:
        limits = LayoutLimits(max_courses=3, max_per_course=4, max_uavs_per_role=3, clearance_m=(0.5, 0.8))
    if args.sub_fleets:
        fleet_scaling(args, limits)
        return
    print(
        f"pad separation {pad_separation_m():.2f} m; airspace {args.airspace}; policy {args.policy}; limits {limits}"
    )
    print(
        "seed  wall                       fleet  r_c   pads   done  stall conf deps held min_sep env_m env_s "
        "makespan bound  wall_s"
    )
    bad = 0
    worst_m: tuple[float, int] = (0.0, -1)
    worst_s: tuple[float, int] = (0.0, -1)
    for seed in range(args.first_seed, args.first_seed + args.n):
        row = fly(
            seed, limits, args.faults, args.reservation, args.airspace, args.policy, args.table_dispatch
        )
        sep = row["min_sep"]
        ok = (
            (row["completed"] or args.faults)
            and not row["stalled"]
            and row["conflicts"] == 0
            and row["deps"] == 0
            and row["held_up"] == 0
            and (sep is None or sep >= SEPARATION_BOUND_M)
        )
        bad += not ok
        env = row["envelope"]
        env_m, env_s = ("-", "-") if env is None else (f"{env.m:.3f}", f"{env.s:.2f}")
        if env is not None:
            worst_m, worst_s = max(worst_m, (env.m, row["seed"])), max(worst_s, (env.s, row["seed"]))
        print(
            f"{row['seed']:<5} {row['wall']:<26} {row['fleet']:<6} {row['r_c']:<5.2f} {row['pads_m']:<6.2f} "
            f"{'yes' if row['completed'] else 'NO':<5} {'YES' if row['stalled'] else 'no':<5} "
            f"{row['conflicts']:<4} {row['deps']:<4} {row['held_up']:<4} {'-' if sep is None else f'{sep:.3f}':<7} "
            f"{env_m:<5} {env_s:<5} {row['makespan']:<8.1f} {row['bound']:<6.1f} {row['wall_s']:.1f}"
            + ("" if ok else f"   <-- {row['stall'] or 'stuck: ' + ', '.join(row['stuck'])}"),
            flush=True,
        )
    print(f"{bad} of {args.n} layouts failed")
    print(
        f"worst envelope excursion {worst_m[0]:.3f} m (seed {worst_m[1]}), "
        f"longest out {worst_s[0]:.2f} s (seed {worst_s[1]})"
    )


if __name__ == "__main__":
    main()
