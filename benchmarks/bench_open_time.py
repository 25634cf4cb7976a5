"""Adhesive open and cure times (issue 31): violations and the makespan's cost over no adhesive; prints, asserts
nothing.

Walls: the 12 m running bond (``masonry blueprint running-bond --courses 3 --bricks-per-course 40
--placed-courses 1``) and the bundled pyramid (``blueprints/pyramid.yaml``). Fleets 2+1 and 4+2 (brick +
adhesion UAVs), open times 60, 120, 300, 600 s and none, cure times 0 and 120 s, the default policy and
reservation, seed 1 (``masonry.mission.simulate``). Per run: makespan, its cost over the run without an adhesive
(same wall, fleet and seed), the world's ``open_time_violations`` and ``cure_time_violations``, the re-sprays
(bead attempts failed with ``open time expired``), the median and oldest ``glue_age_s``, completion, wall time.

Usage: python benchmarks/bench_open_time.py [--walls 12m,pyramid] [--fleets 2+1,4+2]
       [--open 60,120,300,600,none] [--cure 0,120] [--seed 1]
Each run takes 5-60 s of CPU on the 12 m wall: give a subset on a shared machine (docs/performance/adhesive.md has the one
measured).
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from collections.abc import Callable
from pathlib import Path

from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.glue import EXPIRED_REASON
from masonry.mission.report import MissionReport
from masonry.mission.simulate import simulate

ROOT = Path(__file__).resolve().parents[1]
WALLS: dict[str, Callable[[], Blueprint]] = {
    "12m": lambda: running_bond(3, 40, placed_courses=1),
    "pyramid": lambda: load_blueprint(ROOT / "blueprints" / "pyramid.yaml"),
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


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="12m,pyramid")
    ap.add_argument("--fleets", default="2+1,4+2")
    ap.add_argument("--open", default="60,120,300,600,none", help="open times in s, or none")
    ap.add_argument("--cure", default="0,120", help="cure times in s")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
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
                if (open_s, cure_s) == ("none", 0.0):
                    glued = bp
                else:
                    o = None if open_s == "none" else float(open_s)
                    glued = dataclasses.replace(bp, adhesive=Adhesive(open_time_s=o, cure_time_s=cure_s))
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
