"""Where a site visit's flight in goes under ``--airspace table`` (issue 27): from the approach spot or not, the
wait for the grant after the site freed and the flight from the grant to down; prints, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, geometric camera, the
table), recording each hop the table grants (from where, at which layer, its plan's timed descent) and when its UAV
says it is down, and prints per role (``brick``, ``glue``) and start (``spot``: from its approach spot, held back
by the site gate there; ``other``): the visits, the mean seconds from the end of the last conflicting task's site
interval to the grant (``gap``: the wait for the grant once the site freed), from the grant to down (``flight``),
the plan's timed flight, the drop from the start to the site, the layer, and the start's and the site's altitude;
then the table's counters. ``--each`` prints every visit from a spot.

Usage: python benchmarks/bench_approach_visits.py [--walls pyramid] [--fleets 2+1] [--seed 1] [--each]
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets

from masonry.mission import reserved, reserved_requests
from masonry.mission.airspace_state import Phase
from masonry.mission.simulate import SimulatedMission

#: a hop down: (UAV, granted at s, from its approach spot, start, site, down at s, timed flight s, layer m)
Hop = tuple[str, float, bool, Any, Any, float, float, float]


def fly(blueprint: Any, bricks: int, adhesion: int, seed: int) -> tuple[Any, Any, list[Hop]]:
    """Fly the mission under the table, recording each granted hop and when its UAV was down."""
    granted: dict[str, tuple[float, bool, Any, Any, Any]] = {}
    hops: list[Hop] = []
    evaluate, end_transit = reserved_requests.evaluate, reserved.TableClearance.end_transit

    def recorded_evaluate(c: Any, uav: str, u: Any, now_s: float) -> Any:
        spot = u.approach and u.phase is Phase.AT_HOLD
        start = u.spot if spot else (u.request.position if u.request is not None else None)
        g = evaluate(c, uav, u, now_s)
        if g.granted and u.plan is not None:
            granted[uav] = (now_s, spot, start, g.site_m, u.plan)
        return g

    def recorded_end(self: Any, uav: str) -> None:
        u = self._uavs.get(uav)
        if uav in granted and u is not None and u.plan is granted[uav][4]:
            t, spot, start, site, plan = granted.pop(uav)
            down = [r for r in plan.reservations if r.purpose == "descend"]
            timed = down[-1].t1_s - self.margin_s - plan.start_s if down else math.nan
            hops.append((uav, t, spot, start, site, self.now_s, timed, plan.layer_m))
        end_transit(self, uav)

    reserved_requests.evaluate = recorded_evaluate
    reserved.TableClearance.end_transit = recorded_end  # type: ignore[method-assign]
    try:
        mission = SimulatedMission.from_blueprint(
            blueprint,
            brick_uavs=bricks,
            adhesion_uavs=adhesion,
            seed=seed,
            camera="geometric",
            airspace="table",
        )
        report = mission.run()
    finally:
        reserved_requests.evaluate = evaluate
        reserved.TableClearance.end_transit = end_transit  # type: ignore[method-assign]
    return report, mission, hops


def rows(mission: Any, hops: list[Hop]) -> dict[tuple[str, str], list[tuple[float, ...]]]:
    """Per (role, start): each visit's gap, flight, timed flight, drop, layer, start and site altitude."""
    sites = mission.control.sites
    visits = [v for v in sites.visits if v.end_s is not None]
    by_start = {(v.uav, round(v.start_s, 3)): v for v in visits}
    out: dict[tuple[str, str], list[tuple[float, ...]]] = defaultdict(list)
    for uav, t, spot, start, site, down_s, timed, layer in hops:
        v = by_start.get((uav, round(t, 3)))
        if v is None:  # (a hop that starts no site interval: home, the pallet)
            continue
        near = sites._neighbours[v.task_id]
        ends = [o.end_s for o in visits if o.task_id in near and o.uav != uav and o.end_s <= v.start_s + 1e-9]
        gap = v.start_s - max(ends) if ends else math.nan
        z0 = start[2] if start is not None else math.nan
        role = "brick" if uav.startswith("brick") else "glue"
        out[(role, "spot" if spot else "other")].append(
            (gap, down_s - t, timed, z0 - site[2], layer, z0, site[2])
        )
    return out


def _mean(xs: list[float]) -> float:
    xs = [x for x in xs if not math.isnan(x)]
    return statistics.mean(xs) if xs else math.nan


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walls", default="pyramid")
    ap.add_argument("--fleets", default="2+1")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--each", action="store_true", help="print every visit from a spot")
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        report, mission, hops = fly(WALLS[wall][1](), bricks, adhesion, args.seed)
        print(
            f"\n## {WALLS[wall][0]}, {bricks} + {adhesion}, seed {args.seed}: makespan {report.makespan_s:,.1f} s\n"
        )
        print("| role | start | visits | gap s | flight s | timed s | drop m | layer m | start m | site m |")
        print("|---|---|---|---|---|---|---|---|---|---|")
        table = rows(mission, hops)
        for (role, start), rs in sorted(table.items()):
            means = [_mean([r[i] for r in rs]) for i in range(7)]
            print(f"| {role} | {start} | {len(rs)} | " + " | ".join(f"{m:.2f}" for m in means) + " |")
        c = mission.control.columns
        print(
            f"\ngranted {c.granted_count}, extended {c.extended}, forced {c.forced}, "
            f"to a parking spot {c.held_back}, to an approach spot {c.approached_count}"
        )
        if args.each:
            for (role, start), rs in sorted(table.items()):
                for r in rs if start == "spot" else []:
                    print(role, " ".join(f"{x:.2f}" for x in r))
        sys.stdout.flush()


if __name__ == "__main__":
    main()
