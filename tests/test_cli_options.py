"""Commands and options: option ranges, help text, --version, "wrote FILE", plurals,
the progress line, the estimator wait of ``fly --fc`` and diagrams without a system graphviz."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner
from typing_extensions import Self

from masonry.cli import app
from masonry.cli.options import RANGES, Bound, bound, check, plural

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = str(ROOT / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()


def one_line_exit_2(res, *needles: str) -> None:
    assert res.exit_code == 2, (res.exit_code, res.output)
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert "Traceback" not in res.output
    for needle in needles:
        assert needle in lines[0], (needle, lines[0])


# ------------------------------------------------------------------------------------------------ bounds


@pytest.mark.parametrize(
    ("argv", "needles"),
    [
        (["sim", CASE_STUDY, "--dt", "1e-6"], ["--dt 1e-06", "0.001 to 0.2 s"]),
        (["sim", CASE_STUDY, "--dt", "nan"], ["--dt nan"]),
        (["sim", CASE_STUDY, "--brick-uavs", "100000"], ["--brick-uavs 100000", "0 to 100"]),
        (["sim", CASE_STUDY, "--seed", "-1"], ["--seed -1"]),
        (["sim", CASE_STUDY, "--fault", "gusts=1e6"], ["gusts", "at most 15 m/s"]),
        (["sim", CASE_STUDY, "--fault", "battery=5"], ["battery", "at most 1 per second"]),
        (["sim", CASE_STUDY, "--wind", "fast"], ["--wind 'fast'", "SPEED[@DIR_DEG]"]),
        (["sim", CASE_STUDY, "--wind", "40@90"], ["--wind '40@90'", "0 to 30 m/s"]),
        (["sim", CASE_STUDY, "--turbulence", "strong"], ["--turbulence 'strong'", "light, moderate, severe"]),
        (
            ["sim", CASE_STUDY, "--turbulence", "light", "--fault", "gusts=1"],
            ["--turbulence light", "gusts=1", "one of the two"],
        ),
        (
            ["fly", "--uav", "brick", "--sim", "--blueprint", CASE_STUDY, "--task", "B0", "--wind", "4@"],
            ["--wind '4@'", "direction"],
        ),
        (
            [
                "fly",
                "--uav",
                "brick",
                "--sim",
                "--blueprint",
                CASE_STUDY,
                "--mission",
                "tcp/127.0.0.1:1",
                "--wait",
                "-1",
            ],
            ["--wait -1", "> 0 to 3600 s"],
        ),
        (
            ["fly", "--uav", "brick", "--sim", "--blueprint", CASE_STUDY, "--task", "B0", "--dt", "1e-6"],
            ["--dt 1e-06"],
        ),
        (
            ["fly", "--uav", "brick", "--sim", "--blueprint", CASE_STUDY, "--task", "B0", "--timeout", "1e9"],
            ["--timeout 1e+09"],
        ),
        (
            [
                "fly",
                "--uav",
                "brick",
                "--blueprint",
                CASE_STUDY,
                "--task",
                "B0",
                "--fc",
                "udpin:127.0.0.1:1",
                "--estimate-wait",
                "0",
            ],
            ["--estimate-wait 0"],
        ),
        (["mission-control", CASE_STUDY, "--heartbeat-timeout", "0"], ["--heartbeat-timeout 0"]),
        (["mission-control", CASE_STUDY, "--startup-timeout", "-5"], ["--startup-timeout -5"]),
        (["mission-control", CASE_STUDY, "--max-time", "0"], ["--max-time 0"]),
        (["mission-control", CASE_STUDY, "--tick", "1e-6"], ["--tick 1e-06"]),
        (
            ["blueprint", "towers", "--height", "3", "--placed-courses", "5"],
            ["--placed-courses 5", "more than the wall's 3 courses"],
        ),
        (["blueprint", "running-bond", "--courses", "4", "--placed-courses", "7"], ["--placed-courses 7"]),
        (["blueprint", "running-bond", "--brick-uavs", "100000"], ["--brick-uavs 100000", "1 to 100"]),
        (
            ["blueprint", "running-bond", "--courses", "1000", "--bricks-per-course", "1000"],
            ["1000000 bricks"],
        ),
        (["blueprint", "pyramid", "--base", "0"], ["--base 0"]),
        (["blueprint", "towers", "--brick-size", "0.3", "0", "0.1"], ["--brick-size 0.3 0 0.1"]),
        (["blueprint", "towers", "--origin", "1e9", "0"], ["--origin 1e+09 0"]),
        (["blueprint", "towers", "--spacing", "-1"], ["--spacing -1"]),
        (["markers", "--bricks", "0-3", "-o", "m.pdf", "--marker-size", "5"], ["--marker-size 5"]),
        (["markers", "--bricks", "0-100000000", "-o", "m.pdf"], ["more than 100000 bricks"]),
        (["estimate", "--camera", "-3", "--intrinsics", "600,600,320,240"], ["--camera -3"]),
        (["calibrate", "x.png", "--board", "chessboard:100000x6:0.02", "-o", "c.yaml"], ["at most 100x100"]),
        (["sitl", "--seed", "-2"], ["--seed -2"]),
        (["sitl", "--port", "70000"], ["--port 70000"]),
    ],
)
def test_an_option_out_of_range_is_one_line_and_exit_2(argv, needles, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    one_line_exit_2(runner.invoke(app, argv), *needles)


def test_every_range_is_well_formed_and_shown_in_help():
    for key, b in RANGES.items():
        assert key.split()[-1].startswith("--") and b.low < b.high, key
    assert bound("sim", "--dt") != bound("fly", "--dt")  # a command's own range wins over the shared one
    assert bound("towers", "--seed") == bound("sim", "--seed")
    with pytest.raises(KeyError):
        bound("sim", "--no-such-option")
    res = runner.invoke(app, ["sim", "--help"], env={"COLUMNS": "200"})
    assert "Range 0.001 to 0.2 s." in res.stdout
    res = runner.invoke(app, ["fly", "--help"], env={"COLUMNS": "200"})
    assert "--estimate-wait" in res.stdout and "Range > 0 to 600 s." in res.stdout


def test_check_accepts_the_ends_of_a_range_and_names_what_is_wrong():
    check("sim", "--dt", 0.001)
    check("sim", "--dt", 0.2)
    check("fly", "--wait", 3600.0)
    check("fly", "--wait", None)
    with pytest.raises(Exception, match=r"--wait 0: out of range, expected > 0 to 3600 s"):
        check("fly", "--wait", 0.0)
    assert Bound(0, 1, "m").text() == "0 to 1 m" and Bound(0.0, 2.5, low_open=True).text() == "> 0 to 2.5"


def test_values_inside_the_ranges_still_work(tmp_path):
    out = tmp_path / "t.yaml"
    res = runner.invoke(
        app,
        [
            "blueprint",
            "towers",
            "--height",
            "3",
            "--placed-courses",
            "3",
            "--brick-size",
            "0.3",
            "0.15",
            "0.1",
            "--origin",
            "1",
            "2",
            "-o",
            str(out),
        ],
    )
    assert res.exit_code == 0, res.output
    assert "--brick-size 0.3 0.15 0.1" in out.read_text()


# -------------------------------------------------------------------------------------------------- help


def test_help_shows_flags_without_a_value_and_repeatable_options_by_their_form():
    res = runner.invoke(app, ["sim", "--help"], env={"COLUMNS": "200"})
    assert res.exit_code == 0
    resume = next(line for line in res.stdout.splitlines() if "--resume" in line)
    assert "<bool>" not in resume and "Continue the mission" in resume
    fault = next(line for line in res.stdout.splitlines() if "--fault" in line)
    assert "KEY=VALUE" in fault and "list[" not in fault
    assert "<bool>" not in res.stdout and "list[str]" not in res.stdout
    res = runner.invoke(app, ["mission-control", "--help"], env={"COLUMNS": "200"})
    assert "list[str]" not in res.stdout and "<bool>" not in res.stdout
    res = runner.invoke(app, ["calibrate", "--help"], env={"COLUMNS": "200"})  # a list argument
    assert "images..." in res.stdout and "list[" not in res.stdout and "<path>" in res.stdout


def test_brick_size_help_shows_the_form_it_accepts():
    res = runner.invoke(app, ["blueprint", "towers", "--help"], env={"COLUMNS": "200"})
    line = next(line for line in res.stdout.splitlines() if "--brick-size" in line)
    assert "float,float,float" not in line and "L W H" in line and "separated by spaces" in line


def test_fsm_diagram_help_keeps_conditions_in_brackets():
    res = runner.invoke(app, ["fsm", "diagram", "--help"], env={"COLUMNS": "200"})
    assert "[conditions]" in res.stdout


def test_version():
    from importlib.metadata import version

    res = runner.invoke(app, ["--version"])
    assert res.exit_code == 0 and res.stdout.strip() == f"masonry {version('masonry')}"


def test_plural():
    assert (
        plural(1, "task") == "1 task"
        and plural(0, "task") == "0 tasks"
        and plural(2, "pass", "passes") == "2 passes"
    )


def test_plan_summary_says_1_task_and_lists_the_longest_chain_in_execution_order(tmp_path):
    bp = tmp_path / "t.yaml"
    assert (
        runner.invoke(
            app,
            ["blueprint", "towers", "--towers", "1", "--height", "2", "--placed-courses", "1", "-o", str(bp)],
        ).exit_code
        == 0
    )
    res = runner.invoke(app, ["plan", str(bp)])
    assert res.exit_code == 0, res.output
    assert "dependencies    2 edges in G^d" in res.stdout
    # A0 (the glue on brick 0) must be done before B1 goes on top of it
    assert "longest chain   2 tasks: A0 -> B1" in res.stdout
    one = tmp_path / "one.yaml"
    assert (
        runner.invoke(
            app, ["blueprint", "towers", "--towers", "1", "--height", "1", "-o", str(one)]
        ).exit_code
        == 0
    )
    res = runner.invoke(app, ["plan", str(one)])
    assert "longest chain   1 task: B0" in res.stdout and "0 pairs in G^c" in res.stdout
    res = runner.invoke(
        app,
        [
            "blueprint",
            "towers",
            "--towers",
            "1",
            "--height",
            "1",
            "--brick-uavs",
            "1",
            "--adhesion-uavs",
            "1",
            "-o",
            str(one),
        ],
    )
    assert f"wrote {one}: 1 brick (1 to place), 2 UAVs" in res.stderr
    res = runner.invoke(app, ["sim", str(one)])
    assert res.exit_code == 0, res.output
    assert "mission completed: 1/1 task, " in res.stdout


def test_every_command_that_writes_a_file_says_so(tmp_path):
    report, gantt, plot = tmp_path / "r.json", tmp_path / "g.svg", tmp_path / "p.png"
    res = runner.invoke(
        app,
        [
            "sim",
            CASE_STUDY,
            "--report",
            str(report),
            "--gantt",
            str(gantt),
            "--plot3d",
            str(plot),
            "--format",
            "json",
        ],
    )
    assert res.exit_code == 0, res.output
    for p in (report, gantt, plot):
        assert f"wrote {p}" in res.stderr and p.exists()
    assert "wrote" not in res.stdout  # stdout stays the JSON report
    out, graph = tmp_path / "plan.json", tmp_path / "plan.dot"
    res = runner.invoke(app, ["plan", CASE_STUDY, "--format", "json", "-o", str(out), "--graph", str(graph)])
    assert res.exit_code == 0, res.output
    assert f"wrote {out}" in res.stderr and f"wrote {graph}" in res.stderr
    res = runner.invoke(app, ["markers", "--bricks", "0", "-o", str(tmp_path / "m.png"), "--dpi", "60"])
    assert res.exit_code == 0, res.output
    assert "1 brick, markers 0..1" in res.stdout and re.search(r"wrote .*m\.png", res.stdout)


# ---------------------------------------------------------------------------------------------- progress


class FakeClock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def test_progress_lines_come_every_few_seconds_with_an_eta():
    import io

    from masonry.cli.progress import ProgressLines

    clock, out = FakeClock(), io.StringIO()
    lines = ProgressLines(out, interval_s=5.0, clock=clock)
    lines(0, 10, 0.0)
    clock.t += 4.9
    lines(0, 10, 30.0)
    assert out.getvalue() == ""  # not yet 5 s
    clock.t += 0.1
    lines(0, 10, 31.0)
    assert out.getvalue() == "sim: 0/10 tasks done, simulated 31 s, 5 s elapsed, ETA unknown\n"
    clock.t += 1.0
    lines(2, 10, 60.0)  # 1 s after the last line: nothing
    clock.t += 119.0  # 125 s in, 2 of 10 done: 62.5 s a task, 8 to go -> 500 s
    lines(2, 10, 400.0)
    assert (
        out.getvalue().splitlines()[-1]
        == "sim: 2/10 tasks done, simulated 400 s, 2 min 05 s elapsed, ETA 8 min 20 s"
    )


def test_progress_display_picks_bar_lines_or_nothing():
    from masonry.cli.progress import ProgressLines, progress_display

    assert isinstance(progress_display(None, stderr_tty=False)[0], ProgressLines)
    assert isinstance(progress_display(True, stderr_tty=True)[0], ProgressLines)
    assert progress_display(False, stderr_tty=False)[0] is None
    bar, finish = progress_display(None, stderr_tty=True)
    assert bar is not None and not isinstance(bar, ProgressLines)
    finish()


def test_sim_without_a_terminal_prints_progress_lines_on_stderr_never_stdout(monkeypatch):
    import json

    from masonry.cli import progress

    monkeypatch.setattr(progress, "LINE_INTERVAL_S", 0.0)  # every call prints: no need to wait for seconds
    res = runner.invoke(app, ["sim", CASE_STUDY, "--format", "json"])
    assert res.exit_code == 0, res.output
    json.loads(res.stdout)  # stdout is the report alone
    lines = [line for line in res.stderr.splitlines() if line.startswith("sim: ")]
    assert len(lines) > 4 and lines[-1].startswith("sim: 4/4 tasks done") and "ETA 0 s" in lines[-1]
    # between completions too (at least once per simulated second): more lines than the 4 completions
    res = runner.invoke(app, ["sim", CASE_STUDY, "--no-progress"])
    assert res.exit_code == 0 and "sim: " not in res.stderr


# ------------------------------------------------------------------------------------------ fsm diagram


@pytest.mark.parametrize("kind", ["brick", "adhesion"])
def test_fsm_diagram_renders_svg_and_png_without_graphviz(kind, tmp_path, monkeypatch):
    import xml.etree.ElementTree as ET

    from masonry.fsm import diagram
    from masonry.fsm.states import MACHINES

    monkeypatch.setattr(diagram.shutil, "which", lambda name: None)  # a machine without Debian's graphviz
    monkeypatch.setenv("PATH", str(tmp_path))
    svg, png = tmp_path / f"{kind}.svg", tmp_path / f"{kind}.png"
    for out in (svg, png):
        res = runner.invoke(app, ["fsm", "diagram", kind, "-o", str(out)])
        assert res.exit_code == 0, res.output
        assert res.stdout.strip() == f"wrote {out}"
    assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and png.stat().st_size > 10_000
    root = ET.parse(svg).getroot()  # well-formed XML
    assert root.tag.endswith("svg")
    texts = {"".join(t.itertext()).strip() for t in root.iter() if t.tag.endswith("text")}
    states, transitions = MACHINES[kind]
    for state in states:  # every state (and every nested state's children) is named in the drawing
        assert state["name"] in texts, state["name"]
        for child in state.get("children", []):
            assert child["name"] in texts
    for t in transitions:
        assert any(t["trigger"] in text for text in texts), t["trigger"]
    assert any("[has_next_task]" in text for text in texts)  # conditions shown, as graphviz shows them


def test_write_diagram_engines(tmp_path, monkeypatch):
    from masonry.fsm import diagram

    assert diagram.write_diagram("brick", tmp_path / "b.dot") == "text"
    assert diagram.write_diagram("brick", tmp_path / "b.svg", engine="builtin") == "builtin"
    monkeypatch.setattr(diagram.shutil, "which", lambda name: None)
    assert diagram.write_diagram("adhesion", tmp_path / "a.png") == "builtin"
    with pytest.raises(FileNotFoundError):
        diagram.write_diagram("brick", tmp_path / "b.png", engine="dot")
    with pytest.raises(ValueError, match="unknown diagram engine"):
        diagram.write_diagram("brick", tmp_path / "b.png", engine="neato")


# ------------------------------------------------------------------------- fly --fc: the estimator wait


class ScriptedAutopilot:
    """A MAVLink peer on loopback that plays an ArduCopter's boot: heartbeats only ("booting"), then
    LOCAL_POSITION_NED with EKF flags that are not yet usable ("converging"), then a usable EKF ("ready")."""

    BAD_FLAGS = 1 | 128 | 1024  # attitude only, constant-position mode, not initialised
    GOOD_FLAGS = 1 | 2 | 4 | 8 | 32

    def __init__(self, port: int) -> None:
        import threading

        from masonry.adapters.mavlink import mavutil_module

        self.phase = "booting"
        self.peer = mavutil_module().mavlink_connection(
            f"udpout:127.0.0.1:{port}", source_system=1, source_component=1
        )
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._t0 = 0.0

    def __enter__(self) -> Self:
        import time

        self._t0 = time.monotonic()
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._thread.join()
        self.peer.close()

    def _run(self) -> None:
        import time

        mav = self.peer.mav
        while not self._stop.is_set():
            boot_ms = int((time.monotonic() - self._t0) * 1000)
            mav.heartbeat_send(2, 3, 0, 0, 3)  # quadrotor, ArduPilot, disarmed, standby
            mav.sys_status_send(0, 0, 0, 500, 12600, -1, 80, 0, 0, 0, 0, 0, 0)
            mav.attitude_send(
                boot_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
            )  # "ArduPilot Ready": attitude comes first
            if self.phase != "booting":
                mav.local_position_ned_send(boot_ms, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
                flags = self.GOOD_FLAGS if self.phase == "ready" else self.BAD_FLAGS
                mav.ekf_status_report_send(flags, 0.1, 0.1, 0.1, 0.1, 0.0)
            while self.peer.recv_msg() is not None:
                pass
            self._stop.wait(0.05)


def _controller(port: int):
    from masonry.adapters.mavlink import MavlinkFlightController

    return MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=0.5, command_timeout_s=0.1)


def test_the_estimate_wait_counts_down_what_it_sees_until_the_ekf_is_ready():
    import threading

    from masonry.adapters.sitl import free_udp_port

    port = free_udp_port()
    lines: list[str] = []
    with ScriptedAutopilot(port) as autopilot:
        fc = _controller(port)
        try:
            fc.connect()

            # the boot moves on once the countdown has said each phase twice (events, not wall-clock steps: under
            # load a half-second phase could pass between two reports); each wait is bounded
            seen = {"no local position": threading.Event(), "local position streaming": threading.Event()}

            def progress(line: str) -> None:
                lines.append(line)
                for phrase, event in seen.items():
                    if sum(phrase in said for said in lines) >= 2:
                        event.set()

            def play() -> None:
                seen["no local position"].wait(4.0)
                autopilot.phase = "converging"
                seen["local position streaming"].wait(4.0)
                autopilot.phase = "ready"

            player = threading.Thread(target=play)
            player.start()
            fc.wait_for_estimate(20.0, progress=progress, report_every_s=0.2)
            player.join()
        finally:
            fc.close()
    assert lines, "no countdown"
    assert lines[0].startswith("waiting for the position estimate: no local position yet (LOCAL_POSITION_NED")
    converging = [line for line in lines if "local position streaming" in line]
    assert converging, lines
    assert (
        "EKF flags 0x0481: missing horizontal velocity, vertical velocity, relative horizontal position, "
        "vertical position; constant-position mode, not initialised"
    ) in converging[0]
    left = [float(re.search(r"\((\d+) s left\)", line).group(1)) for line in lines]
    assert left == sorted(left, reverse=True) and left[0] in (19.0, 20.0)  # a countdown
    assert len(lines) >= 4  # repeated every 0.2 s while nothing changes, not only on changes


@pytest.mark.parametrize(
    ("phase", "missing"),
    [
        ("booting", "no local position yet (LOCAL_POSITION_NED not streaming)"),
        ("converging", "local position streaming, EKF flags 0x0481: missing horizontal velocity"),
    ],
)
def test_the_estimate_wait_error_names_what_was_missing(phase, missing):
    from masonry.adapters.sitl import free_udp_port
    from masonry.errors import CommandRejected

    port = free_udp_port()
    with ScriptedAutopilot(port) as autopilot:
        autopilot.phase = phase
        fc = _controller(port)
        try:
            fc.connect()
            with pytest.raises(CommandRejected) as info:
                fc.wait_for_estimate(0.6)
        finally:
            fc.close()
    reason = info.value.reason
    assert reason.startswith(f"no usable position estimate from the autopilot after 0.6 s: {missing}"), reason
    assert "`estimate_timeout_s`" in reason and "motion capture" not in reason  # no motion capture configured
    from masonry.cli.app import cli_message

    assert "give more with --estimate-wait;" in cli_message(info.value)  # the CLI names its flag


def test_fly_fc_waits_estimate_wait_seconds_with_a_visible_countdown(tmp_path):
    from masonry.adapters.sitl import free_udp_port
    from masonry.adapters.wiring import HardwareConfig

    assert HardwareConfig().estimate_wait_s == 90.0  # enough for ArduPilot SITL (~40 s) and a cold Pixhawk
    port = free_udp_port()
    with ScriptedAutopilot(port):
        res = runner.invoke(
            app,
            [
                "fly",
                "--uav",
                "brick",
                "--blueprint",
                CASE_STUDY,
                "--task",
                "B0",
                "--fc",
                f"udpin:127.0.0.1:{port}",
                "--estimate-wait",
                "0.5",
            ],
        )
    assert res.exit_code == 1, res.output
    assert "waiting for the position estimate: no local position yet" in res.stderr
    assert "s left)" in res.stderr
    assert (
        "[FAIL] position estimate: no usable position estimate from the autopilot after 0.5 s: no local "
        "position yet"
    ) in res.stderr
    assert "motion capture" not in res.stderr.splitlines()[-1]
