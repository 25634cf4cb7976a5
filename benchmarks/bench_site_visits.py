"""Where a site visit's time goes (issue 27): per phase inside each task's site interval, when the interval ends
against the UAV leaving the r_c neighbourhood, and how long a freed site waits for the next UAV; prints, asserts
nothing.

A site interval (``--reservation site``, :mod:`masonry.mission.sites`) runs from the grant of a UAV's flight down
to its task's site to its asking to fly elsewhere; conflicting tasks' intervals never overlap (G^c). Flies
``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``, geometric
camera), recording every UAV's control tick (task state, transit state, position), and prints per run:

1. per task kind (brick, adhesion): the visits, their mean, median and least length, and the seconds per visit
   in each (task state / transit state) pair, largest first: where the interval's time goes;
2. the release: how long before (or after) its UAV was out of r_c of the site (horizontally, of the
   segment for adhesion) each interval ended; the seconds of each interval before its UAV first came within r_c;
3. the hand-overs: for each interval whose UAV was waiting for its flight (transit ``ask`` or ``hold``) when it
   began, after a conflicting task's interval that ended while it waited, the seconds from that end to this
   start (0: granted the moment the site freed); the longest, with the tasks and UAVs. Then what held the
   waiting UAV in those seconds (the airspace's ``blockers`` at each tick of mission control: the leaving UAV's
   climb, which is where it set off until it is ``TRACK_M`` along its leg, its other volumes, only other UAVs',
   or nothing: the site gate, or the answer on its way), and how long the leaving UAV took from its ask to
   moving off its site (its answer and its climb there); then the hand-over step by step, summed: the leaving
   UAV's ask to moving at all, to moving sideways (its climb there), to ``SEPARATION_XY_M`` off (where its
   climb is freed), to the waiting UAV's grant.

Usage: python benchmarks/bench_site_visits.py [--walls 12m] [--fleets 4+2,8+4] [--seed 1] [--vehicle ideal]
"""

from __future__ import annotations

import argparse
import bisect
import itertools
import math
import statistics
import sys
from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, walls_and_fleets

from masonry.blueprint import Blueprint
from masonry.mission.simulate import SimulatedMission
from masonry.mission.sites import SiteVisit, work_span_m
from masonry.mission.uav_stack import build_machine
from masonry.planner.tasks import BrickTask, Plan
from masonry.segments import point_segment_m
from masonry.separation import SEPARATION_XY_M

#: UAV name -> its ticks: (time s, task state, transit state, position or None)
Ticks = dict[str, list[tuple[float, str, str, tuple[float, float, float] | None]]]
#: UAV name -> at each tick of mission control it waited for its flight: (time s, (other UAV, what of it) ...)
Blocked = dict[str, list[tuple[float, tuple[tuple[str, str], ...]]]]

#: A leaving UAV has moved off its site once this far from where it asked (horizontally).
MOVED_M = 0.05


@dataclass(frozen=True)
class Flown:
    """One mission and its ticks."""

    makespan_s: float
    plan: Plan
    clearance_m: float
    visits: tuple[SiteVisit, ...]
    ticks: Ticks
    blocked: Blocked


def recording_machine(ticks: Ticks) -> Any:
    """A ``uav_machine`` for :meth:`SimulatedMission.from_blueprint` whose machines append each control tick's
    state, transit state and position to ``ticks`` (by UAV name)."""

    def machine(
        spec: Any, ports: Any, bp: Any, handler: Any, clock: Any, layer: Any, template: Any
    ) -> object:
        m: Any = build_machine(spec, ports, bp, handler, clock, layer, template)
        step, rows = m.step, ticks[spec.name]

        def recorded_step(now_s: float) -> None:
            step(now_s)
            tel = m._tel
            rows.append((now_s, m.state, m.transit.state, None if tel is None else tuple(tel.position_m)))

        m.step = recorded_step
        return m

    return machine


def fly(blueprint: Blueprint, bricks: int, adhesion: int, seed: int, vehicle: str | None) -> Flown:
    """Fly the mission, recording each UAV's state, transit and position at every control tick."""
    ticks: Ticks = defaultdict(list)
    machine = recording_machine(ticks)
    options: dict[str, Any] = {"brick_uavs": bricks, "adhesion_uavs": adhesion, "seed": seed}
    if vehicle is not None:
        options["vehicle"] = vehicle
    mission = SimulatedMission.from_blueprint(blueprint, uav_machine=machine, camera="geometric", **options)
    blocked: Blocked = defaultdict(list)
    columns: Any = mission.control.columns
    grant = columns.grant

    def recorded_grant(now_s: float) -> Any:
        for uav in columns.waiting:
            blocked[uav].append((now_s, tuple(columns.blockers(uav))))
        return grant(now_s)

    columns.grant = recorded_grant
    report = mission.run()
    visits = tuple(v for v in mission.control.sites.visits if v.end_s is not None)
    return Flown(report.makespan_s, mission.plan, blueprint.clearance_m, visits, dict(ticks), dict(blocked))


def _in_visit(rows: list[Any], v: SiteVisit) -> Counter[tuple[str, str]]:
    """The seconds per (task state, transit state) of ``v``'s UAV inside the visit."""
    per: Counter[tuple[str, str]] = Counter()
    assert v.end_s is not None
    for (t0, state, transit, _p), (t1, *_rest) in itertools.pairwise(rows):
        if t0 >= v.start_s - 1e-9 and t1 <= v.end_s + 1e-9:
            per[(state, transit)] += t1 - t0
    return per


def _near(rows: list[Any], v: SiteVisit, span: Any, r_c: float) -> tuple[float | None, float | None]:
    """When ``v``'s UAV first came within ``r_c`` of the work ``span`` in the visit, and when it was first
    farther than that after the visit ended (None: not seen)."""
    assert v.end_s is not None
    first = out = None
    for t, _s, _tr, p in rows:
        if p is None or t < v.start_s - 1e-9:
            continue
        inside = point_segment_m((p[0], p[1]), span[0], span[1]) <= r_c
        if first is None and inside and t <= v.end_s + 1e-9:
            first = t
        if t >= v.end_s - 1e-9 and not inside:
            out = t
            break
    return first, out


def _stats(xs: list[float]) -> str:
    if not xs:
        return "-"
    xs = sorted(xs)
    p90 = xs[min(len(xs) - 1, int(0.9 * len(xs)))]
    return (
        f"mean {statistics.mean(xs):.2f}, median {statistics.median(xs):.2f}, p90 {p90:.2f}, "
        f"least {xs[0]:.2f}, most {xs[-1]:.2f} s"
    )


def visit_table(f: Flown) -> list[str]:
    """Section 1 and 2: the phases per visit, the release and the time before r_c."""
    tasks = {t.id: t for t in f.plan.tasks}
    out = []
    for kind in ("brick", "adhesion"):
        mine = [v for v in f.visits if isinstance(tasks[v.task_id], BrickTask) == (kind == "brick")]
        if not mine:
            continue
        lengths = [v.end_s - v.start_s for v in mine if v.end_s is not None]
        per: Counter[tuple[str, str]] = Counter()
        before_rc, released_early = [], []
        for v in mine:
            assert v.end_s is not None
            rows = f.ticks.get(v.uav, [])
            per.update(_in_visit(rows, v))
            first, left = _near(rows, v, work_span_m(tasks[v.task_id]), f.clearance_m)
            if first is not None:
                before_rc.append(first - v.start_s)
            if left is not None:
                released_early.append(left - v.end_s)
        n = len(mine)
        out.append(
            f"{kind}: {n} visits, mean {statistics.mean(lengths):.2f} s, median {statistics.median(lengths):.2f} s, "
            f"least {min(lengths):.2f} s"
        )
        out.append("")
        out.append("| task state / transit | s per visit | share |")
        out.append("|---|---|---|")
        total = sum(per.values())
        for (state, transit), s in per.most_common():
            if s / n >= 0.005:
                out.append(f"| {state} / {transit} | {s / n:.2f} | {s / total:.0%} |")
        out.append("")
        out.append(f"- before its UAV came within r_c: {_stats(before_rc)}")
        out.append(
            f"- ended this long before its UAV was out of r_c (negative: held after it left): {_stats(released_early)}"
        )
        out.append("")
    return out


def hand_overs(f: Flown) -> list[str]:
    """Section 3: from a conflicting interval's end to the next start of a UAV that waited for it."""
    near: dict[str, set[str]] = {t.id: set() for t in f.plan.tasks}
    for a, b in f.plan.conflicts:
        near[a].add(b)
        near[b].add(a)
    gaps = []
    for v in f.visits:
        rows = f.ticks.get(v.uav, [])
        i = bisect.bisect_left([r[0] for r in rows], v.start_s - 1e-6) - 1
        if i < 0 or rows[i][2] not in ("ask", "hold"):
            continue
        j = i
        while j > 0 and rows[j - 1][2] in ("ask", "hold"):
            j -= 1
        ended = [
            o
            for o in f.visits
            if o.task_id in near[v.task_id]
            and o.uav != v.uav
            and o.end_s is not None
            and rows[j][0] <= o.end_s <= v.start_s + 1e-6
        ]
        if ended:
            o = max(ended, key=lambda o: o.end_s or 0.0)
            assert o.end_s is not None
            gaps.append((v.start_s - o.end_s, v, o))
    gaps.sort(key=lambda g: -g[0])
    out = [f"hand-overs: {len(gaps)}, {_stats([g[0] for g in gaps])}; at once (< 0.05 s): "]
    out[0] += str(sum(1 for g in gaps if g[0] < 0.05))
    for gap, v, o in gaps[:5]:
        out.append(
            f"- {gap:.1f} s: {v.task_id} ({v.uav}) at {v.start_s:.1f} s after {o.task_id} ({o.uav}) left"
        )
    held: Counter[str] = Counter()
    off_s, climbed = [], []
    for _gap, v, o in gaps:
        held.update(_held_by(f, v, o))
        off, climb_m = _leaving(f, v, o)
        off_s.append(off)
        if climb_m >= 0.3:
            climbed.append(off)
    total = sum(g[0] for g in gaps)
    out.append(
        f"- what held the waiting UAV, of {total:.1f} s in the sum: "
        + ", ".join(f"{what} {held[what]:.1f} s" for what in HELD_BY)
    )
    out.append(
        f"- the leaving UAV from its ask to moving off its site: {sum(off_s):.1f} s in the sum "
        f"({_stats(off_s)}); {len(climbed)} climbed 0.3 m or more there first ({sum(climbed):.1f} s)"
    )
    steps = [_timeline(f, v, o) for _gap, v, o in gaps]
    out.append(
        "- the hand-over step by step (from the leaving UAV's ask to the waiting one's grant), summed (median):"
    )
    for i, what in enumerate(TIMELINE):
        xs = [t[i + 1] - t[i] for t in steps if t[i] is not None and t[i + 1] is not None]
        if xs:
            out.append(f"  - {what}: {sum(xs):.1f} s ({statistics.median(xs):.2f} s, {len(xs)} hand-overs)")
    return out


#: The steps of a hand-over (:func:`_timeline`), in the order printed.
TIMELINE = (
    "its ask to moving at all (the answer, its own wait)",
    "moving to moving sideways (its climb there)",
    f"moving sideways to {SEPARATION_XY_M} m off (its climb freed)",
    f"{SEPARATION_XY_M} m off to the waiting UAV's grant",
)


def _timeline(f: Flown, v: SiteVisit, o: SiteVisit) -> tuple[float | None, ...]:
    """When ``o``'s UAV asked, moved at all, moved sideways (``MOVED_M``) and was ``SEPARATION_XY_M`` off
    (horizontally) from where it asked, and when ``v`` began (None: not within 30 s after)."""
    assert o.end_s is not None
    rows = [
        r for r in f.ticks.get(o.uav, []) if o.end_s - 1e-6 <= r[0] <= v.start_s + 30.0 and r[3] is not None
    ]
    moved: float | None = None
    sideways: float | None = None
    off: float | None = None
    if rows:
        p0 = rows[0][3]
        assert p0 is not None
        for t, _s, _tr, p in rows:
            assert p is not None
            d = math.hypot(p[0] - p0[0], p[1] - p0[1])
            if moved is None and (d > MOVED_M or abs(p[2] - p0[2]) > MOVED_M):
                moved = t
            if sideways is None and d > MOVED_M:
                sideways = t
            if off is None and d > SEPARATION_XY_M:
                off = t
    return o.end_s, moved, sideways, off, v.start_s


#: What held a waiting UAV at a tick of a hand-over (:func:`_held_by`), in the order printed.
HELD_BY = (
    "the leaving UAV's climb (where it set off)",
    "its leg or other volumes",
    "another UAV only",
    "nothing in the airspace",
)


def _held_by(f: Flown, v: SiteVisit, o: SiteVisit) -> Counter[str]:
    """The seconds of the hand-over from ``o`` to ``v`` by what held ``v``'s UAV (:data:`HELD_BY`)."""
    assert o.end_s is not None
    rows = [r for r in f.blocked.get(v.uav, []) if o.end_s - 1e-6 <= r[0] < v.start_s - 1e-6]
    out: Counter[str] = Counter()
    if not rows:
        return out
    for (t0, blockers), t1 in zip(rows, [r[0] for r in rows[1:]] + [v.start_s], strict=True):
        mine = {kind for uav, kind in blockers if uav == o.uav}
        if "climb" in mine:
            out[HELD_BY[0]] += t1 - t0
        elif mine:
            out[HELD_BY[1]] += t1 - t0
        elif blockers:
            out[HELD_BY[2]] += t1 - t0
        else:
            out[HELD_BY[3]] += t1 - t0
    return out


def _leaving(f: Flown, v: SiteVisit, o: SiteVisit) -> tuple[float, float]:
    """How long ``o``'s UAV took from its ask to moving ``MOVED_M`` off where it asked (at most until ``v``
    began), and how much it climbed meanwhile."""
    assert o.end_s is not None
    rows = [
        r for r in f.ticks.get(o.uav, []) if o.end_s - 1e-6 <= r[0] <= v.start_s + 1e-6 and r[3] is not None
    ]
    if not rows:
        return 0.0, 0.0
    p0 = rows[0][3]
    assert p0 is not None
    off = v.start_s
    for t, _s, _tr, p in rows:
        assert p is not None
        if math.hypot(p[0] - p0[0], p[1] - p0[1]) > MOVED_M:
            off = t
            break
    climb_m = max(p[2] for t, _s, _tr, p in rows if p is not None and t <= off) - p0[2]
    return off - o.end_s, climb_m


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2,8+4")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--vehicle", default=None, help="the simulated vehicle (default: masonry sim's)")
    args = ap.parse_args()
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        f = fly(WALLS[wall][1](), bricks, adhesion, args.seed, args.vehicle)
        print(
            f"\n## {WALLS[wall][0]}, {bricks} + {adhesion}, seed {args.seed}: makespan {f.makespan_s:,.1f} s\n"
        )
        for line in [*visit_table(f), *hand_overs(f)]:
            print(line)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
