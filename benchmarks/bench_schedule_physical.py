"""What each physical term of the offline schedule costs (issue 27): ``masonry schedule`` plain, with the pallet,
with the battery swaps and with both, per wall and fleet; prints, asserts nothing.

The walls and fleets of ``benchmarks/bench_fleet.py`` (``--walls``, ``--fleets``); each schedule as ``masonry
schedule [--physical TERMS]`` computes it (the fleet of ``fleet_for``, the ``site`` rule, 2 workers, seed 0,
``--time-s`` seconds). Printed per wall, a Markdown table: per fleet and model its makespan (status, battery
swaps), its ratio to the plain schedule and its speed-up over the first fleet's with the same terms.

Usage: python benchmarks/bench_schedule_physical.py [--walls pyramid,12m] [--fleets 1+1,4+2,8+4] [--time-s 30]
       [--models plain,pallet,battery,visit,all]
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, schedule_makespan, walls_and_fleets

from masonry.errors import PlanningError
from masonry.planner.schedule import physical_terms


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--walls", default="pyramid,12m", help=f"comma-separated, of {', '.join(WALLS)}")
    ap.add_argument("--fleets", default="1+1,4+2,8+4", help="comma-separated brick+adhesion pairs")
    ap.add_argument("--time-s", type=float, default=30.0, help="CP-SAT's time per schedule, s")
    ap.add_argument("--models", default="plain,pallet,battery,visit,all", help="plain, or --physical terms")
    args = ap.parse_args()
    if not (args.time_s > 0 and args.time_s < float("inf")):
        ap.error(f"--time-s must be > 0, got {args.time_s!r}")
    models = args.models.split(",")
    for model in models:
        try:
            physical_terms("" if model == "plain" else model)
        except PlanningError as exc:
            ap.error(f"--models: {exc}")
    runs = walls_and_fleets(ap, args.walls, args.fleets)
    print(
        f"bench_schedule_physical: site, {args.time_s:g} s per schedule, 2 workers, seed 0; "
        f"{os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f}"
    )
    wall_name = None
    base: dict[str, float] = {}
    for wall, bricks, adhesion in runs:
        if wall != wall_name:
            wall_name, base = wall, {}
            print(f"\n## {WALLS[wall][0]}\n")
            print("| fleet | model | makespan | / plain | speed-up over the first fleet | solved in |")
            print("|---|---|---|---|---|---|")
        bp = WALLS[wall][1]()
        plain_s = None
        for model in models:
            made, status, took, swaps = schedule_makespan(
                bp, bricks, adhesion, "site", args.time_s, "" if model == "plain" else model
            )
            plain_s = made if model == "plain" else plain_s
            base.setdefault(model, made)
            ratio = f"{made / plain_s:.3f}" if plain_s else "-"
            print(
                f"| {bricks} + {adhesion} | {model} | {made:,.1f} s ({status}, {swaps} swaps) | {ratio} "
                f"| {base[model] / made:.2f} | {took:.0f} s |",
                flush=True,
            )


if __name__ == "__main__":
    main()
