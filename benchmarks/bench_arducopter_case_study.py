"""Issue 29's first scenario, run as written: the case study on two ArduCopter SITLs with default settings.

Two ArduCopter SITL vehicles (``-I0``, ``-I1``, quad frame, ``copter.parm``, ``--speedup 1``, as
../shared/sitl/README.md starts one), ``masonry mission-control blueprints/paper_case_study.yaml --listen
tcp/127.0.0.1:7471`` and two ``masonry fly --mission ... --fc tcp:127.0.0.1:5760|5770 --actuators sim --camera sim``
whose only configuration is ``estimate_wait_s: 150`` (no ``control_preset``). Prints whether the mission
completed, the tasks in the order they ended (by whom, attempts), the makespan (mission time), each brick's
placement error, the violations, and each UAV's exit and last lines when it failed; asserts nothing.

Usage: python benchmarks/bench_arducopter_case_study.py [--reservation site|task] [--speedup K]
       [--sitl ../shared/sitl/arducopter] [--keep DIR [--log]]

``--reservation`` is mission control's (``site``, the default, is not passed: the user's default). The masonry run
is this interpreter's (``PYTHONPATH=src`` runs a worktree's code). ``--keep DIR`` keeps the SITLs' folders and
every process's output there (``--log``: each UAV's MCAP log too, ``masonry fly --log``).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
SITL = ROOT.parent / "shared" / "sitl" / "arducopter"
HOME = "-35.363261,149.165230,584,353"
MAIN = "from masonry.cli import main; main()"
LISTEN = "tcp/127.0.0.1:7471"
#: How long (s of wall) a UAV may take to end after mission control has (its return and landing).
UAV_EXIT_S = 180.0


@contextlib.contextmanager
def _arducopter(binary: Path, workdir: Path, instance: int, speedup: int) -> Iterator[str]:
    """One ArduCopter quad SITL (README's command, ``--model quad``, ``copter.parm``); its MAVLink URL."""
    workdir.mkdir(parents=True, exist_ok=True)
    port = 5760 + 10 * instance
    log = (workdir / "sitl.log").open("w")
    proc = subprocess.Popen(
        [str(binary), "--model", "quad", "--speedup", str(speedup), f"-I{instance}", "--sysid", str(instance + 1),
         "-w", "--defaults", str(binary.parent / "copter.parm"), "--home", HOME],
        cwd=workdir, stdout=log, stderr=subprocess.STDOUT, start_new_session=True,
    )  # fmt: skip
    try:
        deadline = time.monotonic() + 20.0
        while True:  # the port opens once it has started (it boots on the first connection)
            with socket.socket() as s:
                if s.connect_ex(("127.0.0.1", port)) == 0:
                    break
            if proc.poll() is not None or time.monotonic() > deadline:
                raise RuntimeError(f"SITL -I{instance} did not open TCP {port}: see {workdir / 'sitl.log'}")
            time.sleep(0.1)
        yield f"tcp:127.0.0.1:{port}"
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=10)
        log.close()


def masonry_process(out: Path, *args: str) -> subprocess.Popen[bytes]:
    """`masonry ARGS` in its own process group, its stdout and stderr to OUT.out and OUT.err."""
    return subprocess.Popen(
        [sys.executable, "-c", MAIN, *args],
        stdout=(out.with_suffix(".out")).open("wb"),
        stderr=(out.with_suffix(".err")).open("wb"),
        start_new_session=True,
    )


def reap(
    mc: subprocess.Popen[bytes], uavs: dict[str, subprocess.Popen[bytes]], mission_wall_s: float
) -> list[str]:
    """Wait for mission control (at most `mission_wall_s`), then each UAV up to UAV_EXIT_S after it; kill the rest.

    Returns the UAVs still running UAV_EXIT_S after mission control ended (killed).
    """
    hung: list[str] = []
    try:
        mc.wait(timeout=mission_wall_s)
        ended_s = time.monotonic()
        for uav, p in uavs.items():
            try:
                p.wait(timeout=max(0.0, ended_s + UAV_EXIT_S - time.monotonic()))
            except subprocess.TimeoutExpired:
                hung.append(uav)
    finally:
        for p in [mc, *uavs.values()]:
            if p.poll() is None:
                with contextlib.suppress(ProcessLookupError):
                    os.killpg(p.pid, signal.SIGKILL)
                p.wait()
    return hung


def _busy_ports() -> list[int]:
    """The ports of this scenario something already listens on (another run of it, a developer's SITL)."""
    busy = []
    for port in (5760, 5770, int(LISTEN.rsplit(":", 1)[1])):
        with socket.socket() as s:
            if s.connect_ex(("127.0.0.1", port)) == 0:
                busy.append(port)
    return busy


def read_report(folder: Path) -> dict:
    """Mission control's JSON report in FOLDER, or {} after printing the end of its stderr when there is none."""
    try:
        return dict(json.loads((folder / "mission-control.out").read_text()))
    except json.JSONDecodeError:
        print("  no report; mission control's stderr ends:")
        print("   ", (folder / "mission-control.err").read_text()[-2000:].replace("\n", "\n    "))
        return {}


def run(reservation: str, speedup: int, binary: Path, folder: Path, log: bool = False) -> None:
    busy = _busy_ports()
    if busy:  # the fixed ports: a second run beside one would join the other's vehicles and mission
        raise SystemExit(f"ports {', '.join(map(str, busy))} are in use: another run (or SITL) is on them")
    config = folder / "uav.yaml"
    config.write_text("estimate_wait_s: 150\n")
    started = time.monotonic()
    with (
        _arducopter(binary, folder / "sitl-0", 0, speedup) as brick_url,
        _arducopter(binary, folder / "sitl-1", 1, speedup) as glue_url,
    ):
        mc_args = ["mission-control", str(CASE_STUDY), "--listen", LISTEN, "--format", "json"]
        if reservation != "site":
            mc_args += ["--reservation", reservation]
        mc = masonry_process(folder / "mission-control", *mc_args)
        uavs = {}
        for role, uav, url in (("brick", "brick-1", brick_url), ("adhesion", "glue-1", glue_url)):
            uavs[uav] = masonry_process(folder / uav, "fly", "--uav", role, "--name", uav, "--blueprint", str(CASE_STUDY),
                                 "--mission", LISTEN, "--fc", url, "--actuators", "sim", "--camera", "sim",
                                 "--config", str(config), "--format", "json",
                                 *(["--log", str(folder / f"{uav}.mcap")] if log else []))  # fmt: skip
        hung = reap(mc, uavs, mission_wall_s=1800.0)
    wall_s = time.monotonic() - started
    print(
        f"reservation {reservation}, speedup {speedup}: wall {wall_s:.0f} s, mission control exit {mc.returncode}"
    )
    report = read_report(folder)
    if report:
        tasks = sorted(report["tasks"], key=lambda t: (t.get("end_s") is None, t.get("end_s") or 0.0))
        order = ", ".join(f"{t['id']} by {t.get('uav')} ({t.get('attempts')} att.)" for t in tasks)
        errors = ", ".join(f"{k} {v * 100:.2f} cm" for k, v in report.get("placement_error_m", {}).items())
        print(f"  completed {report.get('completed')}, makespan {report.get('makespan_s')} s; order: {order}")
        print(f"  bricks: {errors or 'none placed'}; min separation {report.get('min_separation_m')} m")
        print(
            f"  conflict violations {report.get('conflict_violations')}, "
            f"dependency violations {report.get('dependency_violations')}"
        )
        for t in report["tasks"]:
            if t.get("attempts", 1) > 1 or t.get("status") not in (None, "done"):
                print(f"  {t['id']}: {t.get('attempts_detail')}")
    for uav, p in uavs.items():
        err = (folder / uav).with_suffix(".err").read_text()
        tuning = next((line for line in err.splitlines() if "tuning:" in line), "(no tuning line)")
        still = (
            f" (still running {UAV_EXIT_S:.0f} s after mission control ended: killed)" if uav in hung else ""
        )
        print(f"  {uav}: exit {p.returncode}{still}; {tuning.strip()}")
        if p.returncode != 0:
            print("   ", err[-1500:].replace("\n", "\n    "))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reservation", choices=("site", "task"), default="site")
    ap.add_argument("--speedup", type=int, default=1)
    ap.add_argument("--sitl", type=Path, default=Path(os.environ.get("MASONRY_ARDUPILOT_SITL") or SITL))
    ap.add_argument("--keep", type=Path, default=None)
    ap.add_argument(
        "--log", action="store_true", help="with --keep: each UAV's MCAP log (fly --log) there too"
    )
    args = ap.parse_args()
    if args.keep is not None:
        args.keep.mkdir(parents=True, exist_ok=True)
        run(args.reservation, args.speedup, args.sitl, args.keep, args.log)
        return
    with tempfile.TemporaryDirectory(prefix="case-study-sitl-") as tmp:
        run(args.reservation, args.speedup, args.sitl, Path(tmp))


if __name__ == "__main__":
    main()
