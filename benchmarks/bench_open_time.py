"""Adhesive open and cure times (issue 31): violations and the makespan's cost over no adhesive; prints, asserts
nothing.

Walls: the 12 m running bond (``masonry blueprint running-bond --courses 3 --bricks-per-course 40
--placed-courses 1``) and the bundled pyramid (``blueprints/pyramid.yaml``). Fleets 2+1 and 4+2 (brick +
adhesion UAVs), open times 60, 120, 300, 600 s and none, cure times 0 and 120 s, the default policy and
reservation, seed 1 (``masonry.mission.simulate``). Per run: makespan, its cost over the run without an adhesive
(same wall, fleet and seed), the world's ``open_time_violations`` and ``cure_time_violations``, the re-sprays
(bead attempts failed with ``open time expired``), the median and oldest ``glue_age_s``, completion, wall time.

``--faults``: the same missions with the chaos faults (``masonry.mission.chaos``: a :class:`ChaosRun` flown by
:func:`fly_chaos`): grasp failures (``--grasp``, 0.1), the last brick UAV lost at ``--lose-at`` (400 s), mission
control stopped at each of ``--stops`` (200,600 s; dropped as by kill -9) and resumed from its SQLite journal.
Per run: completed, the world's violations (over every segment: the rebuilt world keeps counting), the
re-sprays (beads the UAVs' traces have done more than once) and whether the report explains each with a bead
attempt failed ``open time expired``, the bead attempts failed (each sprays its bead again: an expiry, or a
spray cut by a stop or a loss) and their reasons, the problems :func:`check_chaos` finds in the traces (but a
bead done again, and under ``--reservation site``, the default, conflicts and dependencies: judged on task
intervals, which the site reservation may overlap), segments, makespan.

Usage: python benchmarks/bench_open_time.py [--walls 12m,pyramid] [--fleets 2+1,4+2]
       [--open 60,120,300,600,none] [--cure 0,120] [--seed 1]
       [--faults [--grasp 0.1] [--lose-at 400] [--stops 200,600]]
Each run takes 5-60 s of CPU on the 12 m wall: give a subset on a shared machine (docs/performance/adhesive.md has the one
measured).
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import statistics
import tempfile
import time
from collections import Counter
from collections.abc import Callable, Mapping
from pathlib import Path

from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.chaos import ChaosRun, check_chaos, fly_chaos
from masonry.mission.fleet import fleet_for, with_fleet
from masonry.mission.glue import EXPIRED_REASON
from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate
from masonry.planner.dispatch import DEFAULT_RESERVATION
from masonry.sim import Faults

ROOT = Path(__file__).resolve().parents[1]
WALLS: dict[str, Callable[[], Blueprint]] = {
    "12m": lambda: running_bond(3, 40, placed_courses=1),
    "pyramid": lambda: load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
    "small": lambda: load_blueprint(ROOT / "blueprints" / "running_bond_small.yaml"),
}


def _csv(text: str) -> list[str]:
    return [x.strip() for x in text.split(",") if x.strip()]


def _fleet(text: str) -> tuple[int, int]:
    b, a = text.split("+")
    return int(b), int(a)


def _respray(r: MissionReport) -> int:
    return sum(1 for a in r.attempts if a.kind == "adhesion" and a.reason == EXPIRED_REASON)


def _row(
    wall: str, fleet: str, open_s: str, cure_s: float, r: MissionReport, base: float, wall_s: float
) -> str:
    ages = sorted((r.glue_age_s or {}).values())
    median = f"{statistics.median(ages):.0f}" if ages else "-"
    oldest = f"{ages[-1]:.0f}" if ages else "-"
    cost = f"{100.0 * (r.makespan_s - base) / base:+.1f} %" if base > 0 else "-"
    ov = "-" if r.open_time_violations is None else str(r.open_time_violations)
    cv = "-" if r.cure_time_violations is None else str(r.cure_time_violations)
    return (
        f"| {wall} | {fleet} | {open_s} | {cure_s:g} | {r.makespan_s:.1f} | {cost} | {ov} | {cv} | "
        f"{_respray(r)} | {median} | {oldest} | {'yes' if r.completed else 'NO'} | {wall_s:.0f} |"
    )


@dataclasses.dataclass(frozen=True)
class FaultRun:
    """What one run with faults gave (``--faults``)."""

    report: MissionReport
    #: check_chaos's problems, but a bead done again (a re-spray: judged by ``unexplained``) and, under the
    #: ``site`` reservation, ``conflict`` and ``dependency`` (judged on task intervals, which ``site`` may overlap)
    problems: tuple[str, ...]
    segments: int
    #: bead -> how many times the UAVs' traces have it done (more than once: its glue was sprayed again)
    sprayed: Mapping[str, int]

    @property
    def failed_beads(self) -> tuple[str | None, ...]:
        """The reason of each bead attempt that failed (its bead is sprayed again)."""
        return tuple(a.reason for a in self.report.attempts if a.kind == "adhesion" and a.status == "failed")

    @property
    def resprays(self) -> int:
        """Beads sprayed in full again (done more than once in the traces)."""
        return sum(n - 1 for n in self.sprayed.values() if n > 1)

    @property
    def unexplained(self) -> tuple[str, ...]:
        """Beads sprayed in full again more often than the report has their attempts fail with
        ``open time expired``."""
        expired = Counter(
            a.task_id for a in self.report.attempts if a.kind == "adhesion" and a.reason == EXPIRED_REASON
        )
        return tuple(sorted(b for b, n in self.sprayed.items() if n - 1 > expired[b]))


def fly_with_faults(
    bp: Blueprint,
    bricks: int,
    adhesion: int,
    *,
    seed: int,
    workdir: str | Path,
    grasp: float,
    lose_at_s: float | None,
    stops_s: tuple[float, ...],
    reservation: str = DEFAULT_RESERVATION,
) -> FaultRun:
    """Fly ``bp`` with ``bricks`` + ``adhesion`` UAVs, grasp failures, the last brick UAV lost at ``lose_at_s``
    (None: none), mission control stopped at each of ``stops_s`` and resumed from its journal (``fly_chaos``)."""
    fleet = fleet_for(bp, bricks, adhesion)
    spec = [f"grasp={grasp:g}"] if grasp > 0 else []
    if lose_at_s is not None:
        spec.append(f"uav-loss={[u.name for u in fleet if u.role == 'brick'][-1]}@{lose_at_s:g}")
    run = ChaosRun(seed, with_fleet(bp, fleet), Faults.parse(spec), stops_s=stops_s, reservation=reservation)
    out = fly_chaos(run, workdir)
    beads = {t.id for t in out.plan.tasks if t.kind == "adhesion"}
    sprayed = Counter(e.task_id for e in out.trace if e.status == "done" and e.task_id in beads)
    skip = ("conflict", "dependency") if reservation == "site" else ()
    problems = tuple(
        p
        for p in check_chaos(out)
        if not p.startswith(skip) and not (p.startswith("done twice") and p.split()[2] in beads)
    )
    return FaultRun(out.report, problems, out.segments, dict(sprayed))


def _fault_row(wall: str, fleet: str, open_s: str, cure_s: float, f: FaultRun, wall_s: float) -> str:
    r = f.report
    ov = "-" if r.open_time_violations is None else str(r.open_time_violations)
    cv = "-" if r.cure_time_violations is None else str(r.cure_time_violations)
    expired = sum(x == EXPIRED_REASON for x in f.failed_beads)
    others = Counter(x or "(no reason)" for x in f.failed_beads if x != EXPIRED_REASON)
    why = "; ".join(f"{n} {x}" for x, n in sorted(others.items())) or "-"
    explained = "yes" if not f.unexplained else "NO: " + ", ".join(f.unexplained)
    return (
        f"| {wall} | {fleet} | {open_s} | {cure_s:g} | {'yes' if r.completed else 'NO'} | {ov} | {cv} | "
        f"{f.resprays} | {explained} | {len(f.failed_beads)} | {expired} | {why} | {len(f.problems)} | "
        f"{f.segments} | {r.makespan_s:.1f} | {wall_s:.0f} |"
    )


def _glued(bp: Blueprint, open_s: str, cure_s: float) -> Blueprint:
    if (open_s, cure_s) == ("none", 0.0):
        return bp
    o = None if open_s == "none" else float(open_s)
    return dataclasses.replace(bp, adhesive=Adhesive(open_time_s=o, cure_time_s=cure_s))


def faults_main(args: argparse.Namespace) -> None:
    """``--faults``: one line per run (module docstring)."""
    stops = tuple(float(x) for x in _csv(args.stops))
    lose = None if args.lose_at == "none" else float(args.lose_at)
    print(
        f"faults: grasp {args.grasp:g}, last brick UAV lost at {args.lose_at} s, mission control stopped at "
        f"{', '.join(f'{s:g}' for s in stops) or 'never'} s and resumed from its journal; seed {args.seed}"
    )
    print(
        "| wall | fleet | open s | cure s | completed | open viol. | cure viol. | re-sprays | each says "
        "open time expired | bead attempts failed | of them open time expired | other reasons | trace problems | "
        "segments | makespan s | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    with tempfile.TemporaryDirectory() as work:
        for wall in _csv(args.walls):
            bp = WALLS[wall]()
            for fleet in _csv(args.fleets):
                bricks, adhesion = _fleet(fleet)
                for open_s in _csv(args.open):
                    for cure_s in (float(c) for c in _csv(args.cure)):
                        t0 = time.perf_counter()
                        f = fly_with_faults(
                            _glued(bp, open_s, cure_s),
                            bricks,
                            adhesion,
                            seed=args.seed,
                            workdir=work,
                            grasp=args.grasp,
                            lose_at_s=lose,
                            stops_s=stops,
                            reservation=args.reservation,
                        )
                        print(
                            _fault_row(wall, fleet, open_s, cure_s, f, time.perf_counter() - t0), flush=True
                        )
                        for p in f.problems:
                            print(f"    {p}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="12m,pyramid")
    ap.add_argument("--fleets", default="2+1,4+2")
    ap.add_argument("--open", default="60,120,300,600,none", help="open times in s, or none")
    ap.add_argument("--cure", default="0,120", help="cure times in s")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument(
        "--faults", action="store_true", help="with grasp failures, a UAV lost, mc stopped and resumed"
    )
    ap.add_argument("--grasp", type=float, default=0.1, help="--faults: grasp failure probability")
    ap.add_argument("--lose-at", default="400", help="--faults: the last brick UAV is lost then (s), or none")
    ap.add_argument("--stops", default="200,600", help="--faults: mission control stops then (s), resumed")
    ap.add_argument("--reservation", default=DEFAULT_RESERVATION, help="--faults: site or task")
    args = ap.parse_args()
    if args.faults:
        logging.getLogger("masonry").setLevel(
            logging.ERROR
        )  # each loss and resume is a warning: the row says it
        faults_main(args)
        return
    print(
        "| wall | fleet | open s | cure s | makespan s | cost | open viol. | cure viol. | re-sprays | "
        "median glue age s | oldest s | completed | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for wall in _csv(args.walls):
        bp = WALLS[wall]()
        for fleet in _csv(args.fleets):
            bricks, adhesion = _fleet(fleet)
            base = 0.0
            # the reference first (no adhesive at all: today's mission), when the sweep has it
            cases = [(o, float(c)) for o in _csv(args.open) for c in _csv(args.cure)]
            cases.sort(key=lambda oc: oc != ("none", 0.0))
            for open_s, cure_s in cases:
                glued = _glued(bp, open_s, cure_s)
                t0 = time.perf_counter()
                r = simulate(glued, brick_uavs=bricks, adhesion_uavs=adhesion, seed=args.seed)
                wall_s = time.perf_counter() - t0
                if glued is bp:
                    base = r.makespan_s
                print(_row(wall, fleet, open_s, cure_s, r, base, wall_s), flush=True)
            if base == 0.0:
                print(f"(no reference for {wall} {fleet}: add none to --open and 0 to --cure for the cost)")


if __name__ == "__main__":
    main()
