"""The chaos campaign (issue 18, section 3): random walls and fleets, random faults, mission control stopped and
resumed from its journal one to three times; every run judged from the UAV handlers' traces.

    python benchmarks/bench_chaos.py [--runs 40] [--first-seed 0] [--vehicle ideal|arducopter|both]
                                     [--lose-a-role] [--max-drop S] [--airspace columns|table] [--verbose]

Each run (``masonry.mission.chaos.random_chaos``): a random site (1-3 UAVs per role), grasp failures, detection
dropouts, occlusion and gusts (each present about half the time), UAVs lost at random times (never every UAV
of a role, unless ``--lose-a-role``), mission links that drop for 1-8 s (``--max-drop``), and one to three abrupt stops of
mission control at random simulated times, each resumed from the SQLite journal. Checks
(``masonry.mission.chaos.check_chaos``): no task done twice, no conflict or dependency violation and the
separation (>= 1 m) measured from the traces and the world, the mission complete, or every task left undone
explained (its role lost every UAV, or its attempts ran out with their reasons).

Prints a line per run with a problem (``--verbose``: every run), then the table of docs/reliability.md.
"""

from __future__ import annotations

import argparse
import logging
import tempfile
import time
from collections import Counter

from masonry.mission.chaos import check_chaos, fly_chaos, random_chaos
from masonry.mission.reserved import AIRSPACES, DEFAULT_AIRSPACE


def campaign(
    runs: int,
    first: int,
    vehicle: str,
    lose_a_role: bool,
    verbose: bool,
    max_drop_s: float = 8.0,
    airspace: str = DEFAULT_AIRSPACE,
) -> dict[str, object]:
    injected: Counter[str] = Counter()
    kinds: Counter[str] = Counter()
    completed = lost_tasks = left = failed_runs = segments = 0
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as work:
        for seed in range(first, first + runs):
            run = random_chaos(
                seed, vehicle=vehicle, lose_a_role=lose_a_role, max_drop_s=max_drop_s, airspace=airspace
            )
            injected.update(run.injected())
            out = fly_chaos(run, work)
            problems = check_chaos(out)
            segments += out.segments
            r = out.report
            completed += bool(r.completed)
            # lost: left undone and not explained; left: undone, the report says why (attempts ran out, each
            # with its UAV's reason, or the role lost every UAV)
            lost_tasks += sum(p.startswith("unexplained") for p in problems)
            left += len(r.stuck)
            kinds.update(p.split(":")[0] for p in problems if not p.startswith("unexplained"))
            failed_runs += any(not p.startswith("unexplained") for p in problems)
            if problems or verbose or not r.completed:
                why: dict[str, str] = {}
                for a in r.attempts:  # every distinct reason of its failed attempts, in order
                    if a.status == "failed" and a.reason and a.reason not in why.get(a.task_id, ""):
                        why[a.task_id] = f"{why[a.task_id]}; {a.reason}" if a.task_id in why else a.reason
                left_why = ", ".join(
                    f"{t} ({why.get(t) or 'never started: a task before it was left'})" for t in r.stuck
                )
                status = "completed" if r.completed else f"NOT completed, left: {left_why}"
                print(f"{run.describe()}: {status}, {out.segments} segments")
                for p in problems:
                    print(f"    {p}")
    return {
        "vehicle": vehicle,
        "runs": runs,
        "injected": dict(injected),
        "segments": segments,
        "completed": completed,
        "lost_tasks": lost_tasks,
        "left": left,
        "problems": dict(kinds),
        "failed_runs": failed_runs,
        "wall_s": time.perf_counter() - t0,
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=40)
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--vehicle", choices=("ideal", "arducopter", "both"), default="both")
    ap.add_argument("--lose-a-role", action="store_true", help="may lose every UAV of a role")
    ap.add_argument("--max-drop", type=float, default=8.0, help="longest link drop, s (default 8)")
    ap.add_argument(
        "--airspace", choices=AIRSPACES, default=DEFAULT_AIRSPACE, help="mission control's airspace"
    )
    ap.add_argument("--verbose", action="store_true", help="a line for every run")
    a = ap.parse_args()
    logging.getLogger("masonry").setLevel(
        logging.ERROR
    )  # every loss and rejoin is a warning: the table says it
    vehicles = ("ideal", "arducopter") if a.vehicle == "both" else (a.vehicle,)
    rows = [
        campaign(a.runs, a.first_seed, v, a.lose_a_role, a.verbose, a.max_drop, a.airspace) for v in vehicles
    ]
    print()
    print(
        "| vehicle | runs | faults injected | mc stops | missions completed | tasks left, with why | "
        "tasks lost | runs with a violation |"
    )
    print("| --- | ---: | --- | ---: | ---: | ---: | ---: | ---: |")
    for row in rows:
        inj = dict(row["injected"])  # type: ignore[call-overload]
        stops = inj.pop("mc-kill", 0)
        faults = ", ".join(f"{k} {v}" for k, v in sorted(inj.items()))
        print(
            f"| {row['vehicle']} | {row['runs']} | {faults} | {stops} | {row['completed']} | {row['left']} | "
            f"{row['lost_tasks']} | {row['failed_runs']} |"
        )
    for row in rows:
        print(
            f"{row['vehicle']}: problems by kind {row['problems'] or '{}'}; "
            f"{row['segments']} segments; {row['wall_s']:.0f} s wall"
        )


if __name__ == "__main__":
    main()
