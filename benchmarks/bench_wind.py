"""Missions in wind (issue 18): completion, brick placement error and adhesion coverage against the mean wind.

For each wall (the paper's case study; a small running bond, ``running_bond(2, 5)``), each turbulence level and
each mean wind speed (m/s at 10 m, from the west; ``--wind S@270 --turbulence LEVEL``), ``--seeds`` missions on
the simulated vehicle (``--vehicle``). Per row: missions completed, placement error mean and max over every placed
brick, adhesion coverage mean and min over every segment, and the median makespan. Then the issue's targets:
every mission completes at 4 m/s light and 2 m/s moderate, placement error mean <= 1.5 cm and max <= 3 cm,
coverage >= 0.9.

    .venv/bin/python benchmarks/bench_wind.py                                 # the curve, 5 seeds a point
    .venv/bin/python benchmarks/bench_wind.py --targets --seeds 20            # the issue's two points, 20 seeds
"""

from __future__ import annotations

import argparse
import statistics
from pathlib import Path
from typing import Any

from masonry.blueprint import load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.mission.simulate import SimulatedMission
from masonry.planner.tasks import AdhesionTask
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

ROOT = Path(__file__).resolve().parents[1]


def walls() -> dict[str, Any]:
    return {
        "case study": load_blueprint(ROOT / "blueprints" / "paper_case_study.yaml"),
        "running_bond(2, 5)": running_bond(2, 5),
    }


def fly(bp: Any, speed_mps: float, turbulence: str, seed: int, vehicle: str) -> dict[str, Any]:
    """One mission: completed, placement errors (m), coverages, makespan (s)."""
    faults = Faults(wind=WindConfig(speed_mps=speed_mps, direction_deg=270.0, turbulence=turbulence))
    with SimulatedMission.from_blueprint(bp, seed=seed, faults=faults, vehicle=vehicle) as mission:
        report = mission.run()
        world = mission.world
        coverage = [world.coverage(t) for t in mission.plan.tasks if isinstance(t, AdhesionTask)]
    errors = [e for e in report.placement_error_m.values() if e is not None]
    return {
        "completed": report.completed,
        "errors": errors,
        "coverage": coverage,
        "makespan": report.makespan_s,
    }


def row(bp: Any, speed: float, turbulence: str, seeds: int, vehicle: str) -> dict[str, Any]:
    runs = [fly(bp, speed, turbulence, seed, vehicle) for seed in range(seeds)]
    errors = [e for r in runs for e in r["errors"]]
    coverage = [c for r in runs for c in r["coverage"]]
    return {
        "completed": sum(r["completed"] for r in runs),
        "runs": len(runs),
        "err_mean": statistics.fmean(errors) if errors else float("nan"),
        "err_max": max(errors) if errors else float("nan"),
        "cov_mean": statistics.fmean(coverage) if coverage else float("nan"),
        "cov_min": min(coverage) if coverage else float("nan"),
        "makespan": statistics.median(r["makespan"] for r in runs),
    }


def print_row(wall: str, speed: float, turbulence: str, r: dict[str, Any]) -> None:
    print(
        f"| {wall} | {speed:g} | {turbulence} | {r['completed']}/{r['runs']} | {r['err_mean'] * 100:.2f} | "
        f"{r['err_max'] * 100:.2f} | {r['cov_mean']:.3f} | {r['cov_min']:.3f} | {r['makespan']:.0f} |",
        flush=True,
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--vehicle", default="arducopter", help="ideal | arducopter (default: arducopter)")
    ap.add_argument("--speeds", default="0,2,4,6,8", help="mean wind speeds, m/s at 10 m")
    ap.add_argument("--turbulence", default="light,moderate")
    ap.add_argument(
        "--targets", action="store_true", help="only the issue's two points (4 light, 2 moderate)"
    )
    args = ap.parse_args()
    if args.targets:
        points = [(4.0, "light"), (2.0, "moderate")]
    else:
        speeds = [float(s) for s in args.speeds.split(",")]
        points = [(s, t) for t in args.turbulence.split(",") for s in speeds]
    print(f"vehicle {args.vehicle}, {args.seeds} seeds a point, wind from 270 deg")
    print("| wall | wind m/s | turbulence | completed | error mean cm | error max cm | coverage mean | "
          "coverage min | makespan s |")  # fmt: skip
    print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
    results = {}
    for wall, bp in walls().items():
        for speed, turbulence in points:
            r = results[(wall, speed, turbulence)] = row(bp, speed, turbulence, args.seeds, args.vehicle)
            print_row(wall, speed, turbulence, r)
    for (wall, speed, turbulence), r in results.items():
        if (speed, turbulence) not in ((4.0, "light"), (2.0, "moderate")):
            continue
        ok = (
            r["completed"] == r["runs"]
            and r["err_mean"] <= 0.015
            and r["err_max"] <= 0.03
            and r["cov_min"] >= 0.9
        )
        print(f"target {wall}, {speed:g} m/s {turbulence}: {'met' if ok else 'NOT met'}")


if __name__ == "__main__":
    main()
