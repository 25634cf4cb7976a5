"""The live web view: its server's routes, the pacing of a served simulation, and the page in a real browser
(Debian's chromium, driven by Playwright with that binary: no browser download)."""

from __future__ import annotations

import json
import shutil
import signal
import subprocess
import sys
import urllib.error
import urllib.request
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.errors import InputError
from masonry.mission.events import MissionEvent
from masonry.mission.view import MissionView, wall_layout
from masonry.observe.web import Pacer, ViewServer, parse_serve, static_file
from masonry.planner import plan as make_plan

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
MAIN = "from masonry.cli import main; main()"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")


def _get(url: str) -> tuple[int, bytes, str]:
    try:
        with urllib.request.urlopen(url, timeout=10) as r:
            return r.status, r.read(), r.headers.get("Content-Type", "")
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read(), exc.headers.get("Content-Type", "")


def _post(url: str, body: bytes) -> tuple[int, dict]:
    req = urllib.request.Request(url, data=body, headers={"Content-Type": "application/json"}, method="POST")
    try:
        with urllib.request.urlopen(req, timeout=10) as r:
            return r.status, json.loads(r.read())
    except urllib.error.HTTPError as exc:
        return exc.code, json.loads(exc.read())


@pytest.mark.parametrize(
    ("text", "expected"),
    [("8080", ("127.0.0.1", 8080)), ("0.0.0.0:9000", ("0.0.0.0", 9000)), ("[::1]:80", ("::1", 80))],
)
def test_serve_is_host_and_port(text, expected):
    assert parse_serve(text) == expected


@pytest.mark.parametrize("bad", ["http", "host:", "70000", "1.2.3.4:-1"])
def test_a_bad_serve_is_refused(bad):
    with pytest.raises(InputError, match="`serve`"):
        parse_serve(bad)


def test_the_cli_names_the_flag_of_a_bad_serve_and_of_a_port_in_use():
    import socket

    from typer.testing import CliRunner

    from masonry.cli import app

    res = CliRunner().invoke(app, ["sim", str(CASE_STUDY), "--serve", "http"])
    assert res.exit_code == 2 and "--serve 'http': give [HOST:]PORT" in res.output, res.output
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = CliRunner().invoke(
            app, ["sim", str(CASE_STUDY), "--serve", f"127.0.0.1:{port}", "--no-progress"]
        )
    assert res.exit_code == 2 and f"--serve 127.0.0.1:{port}: cannot listen" in res.output, res.output


def test_the_pacer_keeps_mission_time_at_the_time_scale_of_the_wall():
    wall = [100.0]
    slept: list[float] = []

    def sleep(s: float) -> None:
        slept.append(s)
        wall[0] += s

    pace = Pacer(4.0, monotonic=lambda: wall[0], sleep=sleep)
    pace(10.0)  # the anchor
    pace(12.0)  # 2 mission seconds = 0.5 wall seconds ahead
    assert slept == [pytest.approx(0.5)]
    wall[0] += 3.0  # the machine was slow: no sleep, no catching up by sleeping less later
    pace(13.0)
    assert len(slept) == 1
    pace(40.0)  # mission 30 s after the anchor = wall 107.5; the wall reads 103.5
    assert slept[-1] == pytest.approx(4.0)
    with pytest.raises(InputError):
        Pacer(0.0)


def test_the_server_routes(tmp_path):
    bp = load_blueprint(CASE_STUDY)
    plan = make_plan(bp)
    view = MissionView([t.id for t in plan.tasks if not t.done])
    view.emit(MissionEvent(1.0, "assigned", "glue-1", "A0", {"attempt": 1}))
    asked = []
    server = ViewServer(
        "127.0.0.1",
        0,
        layout=wall_layout(plan, bp.fleet, "case"),
        state=lambda t: {**view.snapshot(), "asked_at": t},
        version=lambda: view.events,
        commands=lambda c: asked.append(c) or {"accepted": False, "reason": "test"},
    )
    with server:
        base = server.url
        status, body, kind = _get(base)
        assert status == 200 and b'<svg id="top"' in body and kind.startswith("text/html")
        assert _get(base + "static/app.js")[1] == static_file("app.js")
        assert _get(base + "static/../pyproject.toml")[0] == 404
        layout = json.loads(_get(base + "layout.json")[1])
        assert layout["name"] == "case" and layout["commands"] is True and layout["replay_s"] is None
        assert {t["id"] for t in layout["tasks"]} == {t.id for t in plan.tasks}
        state = json.loads(_get(base + "state.json")[1])
        assert (
            state["tasks"]["A0"] == "running"
            and state["counts"]["running"] == 1
            and state["asked_at"] is None
        )
        assert json.loads(_get(base + "state.json?at=12.5")[1])["asked_at"] == 12.5
        assert _get(base + "state.json?at=soon")[0] == 400
        assert _get(base + "nope")[0] == 404
        assert _post(base + "command", b'{"command": "pause"}') == (
            200,
            {"accepted": False, "reason": "test"},
        )
        assert asked == [{"command": "pause"}]
        assert _post(base + "command", b"[1]")[0] == 400
        with urllib.request.urlopen(base + "events", timeout=10) as stream:
            first = [stream.readline() for _ in range(2)]
        assert (
            first[0] == b"event: state\n" and json.loads(first[1][len(b"data: ") :])["counts"]["running"] == 1
        )


def test_a_server_without_commands_refuses_them():
    with ViewServer("127.0.0.1", 0, layout={}, state=lambda t: {}, version=lambda: 0) as server:
        assert _post(server.url + "command", b'{"command": "abort"}')[0] == 403


@pytest.mark.slow
def test_the_page_of_a_served_sim_fills_up_in_chromium(tmp_path):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium; .ci/run does it where it can)")
    from playwright.sync_api import sync_playwright

    proc = subprocess.Popen(
        [
            sys.executable,
            "-c",
            MAIN,
            "sim",
            str(CASE_STUDY),
            "--serve",
            "127.0.0.1:0",
            "--time-scale",
            "8",
            "--no-progress",
            "--format",
            "json",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stderr is not None
        line = (
            proc.stderr.readline()
        )  # the first line names the page (bounded: the process prints it or dies)
        assert "serving the mission's page at http://" in line, line
        url = line.rsplit(" ", 1)[-1].strip()
        with sync_playwright() as p:
            browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
            page = browser.new_page(viewport={"width": 1400, "height": 1000})
            errors: list[str] = []
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.goto(url)
            page.wait_for_selector("#side rect", timeout=30_000)
            placed_before = page.locator("#side rect.done").count()
            done_before = int(page.get_attribute("#counts", "data-done") or 0)
            assert done_before < 4
            # the operator pauses it and resumes it from the page
            page.click("button[data-command=pause]")
            page.wait_for_function("document.getElementById('answer').textContent === 'pause: accepted'")
            page.wait_for_function("document.getElementById('status').textContent === 'paused'")
            page.click("button[data-command=pause]")
            page.wait_for_function(
                "document.getElementById('answer').textContent === 'pause: refused (already paused)'"
            )
            page.click("button[data-command=resume]")
            page.wait_for_function("document.getElementById('answer').textContent === 'resume: accepted'")
            # the task counter rises to every task done, the side view's wall fills up with placed bricks
            page.wait_for_function("document.getElementById('counts').dataset.done === '4'", timeout=120_000)
            assert page.locator("#side rect.done").count() > placed_before
            assert "4/4 done" in page.inner_text("#counts")
            assert page.locator("#gantt rect.bar.done").count() >= 4
            assert page.locator("#uavs tbody tr").count() == 2
            page.wait_for_function(
                "document.getElementById('status').textContent === 'completed'", timeout=30_000
            )
            shot = tmp_path / "page.png"
            page.screenshot(path=str(shot), full_page=True)
            browser.close()
        # the UAVs land, the report is printed, then the page stays up (until Ctrl-C)
        while line and "its page stays up" not in line:
            line = proc.stderr.readline()
        assert "its page stays up" in line
        assert shot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert errors == []
    finally:
        proc.send_signal(signal.SIGINT)  # the page stays up after the mission until Ctrl-C
        out, err = proc.communicate(timeout=30)
    assert proc.returncode == 0, err
    report = json.loads(out)
    assert report["completed"] is True
    assert report["conflict_violations"] == 0 and report["dependency_violations"] == 0


def test_replay_serves_the_log_with_its_time_slider(tmp_path):
    from typer.testing import CliRunner

    from masonry.cli import app

    log = tmp_path / "run.mcap"
    res = CliRunner().invoke(
        app, ["sim", str(CASE_STUDY), "--log", str(log), "--no-progress", "--format", "json"]
    )
    assert res.exit_code == 0, res.output
    proc = subprocess.Popen(
        [sys.executable, "-c", MAIN, "replay", str(log), "--serve", "127.0.0.1:0"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert proc.stderr is not None
        line = proc.stderr.readline()
        assert f"playing {log} back at http://" in line, line
        url = line.split(" at ", 1)[1].split(" ", 1)[0]
        layout = json.loads(_get(url + "layout.json")[1])
        assert layout["replay_s"] > 80 and layout["commands"] is False
        start = json.loads(_get(url + "state.json?at=0")[1])
        end = json.loads(_get(url + f"state.json?at={layout['replay_s']}")[1])
        assert start["counts"]["done"] == 0 and end["counts"]["done"] == 4 and end["completed"] is True
        mid_s = json.loads(res.stdout)["tasks"][0]["end_s"] + 0.01
        mid = json.loads(_get(url + f"state.json?at={mid_s}")[1])
        assert 0 < mid["counts"]["done"] < 4
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=30)
    assert proc.returncode == 0


def test_the_operator_keys_in_the_terminal_of_a_served_sim():
    """``masonry sim --serve`` in a terminal (a pty): p pauses, p again is refused, r resumes, 1 recalls the first
    UAV; each answer is a line on stderr, and the mission still completes."""
    import os
    import pty

    master, slave = pty.openpty()
    proc = subprocess.Popen(
        [
            *(sys.executable, "-c", MAIN, "sim", str(CASE_STUDY)),
            *("--serve", "127.0.0.1:0", "--time-scale", "10", "--no-progress", "--format", "json"),
        ],
        stdin=slave,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    os.close(slave)
    assert proc.stderr is not None

    def line_with(text: str) -> str:
        line = proc.stderr.readline()  # bounded: the process writes the line or ends (EOF)
        while line and text not in line:
            line = proc.stderr.readline()
        assert text in line, f"no line with {text!r}"
        return line

    try:
        assert "recall: 1 brick-1, 2 glue-1" in line_with("keys: p pause")
        for key, answer in ((b"p", "pause: accepted"), (b"p", "pause: refused (already paused)")):
            os.write(master, key)
            line_with(answer)
        os.write(master, b"r")
        line_with("resume: accepted")
        os.write(master, b"9x")  # not keys of ours: nothing
        os.write(master, b"1")
        line_with("recall brick-1: accepted")
        os.write(master, b"r")
        line_with("resume: accepted")
        line_with("its page stays up")
    finally:
        proc.send_signal(signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
        os.close(master)
    assert proc.returncode == 0
    report = json.loads(out)
    assert report["completed"] is True and report["conflict_violations"] == 0
