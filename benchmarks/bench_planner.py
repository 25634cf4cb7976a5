"""Planner throughput: bricks per second at 1k, 10k and 100k bricks, and the 20,000-brick CLI check.

Prints its figures (never asserts). Each wall is a running bond with the default 0.30 x 0.15 x 0.10 m bricks,
the bottom course placed, r_c = 1.5 m. Stages: parse + validate the YAML text, plan (both graphs), JSON text.
Walls over 1,160 bricks are more than any ArUco dictionary can number, so they are planner-only studies:
loaded and planned with ``check_marker_ids=False`` (``masonry plan --planner-only``).

    python benchmarks/bench_planner.py            # 1k, 10k, 100k + the 20k CLI run
    python benchmarks/bench_planner.py --quick    # 1k and 10k only
"""

from __future__ import annotations

import argparse
import gc
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from masonry.blueprint import MAX_MARKED_BRICKS, format_blueprint, load_blueprint
from masonry.blueprint_gen import running_bond
from masonry.planner.export import iter_plan_json
from masonry.planner.graphs import plan_graphs

#: (courses, bricks per course)
WALLS = {1_000: (20, 50), 10_000: (50, 200), 20_000: (100, 200), 100_000: (200, 500)}


def bench(n: int, tmp: Path) -> dict[str, float]:
    courses, per_course = WALLS[n]
    bp = running_bond(courses, per_course, placed_courses=1)
    path = tmp / f"wall_{n}.yaml"
    path.write_text(format_blueprint(bp))
    gc.collect()
    t0 = time.perf_counter()
    marked = n <= MAX_MARKED_BRICKS
    loaded = load_blueprint(path, check_marker_ids=marked)
    t1 = time.perf_counter()
    graphs = plan_graphs(loaded, check_marker_ids=marked)
    t2 = time.perf_counter()
    size = 0
    with open(tmp / f"plan_{n}.json", "w", encoding="utf-8") as fh:
        for piece in iter_plan_json(graphs):
            fh.write(piece)
            size += len(piece)
    t3 = time.perf_counter()
    plan_s = t2 - t1
    return {
        "bricks": n,
        "tasks": len(graphs.tasks),
        "dependencies": len(graphs.dependencies),
        "conflicts": graphs.conflict_count,
        "load_s": t1 - t0,
        "plan_s": plan_s,
        "json_s": t3 - t2,
        "json_mb": size / 1e6,
        "total_s": t3 - t0,
        "bricks_per_s": n / (t3 - t0),
        "plan_bricks_per_s": n / plan_s,
    }


def cli_run(tmp: Path) -> float:
    """Wall-clock seconds of `masonry plan WALL --planner-only --format json --output FILE`, 20,000 bricks."""
    courses, per_course = WALLS[20_000]
    path = tmp / "wall_cli.yaml"
    path.write_text(format_blueprint(running_bond(courses, per_course, placed_courses=1)))
    out = tmp / "plan_cli.json"
    masonry = Path(sys.executable).with_name("masonry")
    command = (
        [str(masonry)] if masonry.exists() else [sys.executable, "-c", "from masonry.cli import main; main()"]
    )
    t0 = time.perf_counter()
    subprocess.run(
        [*command, "plan", str(path), "--planner-only", "--format", "json", "--output", str(out)], check=True
    )
    elapsed = time.perf_counter() - t0
    with out.open() as fh:
        data = json.load(fh)
    print(f"  (checked: {len(data['tasks'])} tasks, {len(data['conflicts'])} conflicts in the JSON file)")
    return elapsed


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="1k and 10k bricks only, no CLI run")
    args = parser.parse_args()
    sizes = [1_000, 10_000] if args.quick else [1_000, 10_000, 100_000]
    print(
        f"planner benchmark on {os.cpu_count()} CPUs, python {sys.version.split()[0]}, load {os.getloadavg()[0]:.1f}"
    )
    header = f"{'bricks':>8} {'tasks':>8} {'conflicts':>10} {'load s':>7} {'plan s':>7} {'json s':>7} {'total s':>8} {'bricks/s':>9}"
    print(header)
    with tempfile.TemporaryDirectory() as tmp_name:
        tmp = Path(tmp_name)
        for n in sizes:
            r = bench(n, tmp)
            print(
                f"{r['bricks']:>8} {r['tasks']:>8} {r['conflicts']:>10} {r['load_s']:>7.2f} {r['plan_s']:>7.2f} "
                f"{r['json_s']:>7.2f} {r['total_s']:>8.2f} {r['bricks_per_s']:>9.0f}",
                flush=True,
            )
        if not args.quick:
            print(
                "masonry plan --planner-only on the 20,000-brick wall (100 courses x 200), --format json --output FILE:"
            )
            print(f"  {cli_run(tmp):.2f} s wall clock, process start included")


if __name__ == "__main__":
    main()
