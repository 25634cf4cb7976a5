"""Why ``--airspace table`` is slower than ``columns`` (issue 27): where the UAVs' time goes under each, and how
the table's timed hops compare with how long they are flown; prints its figures, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, geometric camera, the
default vehicle) once per airspace, recording every UAV's control tick (task state, transit state, position) as
``bench_site_visits.py`` does, and prints per run:

1. with the table: its counters (hops granted, answers "wait", windows extended for a late UAV, extensions
   forced, flights to a parking spot, to an approach spot); per hop that ended down at its site, the flight its
   plan timed (the descent's window end less the margin, from the plan's start) against the one flown (from
   the plan's start to the UAV saying it is down), and the layers the hops were granted;
2. per role (``brick``, ``glue``): the flights granted (transit ``down``) per task state, their count, mean
   length, highest altitude and horizontal distance; the UAV-seconds per task state (every transit state in it:
   asking, holding, flying).

Usage: python benchmarks/bench_table_where.py [--walls 12m] [--fleets 4+2] [--seed 1] [--airspaces columns,table]
"""

from __future__ import annotations

import argparse
import itertools
import math
import statistics
import sys
from collections import Counter, defaultdict
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets
from bench_site_visits import Ticks, recording_machine

from masonry.mission import reserved
from masonry.mission.simulate import SimulatedMission

#: UAV name -> its ticks: (time s, task state, transit state, position or None)
#: a hop of the table that ended down: (UAV, seconds its plan timed, seconds flown, layer m)
Hop = tuple[str, float, float, float]


def fly(
    blueprint: Any, bricks: int, adhesion: int, seed: int, airspace: str
) -> tuple[Any, Any, Ticks, list[Hop]]:
    """Fly the mission, recording each UAV's ticks and (with the table) each hop's timed and flown length."""
    ticks: Ticks = defaultdict(list)
    machine = recording_machine(ticks)
    hops: list[Hop] = []
    end_transit = reserved.TableClearance.end_transit

    def recorded_end(self: Any, uav: str) -> None:
        u = self._uavs.get(uav)
        if u is not None and u.plan is not None:
            down = [r for r in u.plan.reservations if r.purpose == "descend"]
            if down:
                timed = down[-1].t1_s - self.margin_s - u.plan.start_s
                hops.append((uav, timed, self.now_s - u.plan.start_s, u.plan.layer_m))
        end_transit(self, uav)

    reserved.TableClearance.end_transit = recorded_end  # type: ignore[method-assign]
    try:
        mission = SimulatedMission.from_blueprint(
            blueprint,
            uav_machine=machine,
            camera="geometric",
            brick_uavs=bricks,
            adhesion_uavs=adhesion,
            seed=seed,
            airspace=airspace,
        )
        report = mission.run()
    finally:
        reserved.TableClearance.end_transit = end_transit  # type: ignore[method-assign]
    return report, mission.control.columns, dict(ticks), hops


def flights(ticks: Ticks, role: str) -> list[str]:
    """Per task state: the granted flights (transit ``down``) of ``role``'s UAVs."""
    by: dict[str, list[tuple[float, float, float]]] = defaultdict(list)
    for name, rows in ticks.items():
        if not name.startswith(role):
            continue
        cur: list[Any] | None = None
        for t, state, transit, p in rows:
            if transit == "down" and cur is None:
                cur = [t, p, p[2] if p else 0.0, state]
            elif transit == "down" and cur is not None and p is not None:
                cur[2] = max(cur[2], p[2])
            elif transit != "down" and cur is not None:
                d = math.hypot(p[0] - cur[1][0], p[1] - cur[1][1]) if p and cur[1] else 0.0
                by[cur[3]].append((t - cur[0], cur[2], d))
                cur = None
    return [
        f"  {role} {state}: {len(fs)} flights, mean {statistics.mean(f[0] for f in fs):.1f} s, highest "
        f"{statistics.mean(f[1] for f in fs):.2f} m, {statistics.mean(f[2] for f in fs):.2f} m across, "
        f"{sum(f[0] for f in fs):,.0f} s in all"
        for state, fs in sorted(by.items())
    ]


def per_state(ticks: Ticks, role: str) -> str:
    """``role``'s UAV-seconds per task state."""
    tot: Counter[str] = Counter()
    for name, rows in ticks.items():
        if name.startswith(role):
            for (t0, state, _tr, _p), (t1, *_rest) in itertools.pairwise(rows):
                tot[state] += t1 - t0
    parts = ", ".join(f"{k} {v:,.0f}" for k, v in tot.most_common(12))
    return f"  {role}: {sum(tot.values()):,.0f} UAV-s; {parts}"


def table_lines(c: Any, hops: list[Hop]) -> list[str]:
    """The table's counters and its hops' timed against flown lengths."""
    out = [
        f"  granted {c.granted_count}, wait answers {c.refused}, extended {c.extended}, forced {c.forced}, "
        f"to a parking spot {c.held_back}, to an approach spot {c.approached_count}"
    ]
    if hops:
        late = sorted(h[2] - h[1] for h in hops)
        out.append(
            f"  hops down: {len(hops)}; timed {statistics.mean(h[1] for h in hops):.1f} s mean, flown "
            f"{statistics.mean(h[2] for h in hops):.1f} s; flown - timed mean {statistics.mean(late):.1f}, median "
            f"{statistics.median(late):.1f}, p90 {late[int(0.9 * len(late))]:.1f}, max {late[-1]:.1f} s; later "
            f"than the margin ({c.margin_s:.0f} s): {sum(1 for x in late if x > c.margin_s)}"
        )
        layers = sorted(Counter(round(h[3], 2) for h in hops).items())
        out.append("  layers (m: hops): " + ", ".join(f"{z:.1f}: {n}" for z, n in layers))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--airspaces", default="columns,table")
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        for airspace in args.airspaces.split(","):
            report, c, ticks, hops = fly(WALLS[wall][1](), bricks, adhesion, args.seed, airspace)
            print(
                f"## {wall} {bricks}+{adhesion} seed {args.seed} {airspace}: makespan {report.makespan_s:,.1f} s, "
                f"completed {report.completed}"
            )
            lines = table_lines(c, hops) if airspace == "table" else []
            for role in ("brick", "glue"):
                lines += [*flights(ticks, role), per_state(ticks, role)]
            print("\n".join(lines), flush=True)


if __name__ == "__main__":
    main()
