"""The pace of the bricks (issue 27): when the 20th, 40th and 60th brick are placed, and where the brick UAVs
hold, per fleet; prints a Markdown table, asserts nothing.

Flies ``masonry.mission.simulate`` as ``bench_fleet.py`` does (``critical-path``, ``site``, ``columns``,
geometric camera) and prints per seed and fleet: the makespan; the times the 20th, 40th and 60th brick were
placed (a fleet that scales places them sooner); when the last adhesion task was done; the brick and adhesion
UAVs' holding per task (``PhaseTimes.holding`` summed over the attempts, per task to do); the clearance answers
a brick UAV was held by (a hold flight or "hover where you are"), for a site at the pallet (y below -1.2 m: the
generated pallets are r_c + 1 m from the wall) and at the wall; and the task-seconds waited for a battery swap.

Usage: python benchmarks/bench_fleet_pace.py [--walls 12m] [--fleets 4+2,6+3,8+4] [--seeds 1,2,3]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_fleet import WALLS, simulate_fleet

from masonry.mission.events import EventList
from masonry.mission.report import MissionReport, phase_totals

#: a clearance for a site farther than this behind the wall's face (y, metres) is one at the pallet
PALLET_Y_M = -1.2


def held_answers(events: EventList) -> Counter[str]:
    """Clearance answers that held a brick UAV, by where its site was: ``pallet`` or ``wall``."""
    held: Counter[str] = Counter()
    for e in events.events:
        if e.kind != "clearance" or e.fields.get("granted") or not (e.uav or "").startswith("brick"):
            continue
        site = e.fields.get("site_m")
        held["pallet" if site is not None and float(site[1]) < PALLET_Y_M else "wall"] += 1
    return held


def row(seed: int, bricks: int, adhesion: int, report: MissionReport, events: EventList) -> str:
    """One line of the table."""
    brick_ends = sorted(t.end_s for t in report.tasks if t.kind == "brick" and t.end_s is not None)
    glue_ends = sorted(t.end_s for t in report.tasks if t.kind != "brick" and t.end_s is not None)
    n_bricks = sum(1 for t in report.tasks if t.kind == "brick") or 1
    n_glue = sum(1 for t in report.tasks if t.kind != "brick") or 1
    hold_b = phase_totals(a for a in report.attempts if a.kind == "brick").holding
    hold_a = phase_totals(a for a in report.attempts if a.kind != "brick").holding
    battery_s = sum(w.duration_s for t in report.tasks for w in t.waits if w.cause.what == "battery")
    held = held_answers(events)

    def nth(k: int) -> str:
        return f"{brick_ends[k - 1]:,.0f}" if len(brick_ends) >= k else "-"

    last_glue = f"{glue_ends[-1]:,.0f} s" if glue_ends else "-"
    return (
        f"| {seed} | {bricks} + {adhesion} | {report.makespan_s:,.0f} s | {nth(20)} / {nth(40)} / {nth(60)} s | "
        f"{last_glue} | {hold_b / n_bricks:.0f} s | {hold_a / n_glue:.1f} s | {held['pallet']:,} / "
        f"{held['wall']:,} | {battery_s:,.0f} s |"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--walls", default="12m")
    ap.add_argument("--fleets", default="4+2,6+3,8+4")
    ap.add_argument("--seeds", default="1,2,3")
    args = ap.parse_args()
    for wall in args.walls.split(","):
        if wall not in WALLS:
            ap.error(f"--walls: unknown wall {wall!r} (one of {', '.join(WALLS)})")
        print(f"\n## {WALLS[wall][0]}\n")
        print(
            "| seed | fleet | makespan | 20th / 40th / 60th brick placed | last adhesion done | holding per "
            "brick | per adhesion task | brick UAVs held: pallet / wall | battery waits |"
        )
        print("|---|---|---|---|---|---|---|---|---|")
        for seed in (int(s) for s in args.seeds.split(",")):
            for fleet in args.fleets.split(","):
                try:
                    bricks, adhesion = (int(x) for x in fleet.split("+"))
                except ValueError:
                    ap.error(f"--fleets: {fleet!r} is not BRICK+ADHESION (e.g. 4+2)")
                events = EventList()
                report = simulate_fleet(
                    WALLS[wall][1](),
                    bricks,
                    adhesion,
                    seed,
                    airspace="columns",
                    events_sink=events,
                )
                print(row(seed, bricks, adhesion, report, events), flush=True)


if __name__ == "__main__":
    main()
