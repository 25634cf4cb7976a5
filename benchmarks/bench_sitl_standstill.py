"""ArduCopter's SITL starved on purpose while masonry's link watches it: the silence on the wall and as counted.

Starts one ArduCopter SITL (``MASONRY_ARDUPILOT_SITL``, tests/ardupilot_sitl.py, instance 48), connects
``MavlinkFlightController`` to it, waits for its telemetry, then ``--rounds`` times starves it for ``--starve``
seconds of wall: its process pinned to CPU 0 beside two busy loops pinned there, its scheduling class
SCHED_IDLE and its autogroup's nice 19 (it stays runnable, as a loaded machine leaves it: its clock, heartbeats
and vehicle stop). Meanwhile it reads, every 20 ms, the longest silence since the last message on the wall (up
to what the receiver read, ``link_silence.heard_until``) and as the watchdog counts it
(``masonry.adapters.sitl_standstill``: the time the process stood runnable and unrun taken out), and whether the
link stayed up. Prints one line a round and asserts nothing. Needs to change its SITL's scheduling (root, or
CAP_SYS_NICE); the busy loops run only while a round starves.

Usage: MASONRY_ARDUPILOT_SITL=$(realpath ../shared/sitl/arducopter) python benchmarks/bench_sitl_standstill.py
       [--rounds 3] [--starve 2.0] [--speedup 2]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import time
from pathlib import Path
from tempfile import TemporaryDirectory

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from ardupilot_sitl import arducopter  # noqa: E402
from masonry.adapters.link_silence import heard_until  # noqa: E402
from masonry.adapters.mavlink import MavlinkFlightController  # noqa: E402

HOG = "import os\nos.sched_setaffinity(0, {0})\nwhile True: pass"


def _starve(pid: int, on: bool) -> None:
    os.sched_setaffinity(pid, {0} if on else set(range(os.cpu_count() or 1)))
    os.sched_setscheduler(pid, os.SCHED_IDLE if on else os.SCHED_OTHER, os.sched_param(0))
    Path(f"/proc/{pid}/autogroup").write_text("19" if on else "0")


def _round(fc: MavlinkFlightController, pid: int, starve_s: float) -> str:
    hogs = [subprocess.Popen([sys.executable, "-c", HOG]) for _ in range(2)]
    _starve(pid, True)
    start, boot0 = time.monotonic(), fc.clock.last_boot_s or 0.0
    wall_s = counted_s = 0.0
    up = True
    try:
        while time.monotonic() - start < starve_s:
            now, st = time.monotonic(), fc._state
            wall_s = max(wall_s, heard_until(now, st.last_message_s, st.listened_s) - st.last_message_s)
            counted_s = max(counted_s, fc._silences(now)[0])
            up &= fc.telemetry().link_ok
            time.sleep(0.02)
    finally:
        _starve(pid, False)
        for hog in hogs:
            hog.kill()
            hog.wait()
    moved_s = (fc.clock.last_boot_s or 0.0) - boot0
    return (
        f"longest silence {wall_s:.2f} s on the wall, {counted_s:.2f} s counted; link up throughout: {up}; "
        f"the SITL's clock moved {moved_s:.2f} s in {time.monotonic() - start:.2f} s of wall"
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--starve", type=float, default=2.0, help="seconds of wall each round starves the SITL")
    ap.add_argument("--speedup", type=int, default=2)
    args = ap.parse_args()
    with (
        TemporaryDirectory() as tmp,
        arducopter(Path(tmp), instance=48, sysid=49, speedup=args.speedup) as url,
    ):
        fc = MavlinkFlightController(url, heartbeat_timeout_s=1.0)
        fc.connect()
        try:
            for _ in range(250):  # 5 s of telemetry: the process found, the watchdog sampling it
                fc.telemetry()
                time.sleep(0.02)
            pid = fc.standstill.pid
            if pid is None:
                sys.exit(f"no process found serving {url}")
            print(f"ArduCopter SITL x{args.speedup} on {url}, pid {pid}; {os.cpu_count()} cores")
            for i in range(1, args.rounds + 1):
                print(f"round {i}: starved {args.starve:.1f} s: {_round(fc, pid, args.starve)}", flush=True)
                time.sleep(2.0)
        finally:
            fc.close()


if __name__ == "__main__":
    main()
