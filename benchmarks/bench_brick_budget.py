"""The brick UAVs' time budget (issue 27 §4): where each brick UAV's mission goes, per fleet, against 1 + 1's;
prints Markdown tables, asserts nothing.

On the running bonds the brick UAVs are the role the wall waits on (the sprayers are done 200-270 s before the last
brick at 4 + 2), so a brick UAV's makespan is its first assignment (``start``), its bricks' work flown without a
hold (``work``: every phase of its attempts but ``queued``, ``takeoff``, ``waiting`` and ``holding``), its holds
(``waiting`` + ``holding``), its battery swaps (``swaps``: the gaps of more than :data:`SWAP_GAP_S` between two of
its attempts, and a handler's hold for a swap inside an attempt, ``queued`` + ``takeoff``), the rest of its time
between tasks (``between``) and what it waits after its last brick for the others (``tail``). The means over the
brick UAVs add up to the makespan less ``tail``'s share of rounding.

Printed per wall: the budget per fleet and seed (means per brick UAV, and the work and holds per brick), then the
makespan each fleet would fly with 1 + 1's holds per brick of the same seed (``start + work + holds at 1 + 1's rate
+ swaps + between + tail``, every other term as flown) and its speed-up over that seed's 1 + 1; and the brick
tasks' holds by cause (mission control's ``waits``: the ``site`` rule or the ``airspace``, by the role of the UAV
in the way), in the first 400 s and after.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``, geometric
camera).

Usage: python benchmarks/bench_brick_budget.py [--walls 12m] [--fleets 1+1,4+2] [--seeds 1]
"""

from __future__ import annotations

import sys
from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import simulate_fleet, sweep

from masonry.mission.report import MissionReport

#: a gap of more than this (s) between two attempts of a brick UAV is a battery swap (the UAV sent home with no
#: task: 78-100 s on the 12 m wall); the gaps between tasks are otherwise 0
SWAP_GAP_S = 30.0
#: a handler's hold of a task for a swap (``queued`` + ``takeoff``) longer than this (s) counts as a swap
HELD_SWAP_S = 30.0
#: the holds before this (s) are the start's (docs/performance/fleet.md: the first 400 s, behind the two fronts)
START_S = 400.0


@dataclass(frozen=True)
class Budget:
    """The means per brick UAV of one mission (s), and its bricks."""

    makespan_s: float
    bricks: int
    uavs: int
    start_s: float
    work_s: float
    holds_s: float
    swaps_s: float
    between_s: float
    tail_s: float

    @property
    def work_per_brick_s(self) -> float:
        return self.work_s * self.uavs / max(1, self.bricks)

    @property
    def holds_per_brick_s(self) -> float:
        return self.holds_s * self.uavs / max(1, self.bricks)

    def with_holds_per_brick(self, holds_per_brick_s: float) -> float:
        """The mean brick UAV's makespan with ``holds_per_brick_s`` a brick, every other term as flown."""
        holds = holds_per_brick_s * self.bricks / max(1, self.uavs)
        return self.start_s + self.work_s + holds + self.swaps_s + self.between_s + self.tail_s


def budget(report: MissionReport) -> Budget:
    """The brick UAVs' budget of ``report`` (see the module docstring)."""
    rows: list[tuple[float, float, float, float, float, float]] = []
    bricks = 0
    for uav in report.uavs:
        if uav.role != "brick":
            continue
        attempts = sorted((a for a in report.attempts if a.uav == uav.name), key=lambda a: a.start_s)
        if not attempts:
            continue
        bricks += sum(1 for a in attempts if a.status == "done")
        holds = work = swaps = between = 0.0
        for a in attempts:
            if a.phases is None:
                continue
            held = a.phases.queued + a.phases.takeoff
            holds += a.phases.clearance_s
            work += a.phases.total_s - a.phases.clearance_s - held
            if held > HELD_SWAP_S:
                swaps += held
            else:
                between += held
        ends = [a.end_s if a.end_s is not None else report.makespan_s for a in attempts]
        for end, nxt in zip(ends, attempts[1:]):
            gap = max(0.0, nxt.start_s - end)
            if gap > SWAP_GAP_S:
                swaps += gap
            else:
                between += gap
        rows.append((attempts[0].start_s, work, holds, swaps, between, report.makespan_s - max(ends)))
    n = max(1, len(rows))

    def mean(i: int) -> float:
        return sum(r[i] for r in rows) / n

    return Budget(report.makespan_s, bricks, n, mean(0), mean(1), mean(2), mean(3), mean(4), mean(5))


def brick_holds(report: MissionReport) -> Counter[str]:
    """The brick tasks' ``site`` and ``airspace`` waits (task-seconds) by cause and the role in the way
    (``site/glue``, ``airspace/brick``, ...; ``airspace/-``: none named), and ``first`` / ``later`` of
    :data:`START_S`."""
    out: Counter[str] = Counter()
    for t in report.tasks:
        if t.kind != "brick":
            continue
        for w in t.waits:
            if w.cause.what not in ("site", "airspace"):
                continue
            role = "glue" if (w.cause.blocking_uav or "").startswith("glue") else "brick"
            out[f"{w.cause.what}/{role if w.cause.blocking_uav else '-'}"] += w.duration_s
            out["first" if w.from_s < START_S else "later"] += w.duration_s
    return out


def budget_lines(runs: Sequence[tuple[str, int, Budget]]) -> list[str]:
    """The budget table: (fleet, seed, budget) per run; 1 + 1 of the same seed, when flown, is the yardstick."""
    base = {seed: b for fleet, seed, b in runs if fleet == "1 + 1"}
    out = [
        "| fleet | seed | makespan | bricks / brick UAV | start | work (per brick) | holds (per brick) | swaps | "
        "between | tail | with 1 + 1's holds per brick | its speed-up over 1 + 1 |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for fleet, seed, b in runs:
        one = base.get(seed)
        if one is not None:
            est = b.with_holds_per_brick(one.holds_per_brick_s)
            what_if = f"{est:,.0f} s | {one.makespan_s / est:.2f}"
        else:
            what_if = "- | -"
        out.append(
            f"| {fleet} | {seed} | {b.makespan_s:,.1f} s | {b.bricks / b.uavs:.0f} | {b.start_s:.0f} | "
            f"{b.work_s:.0f} ({b.work_per_brick_s:.1f}) | {b.holds_s:.0f} ({b.holds_per_brick_s:.1f}) | "
            f"{b.swaps_s:.0f} | {b.between_s:.0f} | {b.tail_s:.0f} | {what_if} |"
        )
    return out


def main() -> None:
    runs: list[tuple[str, int, Budget]] = []
    holds: list[tuple[str, int, Counter[str]]] = []
    title = ""
    for wall, blueprint, bricks, adhesion, seed in sweep(__doc__.splitlines()[0]):
        if wall != title:
            if runs:
                print("\n".join(budget_lines(runs)))
                runs = []
            title = wall
            print(f"\n## {wall}\n")
        report = simulate_fleet(blueprint, bricks, adhesion, seed)
        runs.append((f"{bricks} + {adhesion}", seed, budget(report)))
        holds.append((f"{bricks} + {adhesion}", seed, brick_holds(report)))
        print(
            f"flown {bricks} + {adhesion} seed {seed}: {report.makespan_s:,.1f} s",
            file=sys.stderr,
            flush=True,
        )
    print("\n".join(budget_lines(runs)))
    keys = ("site/glue", "site/brick", "airspace/brick", "airspace/glue", "airspace/-")
    print("\nBrick tasks' holds (task-seconds): " + ", ".join(keys) + "; first 400 s / later\n")
    for fleet, seed, h in holds:
        print(
            f"- {fleet}, seed {seed}: " + " / ".join(f"{h[k]:.0f}" for k in keys) + f"; {h['first']:.0f} / "
            f"{h['later']:.0f}"
        )


if __name__ == "__main__":
    main()
