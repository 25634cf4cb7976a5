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
schedule and the speed-up over 1+1 of both.

Printed per wall, as Markdown tables (docs/performance/fleet.md, "After: `site` as the default" and "Fleet against
the CP-SAT schedule"; the first figures, before issue 15's fleet work, in docs/performance/history.md):

1. fleet, makespan, speed-up over 1+1, the schedule's makespan, its speed-up over 1+1, simulated / schedule,
   ``lower_bound_s``, ratio, ``min_separation_m``, the mean brick and adhesion attempt, the share of adhesion
   segments sprayed chained (done attempts whose descent took less than halfway from ``chain_descent_s`` to
   ``spray_descent_s``: the UAV came from the end of the segment before, not from the transit altitude), the
   UAVs' mean ``idle_s`` and ``waiting_s``, simulated and wall seconds;
2. the phase totals: seconds per phase (docs/mission.md, "Where the time goes") summed over every attempt of
   the mission (failed ones too), and the share of waiting + holding.

Usage: python benchmarks/bench_fleet.py [--quick] [--seed 1] [--policy critical-path] [--reservation site|task]
       [--airspace columns|table]
       [--walls 12m,6x30,pyramid]
       [--fleets 1+1,2+1,4+2,6+3,8+4]
       [--schedule-time-s 90]
``--quick``: a 2-course wall of 12 bricks per course and fleets 1+1, 2+1, 4+2 (seconds, for a smoke run).
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.report import MissionReport, phase_totals
from masonry.mission.reserved import AIRSPACES, DEFAULT_AIRSPACE
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.dispatch import DEFAULT_RESERVATION, RESERVATIONS
from masonry.planner.schedule import solve_schedule
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

    @property
    def fleet(self) -> str:
        return f"{self.bricks} + {self.adhesion}"


def fly(
    blueprint: Blueprint,
    bricks: int,
    adhesion: int,
    seed: int,
    policy: str,
    reservation: str,
    airspace: str = DEFAULT_AIRSPACE,
) -> Run:
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
    )
    return Run(bricks, adhesion, report, time.perf_counter() - wall0)


def schedule_makespan(
    blueprint: Blueprint, bricks: int, adhesion: int, reservation: str, time_limit_s: float
) -> tuple[float, str, float]:
    """The makespan of ``masonry schedule`` for the wall and fleet (as the command calls the solver: the fleet of
    ``fleet_for``, the plan of the blueprint, its cruise altitude, 2 workers, seed 0), its status and wall time."""
    fleet = fleet_for(blueprint, bricks, adhesion)
    bp = blueprint if fleet == blueprint.fleet else with_fleet(blueprint, fleet)
    wall0 = time.perf_counter()
    result = solve_schedule(
        make_plan(bp),
        fleet,
        cruise_altitude_m=bp.cruise_altitude_m,
        reservation=reservation,
        time_limit_s=time_limit_s,
        seed=0,
        workers=2,
        decomposition="auto",
    )
    return result.makespan_s, result.status, time.perf_counter() - wall0


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


def scaling_table(runs: list[Run]) -> list[str]:
    base = runs[0].report.makespan_s if runs and runs[0].report.completed else float("nan")
    base_schedule_s = runs[0].schedule_s if runs else None
    lines = [
        "| fleet (brick + adhesion) | makespan | speed-up over 1 + 1 | schedule (CP-SAT) | its speed-up over 1 + 1 "
        "| simulated / schedule | lower_bound_s | ratio | min_separation_m "
        "| mean brick attempt | mean adhesion attempt | chained segments | mean idle_s | mean waiting_s | done "
        "| simulated | wall |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
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
    ap.add_argument("--policy", default="critical-path")
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
    args = ap.parse_args()
    walls = args.walls.split(",") if args.walls else (["quick"] if args.quick else ["12m", "6x30", "pyramid"])
    unknown = [w for w in walls if w not in WALLS]
    if unknown:
        ap.error(f"--walls: unknown wall {unknown[0]!r} (known: {', '.join(WALLS)})")
    if not (args.schedule_time_s >= 0.0 and args.schedule_time_s < float("inf")):
        ap.error(f"--schedule-time-s must be a number >= 0, got {args.schedule_time_s!r}")
    fleets = _pairs(args.fleets) if args.fleets else (QUICK_FLEETS if args.quick else FLEETS)
    print(
        f"bench_fleet: seed {args.seed}, policy {args.policy}, reservation {args.reservation}, "
        f"airspace {args.airspace}, geometric camera, "
        f"schedule {args.schedule_time_s:g} s; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"
    )
    for key in walls:
        what, make = WALLS[key]
        blueprint = make()
        todo = sum(1 for b in blueprint.bricks if not b.placed)
        print(f"\n## {what} ({todo} bricks to place)\n", flush=True)
        runs = []
        for bricks, adhesion in fleets:
            run = fly(blueprint, bricks, adhesion, args.seed, args.policy, args.reservation, args.airspace)
            print(
                f"  flown {run.fleet}: makespan {run.report.makespan_s:,.0f} s in {run.wall_s:.0f} s wall",
                flush=True,
            )
            if args.schedule_time_s > 0:
                made, status, took = schedule_makespan(
                    blueprint, bricks, adhesion, args.reservation, args.schedule_time_s
                )
                run = dataclasses.replace(run, schedule_s=made, schedule_status=status, schedule_wall_s=took)
                print(
                    f"  scheduled {run.fleet}: makespan {made:,.0f} s ({status}) in {took:.0f} s", flush=True
                )
            runs.append(run)
        print()
        print("\n".join(scaling_table(runs)))
        print("\nPhase totals (seconds, summed over every attempt):\n")
        print("\n".join(phase_table(runs)), flush=True)


if __name__ == "__main__":
    main()
