"""A lock-step flight whose SITL dies: how long ``masonry fly`` takes to end, and how (issue 29).

Flies tests/test_px4.py's task (``masonry fly --task B1`` against ``build_sitl(time_scale=4, vehicle="px4",
lockstep=True)``, in this process) and stops the SITL once it has had ``--grants`` grants (80: in the take-off).
Prints the SITL's simulated time and the wall time at the stop, then ``masonry fly``'s exit code, its last line and
the wall time from the stop to its end, or that it was still running after ``--limit-s`` of wall (before issue 29's
fix it never ended: its lock-step clock held at the last time heard). ``--reply-wait-s`` replaces
``REPLY_WAIT_S`` (2 s). Asserts nothing.

Usage: python benchmarks/bench_lockstep_gone.py [--grants 80] [--reply-wait-s 2] [--limit-s 60]
"""

from __future__ import annotations

import argparse
import sys
import threading
import time
from pathlib import Path

from typer.testing import CliRunner, Result

from masonry.adapters import lockstep
from masonry.adapters.sitl import free_udp_port
from masonry.cli import app
from masonry.cli.hardware import build_sitl

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--grants", type=int, default=80)
    parser.add_argument("--reply-wait-s", type=float, default=lockstep.REPLY_WAIT_S)
    parser.add_argument("--limit-s", type=float, default=60.0)
    args = parser.parse_args()
    lockstep.REPLY_WAIT_S = args.reply_wait_s
    port = free_udp_port()
    sitl, _ = build_sitl(
        port=port,
        uav="brick",
        blueprint=Path(CASE_STUDY),
        time_scale=4.0,
        vehicle="px4",
        seed=1,
        lockstep=True,
    )
    sitl.start()
    ran: list[Result] = []
    argv = ["fly", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B1", "--fc", f"udp:127.0.0.1:{port}",
            "--actuators", "sim", "--camera", "sim"]  # fmt: skip
    flight = threading.Thread(target=lambda: ran.append(CliRunner().invoke(app, argv)), daemon=True)
    start_s = time.monotonic()
    flight.start()
    while sitl.lockstep is not None and sitl.lockstep.grants < args.grants and flight.is_alive():
        time.sleep(0.01)
    sim_s = sitl.sim_time_s
    sitl.stop()
    stopped_s = time.monotonic()
    out = sys.__stdout__  # (CliRunner holds sys.stdout while masonry fly runs)
    print(
        f"SITL stopped at {sim_s:.2f} s simulated, {stopped_s - start_s:.1f} s of wall after the start",
        file=out,
    )
    flight.join(args.limit_s)
    ended_s = time.monotonic()
    if flight.is_alive():
        print(f"masonry fly still running {args.limit_s:.0f} s of wall after the SITL stopped", file=out)
        return
    res = ran[0]
    last = res.output.rstrip().splitlines()[-1] if res.output.strip() else ""
    print(
        f"masonry fly ended {ended_s - stopped_s:.1f} s of wall after the stop: exit {res.exit_code}, {last!r}",
        file=out,
    )


if __name__ == "__main__":
    main()
