"""Issue 29's "default reservation on the real autopilot": a 2 + 1 mission on a 6-brick running bond on three
ArduCopter SITLs, default settings.

The wall (``--wall``): ``12-6`` (the default, as tests/test_ardupilot_bond.py flies it) is ``masonry blueprint
running-bond --courses 2 --bricks-per-course 6 --placed-courses 1 --brick-uavs 2 --adhesion-uavs 1``, six bricks to
lay in running bond on a course laid already (eleven beads), 1.8 m long; ``2x3`` is issue 29's first try, two courses
of three, none laid (six beads), 0.9 m long. Three ArduCopter hexacopter SITLs as the SITL tests start them
(tests/ardupilot_sitl.py: ``copter.parm`` and ``copter-hexa.parm``, ``--speedup`` 2, 10 Ah batteries as
tests/test_ardupilot_bond.py's ``BATTERY_PARAMS``; ``--instance N``: N to N + 2,
21 by default, MAVLink on TCP 5760 + 10 N), ``masonry mission-control BLUEPRINT --listen ...`` (``site``, the
default reservation, unless ``--reservation`` says otherwise) and one ``masonry fly --mission ... --actuators sim
--camera sim`` a UAV whose only configuration is ``estimate_wait_s: 150``; mission time follows the autopilots'
clocks (``--time-scale`` the speed-up until they join) and the heartbeats time out after 30 s, as in
tests/test_ardupilot_sitl.py. Prints whether the mission completed, the tasks in the order they ended (by whom,
from-to in mission seconds, attempts), each UAV's tasks, the makespan (mission time), each brick's placement error
and as-built deviation, the violations measured from the traces (mission control's report: conflicts, dependencies,
the least separation of airborne UAVs as heard, masonry.mission.heard_separation) and each UAV's exit; asserts
nothing. An adhesion task is done only with ``spray_min_coverage`` (0.9) of its bead covered.

On ``2x3`` no two sites are r_c (1.5 m) apart: the admission rule (masonry.planner.dispatch_admission: 3 UAVs for
a wall one site wide) lets one brick UAV be busy at a time, so brick-2 stays on its pad and brick-1 lays all six
(2026-12-07: 285.7 s, B2 waited 45 s for a brick UAV). ``12-6`` is two sites wide: both lay bricks.

    MASONRY_ARDUPILOT_SITL=$(realpath ../shared/sitl/arducopter) PYTHONPATH=src python \\
        benchmarks/bench_arducopter_bond.py [--wall 12-6|2x3] [--reservation site|task] [--instance N] [--keep DIR]
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
from test_ardupilot_bond import BATTERY_PARAMS

#: Wall seconds mission control may take (pre-flights, ~40 s of the autopilots' clocks to a GPS estimate, included).
MISSION_WALL_S = 1800.0
#: The walls: ``12-6`` two courses of six, the first placed (six bricks to place, 1.8 m long: two sites r_c apart),
#: ``2x3`` two courses of three, none placed (0.9 m long: every site within r_c of every other).
WALLS = {
    "12-6": ("--courses", "2", "--bricks-per-course", "6", "--placed-courses", "1"),
    "2x3": ("--courses", "2", "--bricks-per-course", "3"),
}


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def run(reservation: str, folder: Path, wall: str, first_instance: int) -> None:
    blueprint = folder / "bond.yaml"
    subprocess.run(
        [sys.executable, "-c", MAIN, "blueprint", "running-bond", *WALLS[wall], "--brick-uavs", "2",
         "--adhesion-uavs", "1", "--name", f"bond-{wall}", "-o", str(blueprint)],
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
            stack.enter_context(
                arducopter(
                    folder / uav, instance=first_instance + i, sysid=first_instance + i, params=BATTERY_PARAMS
                )
            )
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
        order = ", ".join(
            f"{t['id']} by {t.get('uav')} {t.get('start_s')}-{t.get('end_s')} s ({t.get('attempts')} att.)"
            for t in tasks
        )
        print(f"  completed {report.get('completed')} ({done} of {len(tasks)} tasks done), makespan "
              f"{report.get('makespan_s')} s; order: {order}")  # fmt: skip
        for uav, _ in _fleet(blueprint):
            mine = [f"{t['id']} {t.get('start_s')}-{t.get('end_s')}" for t in tasks if t.get("uav") == uav]
            print(f"  {uav}: {len(mine)} tasks: {', '.join(mine) or 'none'}")
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
    ap.add_argument("--wall", choices=tuple(WALLS), default="12-6", help="12-6 (default) or 2x3")
    ap.add_argument("--instance", type=int, default=21, help="the first SITL's -I (the others follow)")
    ap.add_argument(
        "--keep", type=Path, default=None, help="keep the blueprint, SITLs' folders and outputs here"
    )
    args = ap.parse_args()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        run(args.reservation, args.keep, args.wall, args.instance)
        return
    with tempfile.TemporaryDirectory(prefix="bond-sitl-") as tmp:
        run(args.reservation, Path(tmp), args.wall, args.instance)


if __name__ == "__main__":
    main()
