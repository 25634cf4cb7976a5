"""Separation between UAVs in whole-mission simulations, with and without the airspace rules (docs/safety.md).

For each bundled blueprint (its own fleet, and larger fleets on the running bonds) it runs ``masonry sim``'s
``simulate`` twice: ``separation=False`` (every lateral leg at the work altitude, no site columns: the plain
conflict graph) and ``separation=True`` (the default). It prints makespan and the minimum distance between two
airborne UAVs, plus how often columns were waited for. ``--sweep`` instead runs the busier walls of the
separation sweep in docs/performance/mission.md, "Tracking" (2x30 and 4x25 running bonds with 4 + 2 UAVs, the
200-brick blueprint with 3 + 2; fifo and critical-path; seeds 0, 1, 2) with separation on, and prints each
run's makespan and minimum separation, then how many runs came closer than 1.0 m. Usage:

    .venv/bin/python benchmarks/bench_separation.py [--quick | --sweep]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import simulate

ROOT = Path(__file__).resolve().parent.parent
CASES = [
    ("paper_case_study", None, None),
    ("towers", None, None),
    ("pyramid", None, None),
    ("running_bond_small", None, None),
    ("running_bond_small", 3, 2),
    ("running_bond_200", None, None),
    ("running_bond_200", 3, 2),
]


def sweep() -> None:
    walls = [
        ("2x30 running bond", lambda: running_bond(2, 30), 4, 2),
        ("4x25 running bond", lambda: running_bond(4, 25), 4, 2),
        ("running_bond_200", lambda: load_blueprint(ROOT / "blueprints" / "running_bond_200.yaml"), 3, 2),
    ]
    print(f"{'wall':<18} {'fleet':>5} {'policy':<13} {'seed':>4} | {'makespan':>9} {'min sep':>8} | wall s")
    seps = []
    for label, make, nb, na in walls:
        bp = make()
        for policy in ("fifo", "critical-path"):
            for seed in (0, 1, 2):
                t0 = time.perf_counter()
                r = simulate(bp, brick_uavs=nb, adhesion_uavs=na, policy=policy, seed=seed).to_dict()
                sep = r["min_separation_m"]
                seps.append(sep)
                flag = (
                    "" if r["completed"] and r["conflict_violations"] == 0 else "  (incomplete or violation!)"
                )
                print(
                    f"{label:<18} {nb}+{na:<3} {policy:<13} {seed:>4} | {r['makespan_s']:>9.1f} {sep:>8.3f} | "
                    f"{time.perf_counter() - t0:.0f}{flag}",
                    flush=True,
                )
    below = [x for x in seps if x is not None and x < 1.0]
    print(
        f"{len(seps)} runs: min separation {min(x for x in seps if x is not None):.3f} m, "
        f"{len(below)} below 1.0 m"
    )


def main() -> None:
    if "--sweep" in sys.argv:
        sweep()
        return
    quick = "--quick" in sys.argv
    cases = CASES[:5] if quick else CASES
    print(
        f"{'blueprint':<20} {'fleet':>5} | {'makespan off':>12} {'min sep off':>11} | {'makespan on':>11} "
        f"{'min sep on':>10} {'ratio':>6} | wall s"
    )
    for name, nb, na in cases:
        bp = load_blueprint(ROOT / "blueprints" / f"{name}.yaml")
        row = []
        t0 = time.perf_counter()
        for sep in (False, True):
            r = simulate(bp, brick_uavs=nb, adhesion_uavs=na, separation=sep).to_dict()
            row.append((r["makespan_s"], r["min_separation_m"], r["completed"]))
        fleet = f"{nb}+{na}" if nb is not None else "own"
        (m0, s0, c0), (m1, s1, c1) = row
        flag = "" if c0 and c1 else "  (incomplete!)"
        print(
            f"{name:<20} {fleet:>5} | {m0:>12.1f} {s0 if s0 is not None else float('nan'):>11.3f} | {m1:>11.1f} "
            f"{s1 if s1 is not None else float('nan'):>10.3f} {m1 / m0:>6.2f} | {time.perf_counter() - t0:.0f}{flag}",
            flush=True,
        )


if __name__ == "__main__":
    main()
