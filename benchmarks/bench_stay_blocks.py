"""What the fleet's waiting UAVs wait for, tick by tick (issue 27): the site rule, an earlier request, or whose
reserved volume, of which kind and where; prints Markdown, asserts nothing.

Flies ``masonry.mission.simulate``'s mission as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) and, at every tick of mission control's airspace
(:meth:`masonry.mission.airspace.ColumnClearance.grant`), looks at every UAV with a request that is not lingering
(a linger waits for a task, not for the airspace) and counts the tick's seconds against one cause:

- ``to-hold``: flying its hold flight (granted, on its way to the hold point);
- ``gate``: the site rule holds it back (a conflicting task's UAV is at its site, or a prerequisite is not done);
- ``earlier``: first come, first served (a UAV that asked earlier waits for a site within the wait radius);
- otherwise the airspace: the other UAVs' volumes its flight (from its hold point, or from where it asked) conflicts
  with, at layers 0-3, by *class*: ``zone@wall`` / ``zone@pallet`` / ``zone@pad`` (a UAV working at a drop-off or
  adhesion segment, a pickup, or taking off / landing over its pad; a flight's column down to its site counts as
  a zone where it is), ``hover@lane`` / ``hover@pallet`` / ``hover@wall`` / ``hover@out`` (a hold hover between
  the pallet's nearest pickup row and the wall, over the pallet, over the wall, or elsewhere), ``pad``,
  ``climb``, ``leg``, and ``climb-out`` (its zone's column would be under the hover of a UAV waiting near it:
  ``airspace_requests.climb_out_free``). A tick is credited to a class when taking that class's volumes away
  lets the flight fit at one of those layers (``sole``: that class alone would free it; ``several``: no single
  class would), and each class's ``in the way`` counts every tick it blocks at layer 0.

Mission control looks at the airspace only while some UAV waits (``control_airspace.grant_waiting``): a request
made since the last look counts from when it was made (``FlightRequest.since_s``), not through the quiet gap before
it (until branch ``holdfly35`` the gap was counted against the new request's cause, mostly ``to-hold``: 4 + 2 seed 1
924 UAV-s of ``to-hold`` where its hold flights took 529 s).

Per run: the makespan, the UAV-seconds per cause (and as a share of all UAV-seconds waited), and where the waiting
UAVs wait (their own hover's class), split by what they wait to fly to (``wall``, ``pallet``, ``home``).

Usage: python benchmarks/bench_stay_blocks.py [--walls 12m] [--fleets 4+2,8+4] [--seeds 1]
"""

from __future__ import annotations

import dataclasses
import sys
from collections import Counter
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import simulate_fleet, sweep

from masonry.blueprint import Blueprint
from masonry.mission.airspace import ColumnClearance, Phase
from masonry.mission.airspace_requests import climb_out_free, queued_before
from masonry.mission.volumes import Volume, volumes_clear
from masonry.separation import SEPARATION_XY_M

#: the layers a waiting UAV's flight is tried at (a flight that fits higher would have been granted)
LAYERS = 4

Where = Callable[[float], str]


def where_of(blueprint: Blueprint) -> Where:
    """y (m) -> ``wall``, ``pallet``, ``lane`` (between the pickup row nearest the wall and the wall) or ``out``."""
    pick = [b.pickup_m[1] for b in blueprint.bricks if b.pickup_m is not None]
    wall = [b.position_m[1] for b in blueprint.bricks]
    m = 0.5 * SEPARATION_XY_M
    p0, p1 = min(pick), max(pick)
    w0, w1 = min(wall), max(wall)

    def where(y: float) -> str:
        if w0 - m <= y <= w1 + m:
            return "wall"
        if p0 - m <= y <= p1 + m:
            return "pallet"
        if min(p1, w1) < y < max(p0, w0):
            return "lane"
        return "out"

    return where


def volume_class(c: ColumnClearance, owner: str, q: Volume, where: Where) -> str:
    """The class of another UAV's volume ``q`` (the module docstring)."""
    if q.kind == "zone":
        home = c.homes.get(owner)
        if home is not None and abs(q.a[0] - home[0]) < 1e-6 and abs(q.a[1] - home[1]) < 1e-6:
            return "zone@pad"
        return f"zone@{where(q.a[1])}"
    if q.kind == "hover":
        return f"hover@{where(q.a[1])}"
    return q.kind


def flight_at(c: ColumnClearance, uav: str, u: Any, k: int) -> list[Volume]:
    """``uav``'s wanted flight at layer ``k`` (from its hold point, or from where it asked)."""
    w = u.request
    if u.phase is Phase.AT_HOLD and u.hold is not None:
        start = (u.hold.point_m[0], u.hold.point_m[1], u.hold.layer_m)
    else:
        start = w.position if w.position is not None else w.site
    return c.flight_volumes_at(start, w.site, w.top_m, k, None, w.to, home=c.is_home(uav, w.site))


def cause(c: ColumnClearance, uav: str, u: Any, where: Where) -> tuple[str, set[str]]:
    """Why ``uav`` waits (``sole:<class>``, ``several``, ``gate``, ``earlier``, ``to-hold``, ``none``) and the
    classes in its way at layer 0."""
    w = u.request
    if u.phase is Phase.TO_HOLD:
        return "to-hold", set()
    if c.gate is not None and not c.gate.may_enter(uav, w.site):
        return "gate", set()
    if any(
        abs(e.site[0] - w.site[0]) ** 2 + (e.site[1] - w.site[1]) ** 2 < c.wait_radius_m**2
        for e in queued_before(c, w.seq)
    ):
        return "earlier", set()
    others = [(n, q) for n, o in c.records.items() if n != uav for q in o.volumes]
    classes = {id(q): volume_class(c, n, q, where) for n, q in others}
    flights = [flight_at(c, uav, u, k) for k in range(LAYERS)]
    sep_z = c.spacing_m - 1e-9

    def blocking(vols: list[Volume]) -> set[str]:
        return {classes[id(q)] for _n, q in others if not volumes_clear(vols, [q], c.sep_xy_m, sep_z)}

    in_way = blocking(flights[0])
    if any(not climb_out_free(c, uav, f) for f in flights if not blocking(f)):
        in_way.add("climb-out")
    # which class, taken away alone, lets the flight fit at some layer
    for cls in sorted(in_way - {"climb-out"}):
        rest = [q for _n, q in others if classes[id(q)] != cls]
        for f in flights:
            if volumes_clear(f, rest, c.sep_xy_m, sep_z):
                return f"sole:{cls}", in_way
    if in_way == {"climb-out"}:
        return "sole:climb-out", in_way
    return ("several" if in_way else "none"), in_way


@dataclasses.dataclass
class Tally:
    """UAV-seconds per cause, per class in the way, per (waiting UAV's own place, its destination)."""

    causes: Counter[str] = dataclasses.field(default_factory=Counter)
    in_way: Counter[str] = dataclasses.field(default_factory=Counter)
    waiting_at: Counter[tuple[str, str]] = dataclasses.field(default_factory=Counter)
    total_s: float = 0.0


def fly(blueprint: Blueprint, bricks: int, adhesion: int, seed: int) -> tuple[float, Tally]:
    """Fly the mission; the tally of every waiting UAV's ticks."""
    where = where_of(blueprint)
    tally = Tally()
    last: list[float | None] = [None]
    original = ColumnClearance.grant

    def recorded(self: ColumnClearance, now_s: float) -> Any:
        prev, last[0] = last[0], now_s
        if prev is not None and now_s > prev:
            for uav, u in list(self.records.items()):
                if u.request is None or uav in self.lingering:
                    continue
                # (mission control looks only while someone waits: a request made since the last look waited
                # from when it was made, not through the quiet gap before it)
                dt = now_s - max(prev, u.request.since_s)
                if dt <= 0.0:
                    continue
                why, in_way = cause(self, uav, u, where)
                tally.causes[why] += dt
                tally.total_s += dt
                for cls in in_way:
                    tally.in_way[cls] += dt
                if why != "to-hold":
                    site = u.request.site
                    dest = "home" if self.is_home(uav, site) else where(site[1])
                    own = next((v for v in u.volumes if v.kind == "hover"), None)
                    at = "no hover" if own is None else where(own.a[1])
                    tally.waiting_at[(at, dest)] += dt
        return original(self, now_s)

    ColumnClearance.grant = recorded  # type: ignore[method-assign]
    try:
        report = simulate_fleet(blueprint, bricks, adhesion, seed)
    finally:
        ColumnClearance.grant = original  # type: ignore[method-assign]
    return report.makespan_s, tally


def main() -> None:
    for title, blueprint, bricks, adhesion, seed in sweep(__doc__.split("\n")[0]):
        makespan, t = fly(blueprint, bricks, adhesion, seed)
        print(f"\n## {title}, {bricks} + {adhesion}, seed {seed}: makespan {makespan:,.1f} s\n")
        print(f"UAV-seconds with a request (not lingering): {t.total_s:,.0f}\n")
        print("| cause | UAV-s | share | | class in the way (layer 0) | UAV-s |")
        print("|---|---|---|---|---|---|")
        causes = t.causes.most_common()
        ways = t.in_way.most_common()
        for i in range(max(len(causes), len(ways))):
            a = causes[i] if i < len(causes) else None
            b = ways[i] if i < len(ways) else None
            left = f"| {a[0]} | {a[1]:,.0f} | {100 * a[1] / t.total_s:.0f} % |" if a else "| | | |"
            right = f" | {b[0]} | {b[1]:,.0f} |" if b else " | | |"
            print(left + right)
        print("\nwhere the waiting UAVs wait (own hover) -> what they wait to fly to, UAV-s: ", end="")
        print(
            "; ".join(f"{a} -> {d} {s:,.0f}" for (a, d), s in t.waiting_at.most_common()),
            flush=True,
        )


if __name__ == "__main__":
    main()
