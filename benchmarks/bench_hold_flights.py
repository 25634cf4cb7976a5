"""Every hold flight of the fleet's mission, traced (issue 27): where from, where to, how far round, how long to
the hold point and there, and what it cost against waiting where the UAV asked; prints Markdown, asserts nothing.

Flies ``masonry.mission.simulate``'s mission as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) and records, from mission control's airspace (:mod:`masonry.mission.airspace_requests`'s
``hold_flight`` and ``granted``, :class:`~masonry.mission.airspace.ColumnClearance`'s ``arrive_at_hold`` and
``end_transit``), each hold flight: where its UAV asked from, the hold point, the site, the layer, whether the site
rule held the site back then (``gate``), when the UAV arrived at the hold point and when the rest of its flight was
granted; and each granted flight's time from the grant to the UAV down at its site.

Per run: the makespan; the hold flights: how many, the UAV-seconds flying to the hold point (``to-hold``) and
hovering there (``at hold``), the detour (asked-from -> hold point -> site, less asked-from -> site), how many were
granted within 2 s of arriving (the hold flight was the way there); and by where the UAV asked from, its site and
the hold point (``wall``: within 0.6 m of the wall's line, ``north`` past it, ``pallet``: the pickups' rows, ``south``
past them). Then the cost of the hold flights against a UAV that waited where it asked: each granted flight's time
to its site is fitted as ``a + b d`` (``d`` its lateral distance) over the flights granted without a hold; a held
request's ``cost`` is the time from its hold flight to the UAV down at its site, less (the time to its grant plus
``a + b d`` from where it asked). Negative: the hold flight brought it nearer its site than it would have been.

Usage: python benchmarks/bench_hold_flights.py [--walls 12m] [--fleets 4+2,8+4] [--seeds 1]
"""

from __future__ import annotations

import math
import statistics
import sys
from collections import defaultdict
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import simulate_fleet, sweep

from masonry.blueprint import Blueprint
from masonry.mission import airspace_requests
from masonry.mission.airspace import ColumnClearance

#: a hold flight "was the way there" if the rest of the flight was granted this soon after the UAV arrived
SOON_S = 2.0


@dataclass
class Hold:
    uav: str
    t_s: float
    start: tuple[float, float, float]
    point: tuple[float, float, float]
    site: tuple[float, float, float]
    layer_m: float
    gate: bool
    arrived_s: float | None = None
    granted_s: float | None = None
    down_s: float | None = None

    def detour_m(self) -> float:
        return _d(self.start, self.point) + _d(self.point, self.site) - _d(self.start, self.site)


@dataclass
class Trace:
    holds: list[Hold] = field(default_factory=list)
    #: (distance, grant -> down) of each flight granted without a hold
    direct: list[tuple[float, float]] = field(default_factory=list)


def _d(p: Any, q: Any) -> float:
    return math.hypot(p[0] - q[0], p[1] - q[1])


@contextmanager
def traced(trace: Trace) -> Iterator[None]:
    """Record the hold flights and the granted flights while the block runs (the functions patched back after)."""
    now = [0.0]
    held: dict[str, Hold] = {}
    flying: dict[str, tuple[Hold | None, float, float]] = {}  # uav -> (its hold, distance, granted at)
    saved = (
        airspace_requests.hold_flight,
        airspace_requests.granted,
        ColumnClearance.grant,
        ColumnClearance.request,
        ColumnClearance.arrive_at_hold,
        ColumnClearance.end_transit,
    )
    hold_flight, granted, grant, request, arrive, end = saved

    def grant_(self: ColumnClearance, now_s: float) -> Any:
        now[0] = now_s
        return grant(self, now_s)

    def request_(self: ColumnClearance, uav: str, site_m: Any, now_s: float, *a: Any, **k: Any) -> Any:
        now[0] = now_s
        return request(self, uav, site_m, now_s, *a, **k)

    def hold_flight_(c: ColumnClearance, uav: str, u: Any) -> Any:
        g = hold_flight(c, uav, u)
        if g is not None and g.hold_m is not None and g.layer_m is not None:
            w = u.request
            start = w.position if w.position is not None else w.site
            gate = c.gate is not None and not c.gate.may_enter(uav, w.site)
            h = Hold(uav, now[0], start, g.hold_m, w.site, g.layer_m, gate)
            trace.holds.append(h)
            held[uav] = h
        return g

    def granted_(c: ColumnClearance, uav: str, u: Any, k: int, now_s: float, *, gentle: bool = True) -> Any:
        w = u.request
        h = held.pop(uav, None)
        if h is not None:
            h.granted_s = now_s
            frm: Any = h.point
        else:
            frm = w.position if w.position is not None else w.site
        if not c.is_home(uav, w.site):
            flying[uav] = (h, _d(frm, w.site), now_s)
        return granted(c, uav, u, k, now_s, gentle=gentle)

    def arrive_(self: ColumnClearance, u: Any) -> None:
        for n, o in self.records.items():
            h = held.get(n)
            if o is u and h is not None and h.arrived_s is None:
                h.arrived_s = now[0]
        arrive(self, u)

    def end_(self: ColumnClearance, uav: str) -> None:
        f = flying.pop(uav, None)
        if f is not None:
            h, dist, t0 = f
            if h is None:
                trace.direct.append((dist, now[0] - t0))
            else:
                h.down_s = now[0]
        end(self, uav)

    airspace_requests.hold_flight = hold_flight_  # type: ignore[assignment]
    airspace_requests.granted = granted_  # type: ignore[assignment]
    ColumnClearance.grant = grant_  # type: ignore[method-assign]
    ColumnClearance.request = request_  # type: ignore[method-assign,assignment]
    ColumnClearance.arrive_at_hold = arrive_  # type: ignore[method-assign]
    ColumnClearance.end_transit = end_  # type: ignore[method-assign]
    try:
        yield
    finally:
        airspace_requests.hold_flight, airspace_requests.granted = saved[0], saved[1]
        ColumnClearance.grant, ColumnClearance.request = saved[2], saved[3]  # type: ignore[method-assign]
        ColumnClearance.arrive_at_hold, ColumnClearance.end_transit = saved[4], saved[5]  # type: ignore[method-assign]


def place(p: Any) -> str:
    """The 12 m wall's regions by y (m): the wall's line at y = 0, the pickups' rows at -4.4 to -2.6 m."""
    y = p[1]
    if y > 0.6:
        return "north"
    if y > -0.6:
        return "wall"
    return "pallet" if y >= -4.6 else "south"


def fit(points: list[tuple[float, float]]) -> tuple[float, float]:
    """Least squares ``t = a + b d`` over (d, t)."""
    n = len(points)
    mx = sum(d for d, _ in points) / n
    my = sum(t for _, t in points) / n
    sxx = sum((d - mx) ** 2 for d, _ in points)
    b = sum((d - mx) * (t - my) for d, t in points) / sxx if sxx > 0 else 0.0
    return my - b * mx, b


def fly(blueprint: Blueprint, bricks: int, adhesion: int, seed: int) -> tuple[float, Trace]:
    trace = Trace()
    with traced(trace):
        report = simulate_fleet(blueprint, bricks, adhesion, seed)
    return report.makespan_s, trace


def summary(makespan_s: float, t: Trace) -> list[str]:
    done = [h for h in t.holds if h.arrived_s is not None and h.granted_s is not None]
    to_hold = sum(h.arrived_s - h.t_s for h in done)  # type: ignore[operator]
    at_hold = sum(h.granted_s - h.arrived_s for h in done)  # type: ignore[operator]
    soon = sum(1 for h in done if h.granted_s - h.arrived_s < SOON_S)  # type: ignore[operator]
    a, b = fit(t.direct) if len(t.direct) > 1 else (0.0, 0.0)
    costs = [
        h.down_s - h.t_s - (h.granted_s - h.t_s + a + b * _d(h.start, h.site))
        for h in done
        if h.down_s is not None and h.granted_s is not None
    ]
    out = [
        f"makespan {makespan_s:,.1f} s; {len(t.holds)} hold flights, {len(done)} flown to the end and granted on; "
        f"to-hold {to_hold:,.0f} UAV-s, at hold {at_hold:,.0f} UAV-s; detour mean "
        f"{statistics.fmean(h.detour_m() for h in t.holds) if t.holds else 0.0:.2f} m; granted within "
        f"{SOON_S:.0f} s of arriving: {soon}; the site rule holding the site at the hold flight: "
        f"{sum(h.gate for h in t.holds)}",
        f"granted flights without a hold: {len(t.direct)}, grant -> down = {a:.2f} s + {b:.2f} s/m x distance; "
        f"the held requests' cost against waiting where they asked: {sum(costs):+,.0f} UAV-s "
        f"(mean {statistics.fmean(costs) if costs else 0.0:+.1f} s, > 0 in {sum(c > 0 for c in costs)} of "
        f"{len(costs)})",
        "",
        "| asked from -> site (hold point) | hold flights | to-hold UAV-s | at hold UAV-s | detour m | "
        "asked-from -> site m | granted < 2 s after arriving | site rule |",
        "|---|---|---|---|---|---|---|---|",
    ]
    groups: dict[tuple[str, str, str], list[Hold]] = defaultdict(list)
    for h in done:
        groups[(place(h.start), place(h.site), place(h.point))].append(h)
    for (frm, to, at), hs in sorted(groups.items(), key=lambda kv: -len(kv[1])):
        out.append(
            f"| {frm} -> {to} ({at}) | {len(hs)} "
            f"| {sum(h.arrived_s - h.t_s for h in hs):,.0f} "  # type: ignore[operator]
            f"| {sum(h.granted_s - h.arrived_s for h in hs):,.0f} "  # type: ignore[operator]
            f"| {statistics.fmean(h.detour_m() for h in hs):.2f} "
            f"| {statistics.fmean(_d(h.start, h.site) for h in hs):.2f} "
            f"| {sum(1 for h in hs if h.granted_s - h.arrived_s < SOON_S)} "  # type: ignore[operator]
            f"| {sum(h.gate for h in hs)} |"
        )
    return out


def main() -> None:
    for title, blueprint, bricks, adhesion, seed in sweep(__doc__.split("\n")[0]):
        makespan, trace = fly(blueprint, bricks, adhesion, seed)
        print(f"\n## {title}, {bricks} + {adhesion}, seed {seed}\n")
        print("\n".join(summary(makespan, trace)), flush=True)


if __name__ == "__main__":
    main()
