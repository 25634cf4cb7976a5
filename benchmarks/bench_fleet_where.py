"""Where a fleet's time goes on the ground plan (issue 27): each UAV's time by region and state, its still time
(holds), the waits by where the waiting UAV and the UAV in its way were, and the battery trips; prints, asserts
nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) with an event sink, and reads its UAV samples (every 0.5 s: state, position, battery). The
regions are bands across the wall (y): ``wall`` (y > -0.6 m, over the wall's line), ``pallet`` (down to 0.6 m
behind the pallet's last row), ``pads`` (the rest: the pad row). Printed per run:

1. the makespan, the minimum separation, the tasks done per 100 s (bricks, adhesion segments);
2. seconds per (role, region) and, of those, the seconds still (slower than 0.05 m/s) in a flying state: a hold;
3. task-seconds of waiting per (role, region, the waiting UAV's state, cause, what of the other UAV holds it),
   ``dependency`` and ``fleet`` left out, and per region of the UAV in the way;
4. the trips home: for each flight home that lands and takes off again (state ``home``, ``land``, later
   ``takeoff``: a battery swap, about 63 s on the pad, or a UAV with no task sent home), the seconds to the pad,
   on it, and from take-off to its first state at the work (``pickup_estimate``, ``hover`` or ``descend``), with
   the pad's x from the wall's middle.

Usage: python benchmarks/bench_fleet_where.py [--walls 12m] [--fleets 4+2,8+4] [--seed 1]
"""

from __future__ import annotations

import argparse
import bisect
import itertools
import math
import sys
import time
from collections import Counter, defaultdict
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet, walls_and_fleets

from masonry.blueprint import Blueprint
from masonry.mission.events import EventList, MissionEvent
from masonry.mission.fleet import fleet_for
from masonry.mission.report import MissionReport

#: flying states in which a UAV standing still is held (not working, grasping or on its pad)
WORKING = ("idle", "landed", "swap", "done", "pickup_grasp", "place_release", "spray")
#: where a UAV back in the air after a swap is on its way no more
ARRIVED = ("pickup_estimate", "hover", "descend")

Sample = tuple[float, str, tuple[float, float, float]]


def region(y_m: float, pallet_back_y_m: float) -> str:
    """The band across the wall a point is in: ``wall``, ``pallet`` or ``pads``."""
    if y_m > -0.6:
        return "wall"
    return "pallet" if y_m > pallet_back_y_m - 0.6 else "pads"


def samples_of(events: list[MissionEvent]) -> dict[str, list[Sample]]:
    """Each UAV's samples (time, state, position), in time order."""
    out: dict[str, list[Sample]] = defaultdict(list)
    for e in events:
        if e.kind == "uav" and e.uav and "position_m" in e.fields:
            p = e.fields["position_m"]
            out[e.uav].append((e.time_s, str(e.fields.get("state")), (p[0], p[1], p[2])))
    return out


def time_by_region(
    samples: dict[str, list[Sample]], back_y: float
) -> tuple[dict[tuple[str, str], float], dict[tuple[str, str], float]]:
    """Seconds per (role, region), and of those still in a flying state."""
    spent: dict[tuple[str, str], float] = defaultdict(float)
    still: dict[tuple[str, str], float] = defaultdict(float)
    for uav, seq in samples.items():
        role = "brick" if uav.startswith("brick") else "adhesion"
        for (t0, st, p0), (t1, _, p1) in itertools.pairwise(seq):
            dt = t1 - t0
            if not 0.0 < dt <= 1.0:
                continue
            where = region(p0[1], back_y)
            spent[(role, where)] += dt
            if math.dist(p0, p1) / dt < 0.05 and st not in WORKING:
                still[(role, where)] += dt
    return spent, still


def waits_by_place(
    report: MissionReport, samples: dict[str, list[Sample]], back_y: float
) -> tuple[dict[tuple[str, ...], float], dict[tuple[str, ...], float]]:
    """Task-seconds waited per (role, region, state, cause, holds) and per (role, region, cause, other's region)."""
    times = {u: [s[0] for s in seq] for u, seq in samples.items()}

    def at(uav: str, t_s: float) -> Sample:
        return samples[uav][max(0, bisect.bisect_right(times[uav], t_s) - 1)]

    mine: dict[tuple[str, ...], float] = defaultdict(float)
    theirs: dict[tuple[str, ...], float] = defaultdict(float)
    for t in report.tasks:
        for w in t.waits:
            c = w.cause
            if c.what in ("dependency", "fleet") or c.uav not in samples:
                continue
            _, st, p = at(c.uav, w.from_s)
            where = region(p[1], back_y)
            mine[(t.kind, where, st, c.what, c.holds or "-")] += w.duration_s
            if c.blocking_uav in samples:
                _, _, q = at(c.blocking_uav, w.from_s)
                theirs[(t.kind, where, c.what, region(q[1], back_y))] += w.duration_s
    return mine, theirs


def battery_trips(samples: dict[str, list[Sample]]) -> list[tuple[str, float, float, float, float, float]]:
    """(UAV, from_s, to the pad s, on it s, back on the way s, pad's x) per flight home that lands and flies again."""
    out = []
    for uav, seq in samples.items():
        states = [(t, st, p) for k, (t, st, p) in enumerate(seq) if k == 0 or seq[k - 1][1] != st]
        for k, (t, st, _) in enumerate(states):
            if st != "home" or k + 2 >= len(states) or states[k + 1][1] != "land":
                continue
            landed = states[k + 1][0]
            off = next((s for s in states[k + 2 :] if s[1] == "takeoff"), None)
            if off is None:
                continue
            there = next((s for s in states[k + 2 :] if s[0] > off[0] and s[1] in ARRIVED), None)
            back = (there[0] - off[0]) if there else float("nan")
            out.append((uav, t, landed - t, off[0] - landed, back, states[k + 1][2][0]))
    return sorted(out, key=lambda r: r[1])


def fly(blueprint: Blueprint, bricks: int, adhesion: int, seed: int) -> None:
    """One mission, and its figures printed."""
    sink = EventList()
    t0 = time.perf_counter()
    r = simulate_fleet(
        blueprint,
        bricks,
        adhesion,
        seed,
        events_sink=sink,
    )
    back_y = min(b.pickup_m[1] for b in blueprint.bricks if b.pickup_m is not None)
    xs = [b.position_m[0] for b in blueprint.bricks]
    middle_x = (min(xs) + max(xs)) / 2.0
    sep = "n/a" if r.min_separation_m is None else f"{r.min_separation_m:.3f} m"
    pads = ", ".join(
        f"{u.name} {u.home_m[0] - middle_x:+.0f}" for u in fleet_for(blueprint, bricks, adhesion)
    )
    print(
        f"## {bricks} + {adhesion}, seed {seed}: makespan {r.makespan_s:,.0f} s, min separation "
        f"{sep} ({time.perf_counter() - t0:.0f} s wall)\n  pads (x from the wall's middle, m): {pads}"
    )
    done: Counter[tuple[int, str]] = Counter()
    for t in r.tasks:
        if t.end_s is not None and t.status == "done":
            done[(int(t.end_s // 100), t.kind)] += 1
    bins = range(max((b for b, _ in done), default=0) + 1)
    print(
        "  done per 100 s (bricks/adhesion): "
        + " ".join(f"{done[(b, 'brick')]}/{done[(b, 'adhesion')]}" for b in bins)
    )
    samples = samples_of(sink.events)
    spent, still = time_by_region(samples, back_y)
    print("  seconds by region (still in flight):")
    for role, where in sorted(spent):
        print(f"    {role:<9} {where:<7} {spent[(role, where)]:7,.0f} ({still.get((role, where), 0.0):,.0f})")
    mine, theirs = waits_by_place(r, samples, back_y)
    print("  waits (task-seconds) by role, region, state, cause, holds:")
    for cells, v in sorted(mine.items(), key=lambda kv: -kv[1])[:15]:
        print(f"    {' '.join(f'{k:<15}' for k in cells)} {v:7,.0f}")
    print("  waits by role, region, cause, and the region of the UAV in the way:")
    for cells, v in sorted(theirs.items(), key=lambda kv: -kv[1])[:10]:
        print(f"    {' '.join(f'{k:<10}' for k in cells)} {v:7,.0f}")
    trips = battery_trips(samples)
    print(f"  trips home: {len(trips)}, to the pad / on it / back on the way (s), the pad's x (m)")
    for uav, from_s, home, on, back, x in trips:
        print(
            f"    {uav:<8} from {from_s:6,.0f} s: {home:5.0f} / {on:5.0f} / {back:5.0f}  x {x - middle_x:+5.1f}"
        )
    if trips:
        print(
            f"    total: to the pad {sum(h for _, _, h, _, _, _ in trips):,.0f} s, on it "
            f"{sum(o for _, _, _, o, _, _ in trips):,.0f} s, back "
            f"{sum(b for *_, b, _ in trips if not math.isnan(b)):,.0f} s"
        )


def main() -> None:
    ap = argparse.ArgumentParser(description=(__doc__ or "").splitlines()[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2,8+4")
    ap.add_argument("--seed", type=int, default=1)
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        print(f"# {wall}")
        fly(WALLS[wall][1](), bricks, adhesion, args.seed)


if __name__ == "__main__":
    main()
