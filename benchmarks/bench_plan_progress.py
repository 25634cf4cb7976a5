"""The UAVs' ``plan_progress`` (issue 27 §2.2): missions flown with mission control reading it; prints, asserts nothing.

For each wall (``--walls``, names of ``bench_fleet.WALLS``) and fleet (``--fleets``, BRICK+ADHESION) at ``--seed``
under ``--airspace``: the makespan, whether it completed, the least separation, the envelope excursion (metres and
seconds, :mod:`masonry.mission.envelope`) and, under the table, how many times it extended a late UAV's windows
(``extended``, ``forced``) and how many of the UAVs' reports it took its place along the grant from
(``plan_read``: the UAV's own ``plan_progress``, matching the grant; the rest by the position rule).

Usage: PYTHONPATH=src python benchmarks/bench_plan_progress.py --walls pyramid,12m --fleets 2+1,4+2
       --airspace table --seed 1
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets

from masonry.mission.reserved import AIRSPACES, TableClearance
from masonry.mission.sim_options import SimOptions
from masonry.mission.simulate import SimulatedMission


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--walls", default="pyramid,12m")
    ap.add_argument("--fleets", default="2+1,4+2")
    ap.add_argument("--airspace", choices=AIRSPACES, default="table")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    print(
        "| wall | fleet | airspace | makespan s | complete | least sep m | envelope m, s | extended / forced | plan_read | wall s |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        options = SimOptions(
            brick_uavs=bricks,
            adhesion_uavs=adhesion,
            seed=args.seed,
            policy="critical-path",
            camera="geometric",
            reservation="site",
            airspace=args.airspace,
        )
        t0 = time.perf_counter()
        mission = SimulatedMission.from_blueprint(WALLS[wall][1](), options)
        report = mission.run()
        air = mission.control.columns
        counts = "-"
        read = "-"
        if isinstance(air, TableClearance):
            counts = f"{air.extended} / {air.forced}"
            read = str(air.plan_read)
        env = report.envelope_excursion
        env_text = "-" if env is None else f"{env.m:.3f}, {env.s:.2f}"
        sep = "-" if report.min_separation_m is None else f"{report.min_separation_m:.3f}"
        print(
            f"| {wall} | {bricks} + {adhesion} | {args.airspace} | {report.makespan_s:.1f} | {report.completed} "
            f"| {sep} | {env_text} | {counts} | {read} | {time.perf_counter() - t0:.0f} |",
            flush=True,
        )


if __name__ == "__main__":
    main()
