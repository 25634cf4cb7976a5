"""How long the airspace holds a flight's climb and lateral leg against how long they are flown (issue 27); prints
Markdown, asserts nothing.

Flies ``masonry.mission.simulate``'s mission as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera), recording every UAV's control tick (``bench_site_visits.recording_machine``), and at every tick
of mission control's airspace (:meth:`masonry.mission.airspace.ColumnClearance.grant`) looks at what each UAV
holds. A *flight* is a run of ticks in which the UAV holds a ``climb`` or a ``leg`` volume (a hold flight and the
rest granted after it are one). Per flight:

- climb held: ticks holding a ``climb``; climb flown: ticks with the UAV inside it (within 0.15 m horizontally
  and vertically of the column) and more than 0.05 m from where it was at rest at the grant, i.e. moving up;
- leg held: ticks holding a ``leg``; leg flown: ticks with the UAV on one of its legs (within 0.15 m of the
  segment, 0.15 m of its altitude);
- the far end: seconds from the grant until the UAV first reaches the last 0.5 m of its (first) leg: how long the
  end of the leg was reserved before the UAV could be there.

Usage: python benchmarks/bench_leg_hold.py [--walls 12m] [--fleets 4+2,8+4] [--seeds 1]
"""

from __future__ import annotations

import math
import statistics
import sys
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import sweep
from bench_site_visits import Ticks, recording_machine

from masonry.mission.simulate import SimulatedMission
from masonry.mission.volumes import Volume
from masonry.segments import point_segment_m

#: within this of a climb or leg (horizontally and vertically), the UAV is in it
IN_M = 0.15


@dataclass
class Flight:
    """One flight's ticks: held and flown seconds of its climb and leg."""

    uav: str
    start_s: float
    rest: tuple[float, float, float] | None
    climb_held_s: float = 0.0
    climb_flown_s: float = 0.0
    leg_held_s: float = 0.0
    leg_flown_s: float = 0.0
    leg_len_m: float = 0.0
    far_end_s: float | None = None
    first_leg: Volume | None = None
    end_s: float = 0.0
    legs: list[Volume] = field(default_factory=list)


def inside(v: Volume, p: tuple[float, float, float]) -> bool:
    """``p`` within ``IN_M`` of ``v`` (a climb column or a leg)."""
    if not v.z0_m - IN_M <= p[2] <= v.z1_m + IN_M:
        return False
    return point_segment_m((p[0], p[1]), v.a, v.b) <= IN_M


def fly(blueprint: Any, bricks: int, adhesion: int, seed: int) -> tuple[float, list[Flight]]:
    """Fly the mission; every flight's held and flown seconds."""
    ticks: Ticks = defaultdict(list)
    mission = SimulatedMission.from_blueprint(
        blueprint,
        uav_machine=recording_machine(ticks),
        camera="geometric",
        brick_uavs=bricks,
        adhesion_uavs=adhesion,
        seed=seed,
        policy="critical-path",
        reservation="site",
    )
    columns: Any = mission.control.columns
    grant = columns.grant
    open_: dict[str, Flight] = {}
    done: list[Flight] = []
    last: list[float | None] = [None]

    def position(uav: str) -> tuple[float, float, float] | None:
        rows = ticks.get(uav)
        return None if not rows else rows[-1][3]

    def recorded_grant(now_s: float) -> Any:
        dt = 0.0 if last[0] is None else now_s - last[0]
        last[0] = now_s
        for uav, u in columns.records.items():
            climbs = [v for v in u.volumes if v.kind == "climb"]
            legs = [v for v in u.volumes if v.kind == "leg"]
            f = open_.get(uav)
            p = position(uav)
            if not climbs and not legs:
                if f is not None:
                    f.end_s = now_s
                    done.append(open_.pop(uav))
                continue
            if f is None:
                f = open_[uav] = Flight(uav, now_s, p)
            if legs and f.first_leg is None:
                f.first_leg = legs[0]
                f.leg_len_m = math.dist(legs[0].a, legs[0].b)
            if climbs:
                f.climb_held_s += dt
                moved = p is not None and f.rest is not None and math.dist(p, f.rest) > 0.05
                if p is not None and moved and any(inside(v, p) for v in climbs):
                    f.climb_flown_s += dt
            if legs:
                f.leg_held_s += dt
                if p is not None and any(inside(v, p) for v in legs):
                    f.leg_flown_s += dt
            fl = f.first_leg
            if (
                f.far_end_s is None
                and fl is not None
                and p is not None
                and abs(p[2] - fl.z0_m) < IN_M
                and math.dist((p[0], p[1]), fl.b) < 0.5
                and f.leg_len_m > 0.5
            ):
                f.far_end_s = now_s - f.start_s
        return grant(now_s)

    columns.grant = recorded_grant
    report = mission.run()
    return report.makespan_s, done


def describe(xs: list[float]) -> str:
    if not xs:
        return "-"
    q = statistics.quantiles(xs, n=10) if len(xs) > 1 else [xs[0]] * 9
    return f"{statistics.fmean(xs):.1f} / {statistics.median(xs):.1f} / {q[8]:.1f} / {max(xs):.1f} ({sum(xs):,.0f})"


def main() -> None:
    for title, blueprint, bricks, adhesion, seed in sweep(__doc__.split("\n")[0]):
        makespan, flights = fly(blueprint, bricks, adhesion, seed)
        print(f"\n## {title}, {bricks} + {adhesion}, seed {seed}: makespan {makespan:,.1f} s\n")
        print("mean / median / p90 / max (sum) seconds per flight")
        print()
        print("| | flights | held | flown | held - flown |")
        print("|---|---|---|---|---|")
        cl = [f for f in flights if f.climb_held_s > 0]
        lg = [f for f in flights if f.leg_held_s > 0]
        print(
            f"| climb | {len(cl)} | {describe([f.climb_held_s for f in cl])} | "
            f"{describe([f.climb_flown_s for f in cl])} | "
            f"{describe([f.climb_held_s - f.climb_flown_s for f in cl])} |"
        )
        print(
            f"| leg | {len(lg)} | {describe([f.leg_held_s for f in lg])} | "
            f"{describe([f.leg_flown_s for f in lg])} | "
            f"{describe([f.leg_held_s - f.leg_flown_s for f in lg])} |"
        )
        far = [f.far_end_s for f in lg if f.far_end_s is not None]
        print(f"\nthe first leg's far end (last 0.5 m) reached after the grant: {describe(far)} s")
        ln = [f.leg_len_m for f in lg if f.leg_len_m > 0]
        print(f"\nfirst leg's length: {describe(ln)} m")
        worst = sorted(cl, key=lambda f: f.climb_flown_s - f.climb_held_s)[:3]
        print("\nclimbs held longest past their flying (UAV, granted at, held, flown): ", end="")
        print(
            "; ".join(
                f"{f.uav} {f.start_s:.1f} s {f.climb_held_s:.1f} / {f.climb_flown_s:.1f}" for f in worst
            )
        )
        sys.stdout.flush()


if __name__ == "__main__":
    main()
