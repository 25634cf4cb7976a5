"""Issue 29's "default reservation on the real autopilot": a 2 + 1 mission on a 6-brick running bond on three
ArduCopter SITLs, default settings.

``masonry blueprint running-bond --courses 2 --bricks-per-course 3 --brick-uavs 2 --adhesion-uavs 1`` (six bricks
and six beads, none placed), three ArduCopter hexacopter SITLs as the SITL tests start them (tests/ardupilot_sitl.py:
``copter.parm`` and ``copter-hexa.parm``, ``--speedup`` 2; instances 21-23, MAVLink on TCP 5970-5990),
``masonry mission-control BLUEPRINT --listen ...`` (``site``, the default reservation, unless ``--reservation``
says otherwise) and one ``masonry fly --mission ... --actuators sim --camera sim`` a UAV whose only configuration
is ``estimate_wait_s: 150``; mission time follows the autopilots' clocks (``--time-scale`` the speed-up until they
join) and the heartbeats time out after 30 s, as in tests/test_ardupilot_sitl.py. Prints whether the mission
completed, the tasks in the order they ended (by whom, attempts), the makespan (mission time), each brick's
placement error and as-built deviation, the violations measured from the traces (mission control's report:
conflicts, dependencies, the least separation) and each UAV's exit; asserts nothing. An adhesion task is done only
with ``spray_min_coverage`` (0.9) of its bead covered. On so small a wall the dispatcher gives every brick to brick-1
(in simulation too: ``SimulatedMission``, seed 0, ideal and arducopter), so brick-2 stays on its pad
(2026-12-07: 2 of 2 completed, 287.1 and 289.0 s, bricks 12.2-14.7 mm, 0 violations).

    MASONRY_ARDUPILOT_SITL=$(realpath ../shared/sitl/arducopter) PYTHONPATH=src python \\
        benchmarks/bench_arducopter_bond.py [--reservation site|task] [--keep DIR]
"""

from __future__ import annotations

import argparse
import contextlib
import os
import socket
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

from bench_arducopter_case_study import MAIN, masonry_process, read_report, reap

from ardupilot_sitl import SPEEDUP, arducopter
from masonry.blueprint import load_blueprint

#: Wall seconds mission control may take (pre-flights, ~40 s of the autopilots' clocks to a GPS estimate, included).
MISSION_WALL_S = 1800.0


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def run(reservation: str, folder: Path) -> None:
    blueprint = folder / "bond.yaml"
    subprocess.run(
        [sys.executable, "-c", MAIN, "blueprint", "running-bond", "--courses", "2", "--bricks-per-course", "3",
         "--brick-uavs", "2", "--adhesion-uavs", "1", "--name", "bond-6", "-o", str(blueprint)],
        check=True,
    )  # fmt: skip
    fleet = _fleet(blueprint)
    config = folder / "uav.yaml"
    config.write_text("estimate_wait_s: 150\n")
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    name = ["--mission-name", f"bond-{endpoint.rsplit(':', 1)[1]}"]
    started = time.monotonic()
    with contextlib.ExitStack() as stack:
        urls = [
            stack.enter_context(arducopter(folder / uav, instance=21 + i, sysid=21 + i))
            for i, (uav, _) in enumerate(fleet)
        ]
        mc_args = ["mission-control", str(blueprint), "--listen", endpoint, "--format", "json", "--time-scale",
                   str(SPEEDUP), "--startup-timeout", "300", "--heartbeat-timeout", "30", "--max-time", "3000",
                   "--verbose", *name]  # fmt: skip
        if reservation != "site":
            mc_args += ["--reservation", reservation]
        mc = masonry_process(folder / "mission-control", *mc_args)
        uavs = {}
        for (uav, role), url in zip(fleet, urls, strict=True):
            uavs[uav] = masonry_process(folder / f"{uav}-fly", "fly", "--uav", role, "--name", uav, "--blueprint",
                                 str(blueprint), "--mission", endpoint, "--listen", f"tcp/127.0.0.1:{_free_port()}",
                                 "--fc", url, "--actuators", "sim", "--camera", "sim", "--config", str(config),
                                 "--format", "json", "--wait", "60", "--heartbeat-timeout", "30", *name)  # fmt: skip
        hung = reap(mc, uavs, MISSION_WALL_S)
    print(f"reservation {reservation}, speedup {SPEEDUP}: wall {time.monotonic() - started:.0f} s, "
          f"mission control exit {mc.returncode} (load {os.getloadavg()[0]:.1f})")  # fmt: skip
    report = read_report(folder)
    if report:
        tasks = sorted(report["tasks"], key=lambda t: (t.get("end_s") is None, t.get("end_s") or 0.0))
        done = sum(t.get("status") == "done" for t in tasks)
        order = ", ".join(f"{t['id']} by {t.get('uav')} ({t.get('attempts')} att.)" for t in tasks)
        print(f"  completed {report.get('completed')} ({done} of {len(tasks)} tasks done), makespan "
              f"{report.get('makespan_s')} s; order: {order}")  # fmt: skip
        errors = ", ".join(f"{k} {v * 1000:.1f}" for k, v in report.get("placement_error_m", {}).items())
        built = ", ".join(
            f"{k} {p['deviation_m'] * 1000:.1f}" for k, p in (report.get("as_built") or {}).items()
        )
        print(f"  bricks (mm): placement {errors or 'none placed'}; as built {built or 'none'}")
        print(f"  conflict violations {report.get('conflict_violations')}, dependency violations "
              f"{report.get('dependency_violations')}, min separation {report.get('min_separation_m')} m")  # fmt: skip
        for t in tasks:
            if t.get("attempts", 1) > 1 or t.get("status") != "done":
                print(f"  {t['id']}: {t.get('status')} {t.get('attempts_detail')}")
    for uav, p in uavs.items():
        err = (folder / f"{uav}-fly.err").read_text()
        tuning = next((line for line in err.splitlines() if "tuning:" in line), "(no tuning line)")
        still = " (still running after mission control ended: killed)" if uav in hung else ""
        print(f"  {uav}: exit {p.returncode}{still}; {tuning.strip()}")
        if p.returncode != 0:
            print("   ", err[-1500:].replace("\n", "\n    "))


def _fleet(blueprint: Path) -> list[tuple[str, str]]:
    """The blueprint's fleet as (name, role), in its order."""
    return [(u.name, u.role) for u in load_blueprint(blueprint).fleet]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reservation", choices=("site", "task"), default="site")
    ap.add_argument(
        "--keep", type=Path, default=None, help="keep the blueprint, SITLs' folders and outputs here"
    )
    args = ap.parse_args()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        run(args.reservation, args.keep)
        return
    with tempfile.TemporaryDirectory(prefix="bond-sitl-") as tmp:
        run(args.reservation, Path(tmp))


if __name__ == "__main__":
    main()
