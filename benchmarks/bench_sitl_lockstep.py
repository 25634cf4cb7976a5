"""The PX4 brick task against the project's SITL, free-running and in lock-step, side by side (issue 29).

Flies tests/test_px4.py's task (``masonry fly --task B1`` against ``build_sitl(time_scale=K, vehicle="px4")``, in
this process) ``--pairs`` times, once free and once in lock-step (``masonry sitl --lockstep``) each time, with a
process spinning on one core unless ``--no-busy``. Prints one line per flight: the placement, the task's simulated
time, its wall time, the SITL's grants and free runs (docs/sitl-lockstep.md), a digest of the task's trace (its
states and their times: the same digest, the same flight), the load average after it; at the end, the spread of
each mode's placements (a lock-step flight repeats: the same seed, the same placement, docs/sitl-lockstep.md).
``--lockstep-only`` flies the lock-step flight alone, ``--pairs`` times. Asserts nothing.

Usage: python benchmarks/bench_sitl_lockstep.py [--pairs 4] [--time-scale 4] [--no-busy] [--lockstep-only]
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import time
from pathlib import Path

from typer.testing import CliRunner

from masonry.adapters.sitl import free_udp_port
from masonry.cli import app
from masonry.cli.hardware import build_sitl

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


def fly(lockstep: bool, time_scale: float, placed_m: list[float]) -> str:
    port = free_udp_port()
    sitl, _ = build_sitl(
        port=port, uav="brick", blueprint=Path(CASE_STUDY), time_scale=time_scale, vehicle="px4", seed=1,
        lockstep=lockstep,
    )  # fmt: skip
    sitl.start()
    started = time.perf_counter()
    try:
        res = CliRunner().invoke(app, [
            "fly", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B1", "--fc", f"udp:127.0.0.1:{port}",
            "--actuators", "sim", "--camera", "sim", "--format", "json",
        ])  # fmt: skip
    finally:
        sitl.stop()
    wall_s = time.perf_counter() - started
    try:
        out = json.loads(res.stdout)
    except json.JSONDecodeError:
        return f"exit {res.exit_code}: {res.output[-200:]!r}"
    placed = out.get("placement_error_m")
    if placed is not None:
        placed_m.append(placed)
    pace = sitl.lockstep
    return (
        f"{out['status']:6s} placed {placed * 1000 if placed is not None else float('nan'):9.6f} mm, "
        f"simulated {sitl.sim_time_s:6.1f} s, wall {wall_s:5.1f} s"
        + (f", grants {pace.grants}, free runs {pace.free_runs}" if pace is not None else "")
        + f", trace {hashlib.sha256(json.dumps(out.get('trace')).encode()).hexdigest()[:10]}"
        + ", load average {:.1f} {:.1f} {:.1f}".format(*os.getloadavg())
        + (f"; {out.get('reason')}" if out["status"] != "done" else "")
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--pairs", type=int, default=4)
    ap.add_argument("--time-scale", type=float, default=4.0)
    ap.add_argument("--no-busy", action="store_true", help="no busy process")
    ap.add_argument("--lockstep-only", action="store_true", help="fly the lock-step flight only")
    args = ap.parse_args()
    busy = None if args.no_busy else subprocess.Popen([sys.executable, "-c", "while True: pass"])
    placed_m: dict[bool, list[float]] = {False: [], True: []}
    try:
        for pair in range(1, args.pairs + 1):
            for lockstep in (True,) if args.lockstep_only else (False, True):
                line = fly(lockstep, args.time_scale, placed_m[lockstep])
                print(f"pair {pair} {'lock-step' if lockstep else 'free     '}: {line}", flush=True)
    finally:
        if busy is not None:
            busy.kill()
            busy.wait()
    for lockstep, placed in placed_m.items():
        if placed:
            print(
                f"{'lock-step' if lockstep else 'free'}: {len(placed)} placed, {len(set(placed))} distinct, "
                f"{min(placed) * 1000:.6f}-{max(placed) * 1000:.6f} mm (spread {(max(placed) - min(placed)) * 1000:.6f} mm)"
            )


if __name__ == "__main__":
    main()
