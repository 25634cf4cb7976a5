"""Issue 29's one-brick scenario on the real PX4 v1.16 SITL, run as written, N times (default settings).

Each run starts ``../shared/px4/run.sh`` (SIH quadrotor, ``PX4_PARAM_SDLOG_MODE=-1``) as instance ``--instance``,
then ``masonry fly --uav brick --task B1 --blueprint one_brick.yaml --fc udpin:0.0.0.0:14540+N --actuators sim
--camera sim --config uav.yaml --format json`` with a one-brick blueprint (brick 1 at (2, 1, 0.05), its pickup at
(4, -1, 0.05), brick-1's home at the origin) and a uav.yaml holding only ``estimate_wait_s: 150``. Prints per run
done or failed (with the reason), the placement error, the seconds of flight and how often PX4's log says a
sensor timed out (SIH runs in real time: on a machine too loaded for it EKF2 diverges); then a JSON summary.
PX4 refuses to arm in its first seconds ("temporarily rejected"); masonry asks again for up to 30 s
(``masonry.adapters.arming``), and each run flies ``--boot-wait`` s after starting PX4 (``--boot-wait 0``: at once).
PX4 runs at ``px4_sitl.PX4_NICE`` where the machine allows it (as the tests start it); the scenario is
``px4_sitl.ONE_BRICK``, the blueprint ``tests/test_px4_sitl.py`` flies.

    python benchmarks/bench_px4_brick.py --run-sh ../shared/px4/run.sh --runs 6
    python benchmarks/bench_px4_brick.py --run-sh ../shared/px4/run.sh --runs 6 --control gate_window_s=3.0
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from px4_sitl import ENV, ONE_BRICK, px4


def fly(url: str, folder: Path, timeout_s: float, control: dict[str, float]) -> dict[str, object]:
    """One ``masonry fly`` of the scenario against the PX4 at ``url``: its JSON result (or why there is none)."""
    (folder / "one_brick.yaml").write_text(ONE_BRICK)
    extra = f"control: {json.dumps(control)}\n" if control else ""
    (folder / "uav.yaml").write_text("estimate_wait_s: 150\n" + extra)
    cmd = [sys.executable, "-c", "from masonry.cli import main; main()", "fly", "--uav", "brick", "--task", "B1",
           "--blueprint", str(folder / "one_brick.yaml"), "--fc", url, "--actuators", "sim", "--camera", "sim",
           "--config", str(folder / "uav.yaml"), "--format", "json"]  # fmt: skip
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        return {"status": "failed", "reason": f"no result within {timeout_s:g} s of wall time"}
    lines = [line for line in proc.stdout.splitlines() if line.startswith("{")]
    if not lines:
        return {"status": "failed", "reason": (proc.stderr.strip().splitlines() or ["no output"])[-1]}
    return dict(json.loads(lines[-1]))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--run-sh", type=Path, default=Path(__file__).resolve().parents[2] / "shared/px4/run.sh")
    ap.add_argument("--runs", type=int, default=6)
    ap.add_argument("--instance", type=int, default=6, help="PX4 instance (offboard link on 14540 + N)")
    ap.add_argument("--timeout", type=float, default=400.0, help="wall seconds a run may take")
    ap.add_argument("--boot-wait", type=float, default=10.0,
                    help="wall seconds between starting PX4 and flying (its arming checks settle first)")  # fmt: skip
    ap.add_argument("--control", action="append", default=[], metavar="FIELD=VALUE",
                    help="a `control:` setting added to uav.yaml (not the issue's scenario; repeatable)")  # fmt: skip
    args = ap.parse_args()
    control = {k: float(v) for k, v in (item.split("=", 1) for item in args.control)}
    os.environ[ENV] = str(args.run_sh.resolve())
    rows = []
    for run in range(args.runs):
        with tempfile.TemporaryDirectory() as tmp:
            folder = Path(tmp)
            with px4(folder / "px4", args.instance) as url:
                time.sleep(
                    args.boot_wait
                )  # as a user starts PX4, then flies: it refuses to arm in its first seconds
                out = fly(url, folder, args.timeout, control)
            # SIH runs in real time: a machine too loaded for it starves PX4's sensors (its log says so)
            log = (folder / "px4" / "px4.log").read_text(errors="replace")
        error = out.get("placement_error_m")
        row = {
            "run": run,
            "status": out.get("status"),
            "placement_error_mm": None if error is None else round(float(error) * 1000, 1),  # type: ignore[arg-type]
            "duration_s": out.get("duration_s"),
            "sensor_timeouts": log.count("fail:  TIMEOUT"),
            "reason": out.get("reason"),
        }
        rows.append(row)
        what = f"{row['status']}, error {row['placement_error_mm']} mm, {row['duration_s']} s"
        print(f"run {run}: {what} (load {os.getloadavg()[0]:.1f}; PX4 sensor timeouts {row['sensor_timeouts']})"
              + (f": {row['reason']}" if row["reason"] else ""), flush=True)  # fmt: skip
    done = sum(r["status"] == "done" for r in rows)
    print(json.dumps({"control": control, "runs": rows, "done": done, "of": len(rows)}))


if __name__ == "__main__":
    main()
