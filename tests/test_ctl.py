"""``masonry ctl`` against a running ``masonry mission-control`` over Zenoh: accepted, refused with a reason,
signed with the mission's key (another key gets no answer), and a command sent again is not applied twice."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import urllib.request
from pathlib import Path

import pytest
from typer.testing import CliRunner

from cli_procs import HANG_GUARD_S
from masonry.cli import app
from masonry.mission.auth import write_key_file

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
MAIN = "from masonry.cli import main; main()"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


def _ctl(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        # ends on its own (its --timeout for mission control's answer, after its imports): a hang guard only
        [sys.executable, "-c", MAIN, "ctl", *args],
        capture_output=True,
        text=True,
        timeout=HANG_GUARD_S,
        check=False,
    )


@pytest.mark.slow
def test_ctl_commands_a_running_mission_control(tmp_path):
    key = write_key_file(tmp_path / "mission.key")
    endpoint = f"tcp/127.0.0.1:{_free_port()}"
    name = f"ctl-{endpoint.rsplit(':', 1)[1]}"
    mc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            MAIN,
            "mission-control",
            str(CASE_STUDY),
            "--listen",
            endpoint,
            "--key-file",
            str(key),
            "--mission-name",
            name,
            # waiting for its fleet (never started here) for as long as the ctl commands below take, each a
            # process of its own: on a loaded machine their imports alone took up to 35 s each, so the waits are
            # the bounds' maxima, hang guards only (the test kills mission control at its end)
            "--startup-timeout",
            "3600",
            "--max-time",
            "3600",
            "--format",
            "json",
            "--serve",
            "127.0.0.1:0",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert mc.stderr is not None
        line = mc.stderr.readline()  # mission control's page, served while it waits for its fleet
        assert "serving the mission's page at http://" in line, line
        page = line.rsplit(" ", 1)[-1].strip()
        common = ["--mission", endpoint, "--key-file", str(key), "--mission-name", name]
        first = _ctl("pause", *common)
        assert (first.returncode, first.stdout) == (0, "pause: accepted\n"), first.stderr
        with urllib.request.urlopen(page + "state.json", timeout=10) as r:
            state = json.loads(r.read())
        assert state["paused"] is True and state["operator"][0].endswith("operator: pause: accepted")
        again = _ctl("pause", *common)
        assert (again.returncode, again.stdout) == (1, "pause: refused: already paused\n"), again.stderr
        ghost = _ctl("recall", "brick-9", *common)
        assert ghost.returncode == 1 and "refused" in ghost.stdout + ghost.stderr
        limit = _ctl("limit", "--role", "brick", "--limit", "1", *common)
        assert (limit.returncode, limit.stdout) == (0, "limit brick 1: accepted\n"), limit.stderr
        resume = _ctl("resume", *common)
        assert (resume.returncode, resume.stdout) == (0, "resume: accepted\n"), resume.stderr
        other = write_key_file(tmp_path / "other.key")
        forged = _ctl(
            "abort", "--mission", endpoint, "--key-file", str(other), "--mission-name", name, "--timeout", "3"
        )
        assert forged.returncode == 1 and "no answer from mission control" in forged.stderr, forged.stderr
        assert mc.poll() is None  # the forged abort did nothing: mission control still waits for its fleet
    finally:
        mc.kill()
        mc.communicate(timeout=HANG_GUARD_S)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["fly"], "COMMAND must be one of"),
        (["recall"], "recall needs the UAV"),
        (["pause", "brick-1"], "recall needs the UAV"),
        (["limit", "--role", "brick"], "limit needs --role and --limit"),
        (["pause", "--timeout", "0"], "--timeout 0: out of range"),
    ],
)
def test_ctl_bad_input_is_one_line_and_exit_2(args, message):
    res = CliRunner().invoke(app, ["ctl", *args, "--mission", "tcp/127.0.0.1:7447"])
    assert res.exit_code == 2, res.output
    assert message in res.output
