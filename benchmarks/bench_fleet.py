"""Fleet scaling (issues 15, 27): makespan against the number of UAVs, beside the CP-SAT schedule's, and where the
time goes; prints, asserts nothing.

Walls: two running bonds from :mod:`masonry.blueprint_gen`, one course pre-placed: the 12 m wall (``masonry
blueprint running-bond --courses 3 --bricks-per-course 40 --placed-courses 1``: 80 bricks and 158 adhesion tasks
to do) and a 6-course wall of 30 bricks per course (150 bricks to do); and the bundled pyramid
(``blueprints/pyramid.yaml``). Each is flown by fleets of 1+1, 2+1, 4+2, 6+3 and 8+4 (brick + adhesion) UAVs with
the default policy, seed 1, geometric camera (``masonry.mission.simulate``).

The yardstick (issue 27): for the same wall and fleet, the makespan of ``masonry schedule`` (OR-Tools CP-SAT,
minimum task durations, the same reservation rule, ``--schedule-time-s`` seconds, 90 by default, 2 workers,
seed 0; ``--schedule-time-s 0`` leaves it out). Printed beside the simulated makespan: the ratio simulated /
schedule and the speed-up over 1+1 of both. Beside it the physical schedule (``masonry schedule --physical``,
``--physical`` terms, ``all`` by default: the pallet, the battery swaps and the site visit at its floor, docs/schedule.md; ``none`` leaves
it out), its battery swaps, its speed-up over 1+1 and simulated / physical.

Printed per wall, as Markdown tables (docs/performance/fleet.md, "After: `site` as the default" and "Fleet against
the CP-SAT schedule"; the first figures, before issue 15's fleet work, in docs/performance/history.md):

1. fleet, makespan, speed-up over 1+1, the schedule's makespan, its speed-up over 1+1, simulated / schedule,
   ``lower_bound_s``, ratio, ``min_separation_m``, the mean brick and adhesion attempt, the share of adhesion
   segments sprayed chained (done attempts whose descent took less than halfway from ``chain_descent_s`` to
   ``spray_descent_s``: the UAV came from the end of the segment before, not from the transit altitude), the
   UAVs' mean ``idle_s`` and ``waiting_s``, simulated and wall seconds;
2. the phase totals: seconds per phase (docs/mission.md, "Where the time goes") summed over every attempt of
   the mission (failed ones too), and the share of waiting + holding.

``--policy`` takes a comma-separated list (``critical-path,schedule``): each wall and fleet is flown by each, one
table per policy. ``schedule`` follows the CP-SAT schedule above (``masonry sim --policy schedule``); the
schedule is solved once per wall, fleet, reservation and time limit and cached on disk
(``benchmarks/schedule_cache.py``, ``--schedule-cache DIR``), so every seed and policy of a sweep uses the same.
``--schedule-physical TERMS`` gives that schedule physical terms (e.g. ``flown``: ``masonry schedule --physical
flown``; none by default, the plain schedule).

Usage: python benchmarks/bench_fleet.py [--quick] [--seed 1] [--policy critical-path[,schedule]]
       [--reservation site|task] [--airspace columns|table]
       [--walls 12m,6x30,pyramid]
       [--fleets 1+1,2+1,4+2,6+3,8+4]
       [--schedule-time-s 90] [--physical all|pallet|battery|visit|none] [--schedule-cache DIR]
       [--schedule-physical none|flown|...] [--table-dispatch soonest|policy]
``--table-dispatch policy``: under ``--airspace table`` the brick UAVs take the policy's pick, not the task they
can finish soonest by the table (:mod:`masonry.mission.table_dispatch`; issue 27 §1.6).
``--quick``: a 2-course wall of 12 bricks per course and fleets 1+1, 2+1, 4+2 (seconds, for a smoke run).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from schedule_cache import cached_schedule, solve_as_the_cli

from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.errors import PlanningError
from masonry.mission.report import MissionReport, phase_totals
from masonry.mission.reserved import AIRSPACES, DEFAULT_AIRSPACE
from masonry.mission.simulate import simulate
from masonry.mission.table_dispatch import DEFAULT_TABLE_DISPATCH, TABLE_DISPATCHES
from masonry.planner.dispatch import DEFAULT_RESERVATION, POLICIES, RESERVATIONS
from masonry.planner.schedule import physical_terms
from masonry.planner.schedule_policy import SCHEDULE_POLICY
from masonry.planner.schedule_values import OfflineSchedule
from masonry.ports import PHASES
from masonry.timing import DEFAULT_TIMING

BLUEPRINTS = Path(__file__).resolve().parent.parent / "blueprints"

#: name -> (description, generator): the walls of the issue
WALLS: dict[str, tuple[str, Callable[[], Blueprint]]] = {
    "12m": ("12 m running bond, 3 x 40, 1 placed course", lambda: running_bond(3, 40, placed_courses=1)),
    "6x30": ("running bond 6 x 30, 1 placed course", lambda: running_bond(6, 30, placed_courses=1)),
    "pyramid": (
        "the bundled pyramid (blueprints/pyramid.yaml)",
        lambda: load_blueprint(BLUEPRINTS / "pyramid.yaml"),
    ),
    "quick": ("running bond 2 x 12, 1 placed course", lambda: running_bond(2, 12, placed_courses=1)),
}
#: CP-SAT's time per schedule (the issue's yardstick: ``masonry schedule`` with 90 s)
DEFAULT_SCHEDULE_TIME_S = 90.0
FLEETS = ((1, 1), (2, 1), (4, 2), (6, 3), (8, 4))
QUICK_FLEETS = ((1, 1), (2, 1), (4, 2))


def walls_and_fleets(ap: argparse.ArgumentParser, walls: str, fleets: str) -> list[tuple[str, int, int]]:
    """``--walls`` x ``--fleets`` (comma-separated names of :data:`WALLS`, BRICK+ADHESION pairs) as (wall, brick
    UAVs, adhesion UAVs), wall by wall; a bad name or pair ends the run with argparse's one-line error."""
    out = []
    for wall in walls.split(","):
        if wall not in WALLS:
            ap.error(f"--walls: unknown wall {wall!r} (one of {', '.join(WALLS)})")
        for fleet in fleets.split(","):
            try:
                bricks, adhesion = (int(x) for x in fleet.split("+"))
            except ValueError:
                ap.error(f"--fleets: {fleet!r} is not BRICK+ADHESION (e.g. 4+2)")
            out.append((wall, bricks, adhesion))
    return out


def sweep(description: str) -> Iterator[tuple[str, Blueprint, int, int, int]]:
    """The airspace tracers' command line (``--walls`` names of :data:`WALLS`, ``--fleets`` BRICK+ADHESION pairs,
    ``--seeds``, each comma-separated; 12m, 4+2,8+4 and 1 by default) as (the wall's title, its blueprint, brick
    UAVs, adhesion UAVs, seed), wall by wall; a bad name, pair or seed ends the run with argparse's one-line error."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2,8+4")
    ap.add_argument("--seeds", default="1")
    args = ap.parse_args()
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        ap.error(f"--seeds: {args.seeds!r} is not a comma-separated list of integers")
    blueprints: dict[str, Blueprint] = {}
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        if wall not in blueprints:
            blueprints[wall] = WALLS[wall][1]()
        for seed in seeds:
            yield WALLS[wall][0], blueprints[wall], bricks, adhesion, seed


@dataclass(frozen=True)
class Run:
    """One mission of the sweep and what it took."""

    bricks: int
    adhesion: int
    report: MissionReport
    wall_s: float
    #: the CP-SAT schedule's makespan for the same wall and fleet (None: not computed)
    schedule_s: float | None = None
    #: its status (optimal / feasible) and the seconds CP-SAT took
    schedule_status: str = ""
    schedule_wall_s: float = 0.0
    #: the physical schedule's makespan (``--physical``; None: not computed), status and battery swaps
    physical_s: float | None = None
    physical_status: str = ""
    physical_swaps: int = 0

    @property
    def fleet(self) -> str:
        return f"{self.bricks} + {self.adhesion}"


def simulate_fleet(
    blueprint: Blueprint, bricks: int, adhesion: int, seed: int, **extra: Any
) -> MissionReport:
    """The issue's mission as the fleet benchmarks fly it: ``critical-path``, the ``site`` rule, the geometric
    camera (``extra``: any other keyword of :func:`masonry.mission.simulate.simulate`, e.g. ``events_sink``)."""
    kwargs: dict[str, Any] = {
        "policy": "critical-path",
        "camera": "geometric",
        "reservation": "site",
        **extra,
    }
    return simulate(blueprint, brick_uavs=bricks, adhesion_uavs=adhesion, seed=seed, **kwargs)


def fly(
    blueprint: Blueprint,
    bricks: int,
    adhesion: int,
    seed: int,
    policy: str,
    reservation: str,
    airspace: str = DEFAULT_AIRSPACE,
    schedule: OfflineSchedule | None = None,
    table_dispatch: str = DEFAULT_TABLE_DISPATCH,
) -> Run:
    """One mission; ``schedule`` is the one ``policy`` ``schedule`` follows (:func:`cached_schedule`)."""
    wall0 = time.perf_counter()
    report = simulate(
        blueprint,
        brick_uavs=bricks,
        adhesion_uavs=adhesion,
        seed=seed,
        policy=policy,
        camera="geometric",
        reservation=reservation,
        airspace=airspace,
        schedule=schedule if policy == SCHEDULE_POLICY else None,
        table_dispatch=table_dispatch,
    )
    return Run(bricks, adhesion, report, time.perf_counter() - wall0)


def schedule_makespan(
    blueprint: Blueprint,
    bricks: int,
    adhesion: int,
    reservation: str,
    time_limit_s: float,
    physical: str = "",
) -> tuple[float, str, float, int]:
    """The makespan of ``masonry schedule [--physical TERMS]`` for the wall and fleet (as the command calls the
    solver: the fleet of ``fleet_for``, the plan of the blueprint, its cruise altitude and r_c, 2 workers, seed
    0), its status, wall time and battery swaps."""
    wall0 = time.perf_counter()
    result = solve_as_the_cli(blueprint, bricks, adhesion, reservation, time_limit_s, physical)
    greedy = sum(
        1 for q in result.parts if q.get("status") == "greedy"
    )  # CP-SAT found nothing in a part's time
    status = f"{result.status}, {greedy} of {len(result.parts)} parts greedy" if greedy else result.status
    return result.makespan_s, status, time.perf_counter() - wall0, result.battery_swaps


def policies_of(ap: argparse.ArgumentParser, text: str, schedule_time_s: float) -> list[str]:
    """``--policy`` as a list; ``schedule`` needs a schedule (``--schedule-time-s`` above 0)."""
    out = text.split(",")
    for p in out:
        if p != SCHEDULE_POLICY and p not in POLICIES:
            ap.error(f"--policy: unknown policy {p!r} (one of {', '.join((*POLICIES, SCHEDULE_POLICY))})")
    if SCHEDULE_POLICY in out and schedule_time_s <= 0:
        ap.error("--policy schedule needs a schedule: --schedule-time-s above 0")
    return out


def _mean_attempt_s(report: MissionReport, kind: str) -> float:
    spans = [a.end_s - a.start_s for a in report.attempts if a.kind == kind and a.end_s is not None]
    return statistics.fmean(spans) if spans else float("nan")


def _chained(report: MissionReport) -> str:
    """Adhesion segments sprayed chained, of those done: a descent shorter than halfway from a chained one's to
    a full one's (the UAV hovered at the spraying height already)."""
    limit_s = (DEFAULT_TIMING.chain_descent_s + DEFAULT_TIMING.spray_descent_s) / 2.0
    done = [
        a for a in report.attempts if a.kind == "adhesion" and a.status == "done" and a.phases is not None
    ]
    chained = sum(1 for a in done if a.phases is not None and a.phases.descending < limit_s)
    return f"{chained}/{len(done)} ({chained / len(done):.0%})" if done else "-"


def _sep(v: float | None) -> str:
    return "-" if v is None else f"{v:.2f}"


def _schedule_cells(r: Run, base_s: float | None) -> str:
    """The schedule's makespan, its speed-up over the first fleet's schedule, and simulated / schedule."""
    if r.schedule_s is None or r.schedule_s <= 0:
        return "- | - | -"
    speedup = base_s / r.schedule_s if base_s else float("nan")
    return f"{r.schedule_s:,.0f} s ({r.schedule_status}) | {speedup:.2f} | {r.report.makespan_s / r.schedule_s:.2f}"


def _physical_cells(r: Run, base_s: float | None) -> str:
    """The physical schedule's makespan (its swaps), its speed-up over the first fleet's, simulated / it."""
    if r.physical_s is None or r.physical_s <= 0:
        return "- | - | -"
    speedup = base_s / r.physical_s if base_s else float("nan")
    return (
        f"{r.physical_s:,.0f} s ({r.physical_status}, {r.physical_swaps} swaps) | {speedup:.2f} "
        f"| {r.report.makespan_s / r.physical_s:.2f}"
    )


def scaling_table(runs: list[Run]) -> list[str]:
    base = runs[0].report.makespan_s if runs and runs[0].report.completed else float("nan")
    base_schedule_s = runs[0].schedule_s if runs else None
    base_physical_s = runs[0].physical_s if runs else None
    lines = [
        "| fleet (brick + adhesion) | makespan | speed-up over 1 + 1 | schedule (CP-SAT) | its speed-up over 1 + 1 "
        "| simulated / schedule | physical schedule | its speed-up over 1 + 1 | simulated / physical "
        "| lower_bound_s | ratio | min_separation_m "
        "| mean brick attempt | mean adhesion attempt | chained segments | mean idle_s | mean waiting_s | done "
        "| simulated | wall |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in runs:
        rep = r.report
        done = sum(1 for t in rep.tasks if t.status == "done")
        ratio = rep.makespan_s / rep.lower_bound_s if rep.lower_bound_s > 0 else float("nan")
        speedup = base / rep.makespan_s if rep.makespan_s > 0 else float("nan")
        idle = statistics.fmean(u.idle_s for u in rep.uavs)
        waiting = statistics.fmean(u.waiting_s for u in rep.uavs)
        lines.append(
            f"| {r.fleet} | {rep.makespan_s:,.0f} s | {speedup:.2f} | {_schedule_cells(r, base_schedule_s)} "
            f"| {_physical_cells(r, base_physical_s)} "
            f"| {rep.lower_bound_s:,.0f} s | {ratio:.2f} "
            f"| {_sep(rep.min_separation_m)} | {_mean_attempt_s(rep, 'brick'):.1f} s "
            f"| {_mean_attempt_s(rep, 'adhesion'):.1f} s | {_chained(rep)} | {idle:,.0f} s | {waiting:,.0f} s "
            f"| {done}/{len(rep.tasks)}{'' if rep.completed else ' (NOT completed)'} "
            f"| {rep.sim_time_s:,.0f} s | {r.wall_s:.0f} s |"
        )
    return lines


def phase_table(runs: list[Run]) -> list[str]:
    shown = [p for p in PHASES if any(getattr(phase_totals(r.report.attempts), p) > 0 for r in runs)]
    lines = [
        "| fleet | " + " | ".join(shown) + " | all | waiting + holding |",
        "|---|" + "---|" * (len(shown) + 2),
    ]
    for r in runs:
        totals = phase_totals(r.report.attempts)
        share = totals.clearance_s / totals.total_s if totals.total_s > 0 else float("nan")
        cells = " | ".join(f"{getattr(totals, p):,.0f}" for p in shown)
        lines.append(f"| {r.fleet} | {cells} | {totals.total_s:,.0f} | {share:.0%} |")
    return lines


def _pairs(text: str) -> tuple[tuple[int, int], ...]:
    out = []
    for item in text.split(","):
        b, a = item.split("+")
        out.append((int(b), int(a)))
    return tuple(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="a small wall and three fleets")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--policy", default="critical-path", help="comma-separated, e.g. critical-path,schedule")
    ap.add_argument("--reservation", default=DEFAULT_RESERVATION, choices=RESERVATIONS)
    ap.add_argument("--airspace", default=DEFAULT_AIRSPACE, choices=AIRSPACES)
    ap.add_argument("--walls", default=None, help=f"comma-separated, of {', '.join(WALLS)}")
    ap.add_argument("--fleets", default=None, help="comma-separated brick+adhesion pairs, e.g. 1+1,2+1")
    ap.add_argument(
        "--schedule-time-s",
        type=float,
        default=DEFAULT_SCHEDULE_TIME_S,
        help="CP-SAT's time for each wall and fleet's schedule, s (0: no schedule column)",
    )
    ap.add_argument(
        "--physical",
        default="all",
        help="the physical schedule's terms (pallet, battery, all; none: no physical column)",
    )
    ap.add_argument("--schedule-cache", type=Path, default=None, help="directory of the cached schedules")
    ap.add_argument(
        "--schedule-physical",
        default="none",
        help="the physical terms of the schedule --policy schedule follows (e.g. flown; none: the plain one)",
    )
    ap.add_argument(
        "--table-dispatch",
        choices=TABLE_DISPATCHES,
        default=DEFAULT_TABLE_DISPATCH,
        help="--airspace table: a brick UAV given the task it can finish soonest by the table, or the policy's pick",
    )
    args = ap.parse_args()
    walls = args.walls.split(",") if args.walls else (["quick"] if args.quick else ["12m", "6x30", "pyramid"])
    unknown = [w for w in walls if w not in WALLS]
    if unknown:
        ap.error(f"--walls: unknown wall {unknown[0]!r} (known: {', '.join(WALLS)})")
    if not (args.schedule_time_s >= 0.0 and args.schedule_time_s < float("inf")):
        ap.error(f"--schedule-time-s must be a number >= 0, got {args.schedule_time_s!r}")
    try:
        physical_terms(args.physical)
    except PlanningError as exc:
        ap.error(f"--physical: {exc}")
    try:
        physical_terms(args.schedule_physical)
    except PlanningError as exc:
        ap.error(f"--schedule-physical: {exc}")
    policies = policies_of(ap, args.policy, args.schedule_time_s)
    fleets = _pairs(args.fleets) if args.fleets else (QUICK_FLEETS if args.quick else FLEETS)
    print(
        f"bench_fleet: seed {args.seed}, policy {', '.join(policies)}, reservation {args.reservation}, "
        f"airspace {args.airspace}, geometric camera, "
        f"schedule {args.schedule_time_s:g} s, physical {args.physical}; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"
    )
    for key in walls:
        what, make = WALLS[key]
        blueprint = make()
        todo = sum(1 for b in blueprint.bricks if not b.placed)
        print(f"\n## {what} ({todo} bricks to place)\n", flush=True)
        runs: dict[str, list[Run]] = {p: [] for p in policies}
        for bricks, adhesion in fleets:
            schedule = None
            if args.schedule_time_s > 0:
                schedule, took, cached = cached_schedule(
                    blueprint,
                    bricks,
                    adhesion,
                    args.reservation,
                    args.schedule_time_s,
                    args.schedule_cache,
                    physical=args.schedule_physical,
                )
                print(
                    f"  scheduled {bricks} + {adhesion}: makespan {schedule.makespan_s:,.0f} s "
                    f"({schedule.status}) {'from the cache' if cached else 'solved'} in {took:.0f} s",
                    flush=True,
                )
            physical: tuple[float, str, int] | None = None
            if args.schedule_time_s > 0 and args.physical not in ("", "none"):
                made, status, took, swaps = schedule_makespan(
                    blueprint, bricks, adhesion, args.reservation, args.schedule_time_s, args.physical
                )
                physical = (made, status, swaps)
                print(
                    f"  scheduled {bricks} + {adhesion} --physical {args.physical}: makespan {made:,.0f} s "
                    f"({status}, {swaps} swaps) in {took:.0f} s",
                    flush=True,
                )
            for policy in policies:
                run = fly(
                    blueprint,
                    bricks,
                    adhesion,
                    args.seed,
                    policy,
                    args.reservation,
                    args.airspace,
                    schedule,
                    args.table_dispatch,
                )
                if schedule is not None:
                    run = dataclasses.replace(
                        run,
                        schedule_s=schedule.makespan_s,
                        schedule_status=schedule.status,
                        schedule_wall_s=schedule.solve_time_s,
                    )
                if physical is not None:
                    made, status, swaps = physical
                    run = dataclasses.replace(
                        run, physical_s=made, physical_status=status, physical_swaps=swaps
                    )
                print(
                    f"  flown {run.fleet} ({policy}): makespan {run.report.makespan_s:,.0f} s "
                    f"in {run.wall_s:.0f} s wall{followed_note(run.report)}",
                    flush=True,
                )
                runs[policy].append(run)
        for policy in policies:
            print(f"\n### {policy}\n")
            print("\n".join(scaling_table(runs[policy])))
            print("\nPhase totals (seconds, summed over every attempt):\n")
            print("\n".join(phase_table(runs[policy])), flush=True)


def followed_note(report: MissionReport) -> str:
    """``, followed the schedule in N of M assignments`` (``--policy schedule``), else nothing."""
    if report.schedule_assignments is None:
        return ""
    return (
        f", followed the schedule in {report.schedule_followed} of {report.schedule_assignments} assignments"
    )


if __name__ == "__main__":
    main()
