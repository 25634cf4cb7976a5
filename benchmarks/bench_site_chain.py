"""The site chain (issue 27 §4): where a compact wall's makespan goes when its site visits follow one another;
prints Markdown tables, asserts nothing.

On the bundled pyramid r_c (1.5 m) spans the wall (2.1 m): 77 of its 84 tasks pairwise conflict or depend, so
their site intervals (``--reservation site``: from the grant of a UAV's flight down to its task's site to its
next request) run one at a time, and the mission is the first visit's start + the union of the visits + the gaps
between them (+ a tail after the last visit). Per run this prints that sum, the visits per role, the gaps by the
roles on either side (``brick>adhesion``: a brick's visit, then a segment's), and the gap seconds by what the
*next* visitor's task waited for while the site was free (its ``waits``: ``airspace:<purpose>`` of the UAV in
its way, ``battery``, ``site``, ``dependency``, ``fleet``; ``no wait``: none recorded, its UAV on its way). A
task-second of waiting off the chain (a UAV holding while another works at the site) costs the mission nothing;
a gap second costs it one.

With ``--schedule-time-s`` above 0 the CP-SAT schedule of the wall and fleet (``masonry schedule``, cached as
``bench_fleet.py`` caches it) is put beside it: its site parts' sum and union, its gaps, and how often the site
changes role (a brick after a segment or back) in either, the order being the other thing a schedule could do
differently.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera).

Usage: python benchmarks/bench_site_chain.py [--walls pyramid] [--fleets 2+1,4+2] [--seeds 1,2,3]
       [--schedule-time-s 0]
"""

from __future__ import annotations

import argparse
import itertools
import sys
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet, walls_and_fleets
from schedule_cache import cached_schedule

from masonry.mission.report import MissionReport, TaskReport
from masonry.planner.schedule_values import OfflineSchedule

#: the roles' letters in a chain's order string (a task id starts with its kind's letter)
ROLE = {"A": "adhesion", "B": "brick"}


@dataclass(frozen=True)
class Chain:
    """A mission's (or a schedule's) site intervals laid end to end (seconds)."""

    first_s: float  # the first visit's start
    union_s: float  # the time at least one visit is open
    gaps_s: float  # the time between the first visit's start and the last one's end with none open
    visits: dict[str, tuple[int, float]]  # role -> (visits, their sum)
    by_transition: Counter[str]  # "brick>adhesion" etc. -> gap seconds
    by_cause: Counter[tuple[str, str]]  # (the next visitor's role, what its task waited for) -> gap seconds
    order: str  # the visits' roles in start order, one letter each ("A", "B")

    @property
    def switches(self) -> int:
        """How often the site changes role between two visits in start order."""
        return max(0, len(list(itertools.groupby(self.order))) - 1)


def _waited(task: TaskReport, lo: float, hi: float) -> Counter[str]:
    """What ``task`` waited for between ``lo`` and ``hi`` (its ``waits``), the rest ``no wait``."""
    out: Counter[str] = Counter()
    for w in task.waits:
        a, b = max(lo, w.from_s), min(hi, w.to_s)
        if b > a:
            c = w.cause
            out[f"airspace:{c.holds}" if c.what == "airspace" else c.what] += b - a
    rest = (hi - lo) - sum(out.values())
    if rest > 1e-9:
        out["no wait"] += rest
    return out


def _laid(
    spans: Iterable[tuple[float, float, str]],
) -> tuple[float, float, list[tuple[float, float, str, str]]]:
    """Spans (start, end, id) in start order as (first start, union, gaps): each gap (from, to, the visit before
    it, the visit after it)."""
    ordered = sorted(spans)
    union, gaps = 0.0, []
    cur_a, cur_b, last = ordered[0][0], ordered[0][1], ordered[0][2]
    for a, b, i in ordered[1:]:
        if a > cur_b:
            union += cur_b - cur_a
            gaps.append((cur_b, a, last, i))
            cur_a, cur_b = a, b
        cur_b, last = (b, i) if b >= cur_b else (cur_b, last)
    return ordered[0][0], union + cur_b - cur_a, gaps


def _visits(spans: list[tuple[float, float, str]]) -> dict[str, tuple[int, float]]:
    out: dict[str, tuple[int, float]] = {}
    for a, b, i in spans:
        n, s = out.get(ROLE[i[0]], (0, 0.0))
        out[ROLE[i[0]]] = (n + 1, s + b - a)
    return out


def chain(report: MissionReport) -> Chain:
    """The site chain of a simulated mission (every task with a site interval)."""
    tasks = {t.id: t for t in report.tasks}
    spans = [(t.site_start_s, t.site_end_s, t.id) for t in report.tasks if t.site_start_s is not None]
    spans = [(a, b, i) for a, b, i in spans if b is not None]
    first, union, gaps = _laid(spans)
    by_transition: Counter[str] = Counter()
    by_cause: Counter[tuple[str, str]] = Counter()
    for lo, hi, before, after in gaps:
        by_transition[f"{ROLE[before[0]]}>{ROLE[after[0]]}"] += hi - lo
        for what, s in _waited(tasks[after], lo, hi).items():
            by_cause[(ROLE[after[0]], what)] += s
    order = "".join(i[0] for _, _, i in sorted(spans))
    return Chain(
        first, union, sum(hi - lo for lo, hi, _, _ in gaps), _visits(spans), by_transition, by_cause, order
    )


def schedule_chain(schedule: OfflineSchedule) -> Chain:
    """The same laid out over a ``site`` schedule's planned site parts (no waits: the causes are empty)."""
    spans = [
        (t.site_start_s, t.site_end_s, t.id)
        for u in schedule.uavs
        for t in u.tasks
        if t.site_start_s is not None and t.site_end_s is not None
    ]
    first, union, gaps = _laid(spans)
    by_transition: Counter[str] = Counter()
    for lo, hi, before, after in gaps:
        by_transition[f"{ROLE[before[0]]}>{ROLE[after[0]]}"] += hi - lo
    order = "".join(i[0] for _, _, i in sorted(spans))
    return Chain(
        first, union, sum(hi - lo for lo, hi, _, _ in gaps), _visits(spans), by_transition, Counter(), order
    )


def chain_row(label: str, makespan_s: float, c: Chain) -> str:
    """One row of the chain table."""
    visits = " / ".join(f"{n} {s:,.0f} s ({s / n:.1f})" for _, (n, s) in sorted(c.visits.items()))
    trans = ", ".join(f"{k} {v:,.0f}" for k, v in sorted(c.by_transition.items()))
    return (
        f"| {label} | {makespan_s:,.1f} s | {c.first_s:.1f} | {c.union_s:,.1f} | {c.gaps_s:,.1f} | "
        f"{makespan_s - c.first_s - c.union_s - c.gaps_s:.1f} | {visits} | {trans} | {c.switches} |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="pyramid")
    ap.add_argument("--fleets", default="2+1,4+2")
    ap.add_argument("--seeds", default="1")
    ap.add_argument("--schedule-time-s", type=float, default=0.0, help="CP-SAT seconds (0: no schedule)")
    args = ap.parse_args()
    try:
        seeds = [int(s) for s in args.seeds.split(",")]
    except ValueError:
        ap.error(f"--seeds: {args.seeds!r} is not a comma-separated list of integers")
    print(
        "| run | makespan | first visit | visits' union | gaps | tail | visits (adhesion / brick: n, sum, mean) | "
        "gaps by roles | role changes |\n|---|---|---|---|---|---|---|---|---|"
    )
    causes: list[tuple[str, Counter[tuple[str, str]]]] = []
    for wall, bricks, adhesion in walls_and_fleets(ap, args.walls, args.fleets):
        blueprint = WALLS[wall][1]()
        if args.schedule_time_s > 0:
            schedule, _took, _cached = cached_schedule(
                blueprint, bricks, adhesion, "site", args.schedule_time_s
            )
            label = f"{wall} {bricks} + {adhesion}, schedule ({schedule.status})"
            print(chain_row(label, schedule.makespan_s, schedule_chain(schedule)), flush=True)
        for seed in seeds:
            report = simulate_fleet(blueprint, bricks, adhesion, seed)
            c = chain(report)
            label = f"{wall} {bricks} + {adhesion}, seed {seed}"
            print(chain_row(label, report.makespan_s, c), flush=True)
            causes.append((label, c.by_cause))
    print("\nGap seconds by what the next visitor's task waited for while the site was free:\n")
    for label, by in causes:
        print(f"- {label}: " + ", ".join(f"{r} {w} {s:.1f}" for (r, w), s in by.most_common() if s >= 0.05))


if __name__ == "__main__":
    main()
