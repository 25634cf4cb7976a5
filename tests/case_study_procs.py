"""The case study as a mission of processes (mission control and two ``masonry fly --mission``), shared by the
SITL tests of both autopilots: starting them, reaping them, and checking what every such mission must show."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from pathlib import Path

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
MAIN = "from masonry.cli import main; main()"
#: the case study's tasks by the UAV of their kind, whatever the order
EVERY_TASK_BY_ITS_KIND = [("A0", "glue-1"), ("A1", "glue-1"), ("B0", "brick-1"), ("B1", "brick-1")]


def masonry(*args: str, own_session: bool = False) -> subprocess.Popen[str]:
    """``masonry ARGS`` as a process, its output piped; ``own_session``: in a session (and process group) of its
    own, which a test may then give a share of the CPU of its own (tests/px4_sitl.py ``give_the_cpu``)."""
    return subprocess.Popen([sys.executable, "-c", MAIN, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True, start_new_session=own_session)  # fmt: skip


def free_tcp_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def fly_mission(
    role: str,
    uav: str,
    url: str,
    endpoint: str,
    config: Path,
    *extra: str,
    own_session: bool = False,
    blueprint: str = CASE_STUDY,
) -> subprocess.Popen[str]:
    """``masonry fly --mission`` for one UAV of the case study (or of ``blueprint``), simulated actuators and
    camera, JSON out."""
    return masonry("fly", "--uav", role, "--name", uav, "--blueprint", blueprint, "--mission", endpoint,
                   "--listen", f"tcp/127.0.0.1:{free_tcp_port()}", "--fc", url, "--actuators", "sim",
                   "--camera", "sim", "--config", str(config), "--format", "json", *extra,
                   own_session=own_session)  # fmt: skip


@contextmanager
def reaped(procs: Sequence[subprocess.Popen[str]]) -> Iterator[None]:
    """Kill and wait for whichever of ``procs`` is still running when the block ends, however it ends."""
    try:
        yield
    finally:
        for p in procs:
            if p.poll() is None:
                p.kill()
                p.wait()


def check_completed(
    mc: subprocess.Popen[str], mc_out: str, mc_err: str, runs: Sequence[tuple[str, str]]
) -> tuple[dict, list[tuple[float, str, str]]]:
    """Mission control's report once it exited 0 and completed, and its tasks as (end_s, id, uav) by end."""
    assert mc.returncode == 0, mc_err[-3000:] + "".join(err[-2000:] for _, err in runs)
    report = json.loads(mc_out)
    assert report["completed"] is True
    done = sorted((t["end_s"], t["id"], t["uav"]) for t in report["tasks"])
    assert sorted((tid, uav) for _, tid, uav in done) == EVERY_TASK_BY_ITS_KIND
    return report, done
