"""``--foxglove [HOST:]PORT``: a mission served live to a Foxglove WebSocket client (the ``foxglove.sdk.v1``
subprotocol, written here with ``websockets``), steered through its services; the option's checks."""

from __future__ import annotations

import base64
import json
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner
from websockets.exceptions import WebSocketException
from websockets.sync.client import connect

from foxglove_decode import decode
from masonry.cli import app

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
MAIN = "from masonry.cli import main; main()"
runner = CliRunner()
#: every wait below is bounded by this (wall seconds): generous, the test runs on two busy cores
WAIT_S = 240.0


class FoxgloveClient:
    """A minimal client of Foxglove's WebSocket protocol: channels, subscriptions, service calls."""

    def __init__(self, ws: Any) -> None:
        self.ws = ws
        assert ws.subprotocol == "foxglove.sdk.v1"
        self.channels: dict[str, dict[str, Any]] = {}
        self.services: dict[str, dict[str, Any]] = {}
        self.subscriptions: dict[int, dict[str, Any]] = {}
        self.received: dict[str, list[tuple[int, bytes]]] = {}
        self.responses: dict[int, bytes] = {}
        self.failures: dict[int, str] = {}
        self._call_id = 0

    def pump(self, until: Any, what: str) -> None:
        """Handle what the server sends until ``until()`` holds (bounded by :data:`WAIT_S`)."""
        deadline = time.monotonic() + WAIT_S
        while not until():
            left = deadline - time.monotonic()
            assert left > 0, f"no {what} from the server in {WAIT_S:.0f} s"
            try:
                frame = self.ws.recv(timeout=left)
            except TimeoutError:
                continue
            self._handle(frame)

    def _handle(self, frame: str | bytes) -> None:
        if isinstance(frame, str):
            msg = json.loads(frame)
            if msg["op"] == "advertise":
                self.channels.update({c["topic"]: c for c in msg["channels"]})
            elif msg["op"] == "advertiseServices":
                self.services.update({s["name"]: s for s in msg["services"]})
            elif msg["op"] == "serviceCallFailure":
                self.failures[msg["callId"]] = msg["message"]
            return
        if frame[0] == 0x01:  # message data: subscription id, log time (ns), the message
            sub, log_time = struct.unpack_from("<IQ", frame, 1)
            topic = self.subscriptions[sub]["topic"]
            self.received.setdefault(topic, []).append((log_time, frame[13:]))
        elif frame[0] == 0x03:  # service call response: service id, call id, encoding, the response
            _, call, n = struct.unpack_from("<III", frame, 1)
            self.responses[call] = frame[13 + n :]

    def subscribe(self, *topics: str) -> None:
        subs = []
        for topic in topics:
            sub = len(self.subscriptions) + 1
            self.subscriptions[sub] = self.channels[topic]
            subs.append({"id": sub, "channelId": self.channels[topic]["id"]})
        self.ws.send(json.dumps({"op": "subscribe", "subscriptions": subs}))

    def call(self, service: str, request: dict[str, Any]) -> dict[str, Any]:
        self._call_id += 1
        call = self._call_id
        body = json.dumps(request).encode()
        header = struct.pack("<BIII", 0x02, self.services[service]["id"], call, 4)
        self.ws.send(header + b"json" + body)
        self.pump(lambda: call in self.responses or call in self.failures, f"answer to {service}")
        assert call not in self.failures, self.failures[call]
        return dict(json.loads(self.responses[call]))

    def events(self) -> list[dict[str, Any]]:
        return [json.loads(data) for _, data in self.received.get("/mission/events", [])]


def foxglove_client(url: str) -> Any:
    """A connection as a Foxglove viewer (``with foxglove_client(url) as ws: client = FoxgloveClient(ws)``)."""
    return connect(url, subprotocols=["foxglove.sdk.v1"], max_size=None, open_timeout=60)


def _masonry(args: list[str]) -> subprocess.Popen[str]:
    """``masonry ARGS`` in a process of its own, its output read as text (no input)."""
    return subprocess.Popen(
        [sys.executable, "-c", MAIN, *args],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )


def _line_with(proc: subprocess.Popen[str], text: str) -> str:
    assert proc.stderr is not None
    line = proc.stderr.readline()  # bounded: the process writes the line or ends (EOF)
    while line and text not in line:
        line = proc.stderr.readline()
    assert text in line, f"no line with {text!r}"
    return line


@pytest.mark.slow
def test_a_served_sim_is_watched_and_paused_and_resumed_from_a_foxglove_client():
    """The done-when test of issue 32, with the live page served beside Foxglove: both show the same state."""
    import urllib.request

    proc = _masonry(
        [
            *("sim", str(CASE_STUDY), "--serve", "127.0.0.1:0"),
            *("--foxglove", "127.0.0.1:0", "--time-scale", "4", "--no-progress", "--format", "json"),
        ]
    )
    try:
        page = _line_with(proc, "serving the mission's page at ").rsplit(" ", 1)[-1].strip()
        url = _line_with(proc, "serving the mission to Foxglove at ").split(" at ", 1)[1].split(" ", 1)[0]
        assert url.startswith("ws://127.0.0.1:")
        with foxglove_client(url) as ws:
            client = FoxgloveClient(ws)
            _watch_pause_resume(client)
        _line_with(proc, "page and Foxglove server stay up")
        with urllib.request.urlopen(page + "state.json", timeout=60) as r:
            state = json.loads(r.read())
        # the page saw what Foxglove saw: every task done, the same operator's answers, in the same order
        assert state["counts"]["done"] == 4 and state["completed"] is True and state["paused"] is False
        from masonry.mission.events import MissionEvent

        ops = [MissionEvent.from_dict(e) for e in client.events() if e["kind"] == "operator"]
        assert state["operator"] == [e.line().strip() for e in ops] and len(ops) == 4
    finally:
        proc.send_signal(signal.SIGINT)  # the server stays up after the mission until Ctrl-C
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    report = json.loads(out)
    assert report["completed"] is True and report["conflict_violations"] == 0


def _watch_pause_resume(client: FoxgloveClient) -> None:
    """Subscribe, decode the wall, pause and resume through the services, follow the mission to its end."""
    wanted = {"/wall", "/airspace", "/mission/events", "/log", "/uav/brick-1/pose"}
    client.pump(
        lambda: (
            wanted <= set(client.channels) and {"/mission/pause", "/mission/resume"} <= set(client.services)
        ),
        "channels and services",
    )
    assert {"/mission/recall", "/mission/return-all", "/mission/abort", "/mission/limit"} <= set(
        client.services
    )
    wall = client.channels["/wall"]
    assert (wall["encoding"], wall["schemaName"], wall["schemaEncoding"]) == (
        "protobuf",
        "foxglove.SceneUpdate",
        "protobuf",
    )
    client.subscribe("/wall", "/airspace", "/mission/events", "/log")
    # the wall, whole (as we subscribe, and at each change); decoded with the schema the server advertised
    # (Foxglove's own)
    client.pump(lambda: client.received.get("/wall"), "/wall")
    schema = base64.b64decode(wall["schema"])
    first = decode("foxglove.SceneUpdate", schema, client.received["/wall"][0][1])
    assert len(first["entities"]) == 8
    ids = {e["id"] for e in first["entities"]}
    assert {"task/B0", "task/B1", "task/A0", "task/A1"} <= ids
    assert all(e["frame_id"] == "world" and (e["cubes"] or e["lines"]) for e in first["entities"])

    assert client.call("/mission/pause", {}) == {"accepted": True, "reason": ""}
    assert client.call("/mission/pause", {}) == {"accepted": False, "reason": "already paused"}
    assert client.call("/mission/recall", {"uav": "nobody"}) == {
        "accepted": False,
        "reason": "no UAV 'nobody' in this mission",
    }
    assert client.call("/mission/recall", {})["reason"] == "recall needs uav"
    assert client.call("/mission/resume", {}) == {"accepted": True, "reason": ""}
    client.pump(lambda: any(e["kind"] == "end" for e in client.events()), "end of the mission")

    events = client.events()
    ops = [e for e in events if e["kind"] == "operator"]
    assert [(e["fields"]["command"], e["fields"]["accepted"]) for e in ops] == [
        ("pause", True),
        ("pause", False),
        ("recall", False),
        ("resume", True),
    ]
    paused_s, resumed_s = ops[0]["time_s"], ops[-1]["time_s"]
    # paused: no task handed out between the pause and the resume
    assert not [e for e in events if e["kind"] == "assigned" and paused_s < e["time_s"] < resumed_s]
    assert next(e for e in events if e["kind"] == "end")["fields"]["completed"] is True
    # the log panel's lines and the wall's updates, every one a well-formed Foxglove message
    log_schema = base64.b64decode(client.channels["/log"]["schema"])
    lines = [decode("foxglove.Log", log_schema, d)["message"] for _, d in client.received["/log"]]
    assert any("pause: accepted" in line for line in lines)
    # the wall fills up: at the end every bead is sprayed (blue) and every brick placed: brick red if it was there
    # before the mission, else seen by its UAV after the release and coloured by its as-built deviation (issue 30:
    # red + green = 1, green on the design)
    colours = {
        e["id"]: (e["cubes"] or e["lines"])[0]["color"]
        for e in decode("foxglove.SceneUpdate", schema, client.received["/wall"][-1][1])["entities"]
    }
    assert len(colours) == 8 and colours["task/A0"]["r"] == pytest.approx(0.2)
    bricks = [c for k, c in colours.items() if k.startswith("task/B")]
    seen = [c for c in bricks if c["r"] + c["g"] == pytest.approx(1.0)]
    assert seen and all(c in seen or c["r"] == pytest.approx(0.72) for c in bricks), colours
    assert all(c["r"] == pytest.approx(0.2) for k, c in colours.items() if k.startswith("task/A")), colours


def test_replay_plays_a_log_back_to_a_foxglove_client(tmp_path):
    log = tmp_path / "run.mcap"
    res = runner.invoke(app, ["sim", str(CASE_STUDY), "--log", str(log), "--no-progress", "--format", "json"])
    assert res.exit_code == 0, res.output
    proc = _masonry(["replay", str(log), "--foxglove", "127.0.0.1:0", "--time-scale", "100"])
    try:
        url = _line_with(proc, "back to Foxglove at ").split(" at ", 1)[1].split(" ", 1)[0]
        with foxglove_client(url) as ws:
            client = FoxgloveClient(ws)
            client.pump(
                lambda: {"/wall", "/mission/events", "/mission/report"} <= set(client.channels), "channels"
            )
            assert not client.services  # a replay is not steered
            client.subscribe("/wall", "/mission/events", "/mission/report")

            # the log plays over and over: a whole pass, its whole wall first, its start event, then its report
            schema = base64.b64decode(client.channels["/wall"]["schema"])
            whole_wall = []

            def a_whole_pass() -> bool:
                walls = client.received.get("/wall", [])
                for _, data in walls[len(whole_wall) :]:
                    whole_wall.append(len(decode("foxglove.SceneUpdate", schema, data)["entities"]) == 8)
                kinds = [e["kind"] for e in client.events()]
                return (
                    any(whole_wall)
                    and "start" in kinds
                    and "end" in kinds[kinds.index("start") :]
                    and bool(client.received.get("/mission/report"))
                )

            client.pump(a_whole_pass, "a whole pass of the log")
        kinds = [e["kind"] for e in client.events()]
        assert {"assigned", "completed"} <= set(kinds[kinds.index("start") :])
        assert json.loads(client.received["/mission/report"][0][1])["report"]["completed"] is True
    finally:
        proc.send_signal(signal.SIGINT)
        proc.communicate(timeout=60)
    assert proc.returncode == 0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--foxglove", "ws"], "--foxglove 'ws': give [HOST:]PORT"),
        (
            ["--foxglove", "0.0.0.0:8765"],
            "--foxglove 0.0.0.0:8765 is not loopback: give --foxglove-cert FILE",
        ),
        (["--foxglove-cert", "c.pem"], "--foxglove-cert and --foxglove-key go with --foxglove"),
        (["--foxglove", "8765", "--foxglove-cert", "c.pem"], "go together"),
    ],
)
def test_a_bad_foxglove_option_is_one_line_and_exit_2(args, message):
    old_log = str(ROOT / "tests" / "data" / "old_format_case_study.mcap")
    for cmd in (["sim", str(CASE_STUDY)], ["replay", old_log], ["mission-control", str(CASE_STUDY)]):
        res = runner.invoke(app, [*cmd, *args])
        assert res.exit_code == 2, res.output
        lines = res.output.strip().splitlines()
        assert len(lines) == 1 and message in lines[0], res.output


def test_a_taken_port_is_one_line_and_exit_2():
    import socket

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        res = runner.invoke(app, ["sim", str(CASE_STUDY), "--foxglove", f"127.0.0.1:{port}", "--no-progress"])
    assert res.exit_code == 2 and f"--foxglove 127.0.0.1:{port}: cannot listen" in res.output, res.output


def _self_signed(tmp_path: Path) -> tuple[Path, Path]:
    """A certificate for 127.0.0.1 and its PKCS#8 key (PEM files)."""
    import datetime
    import ipaddress

    from cryptography import x509
    from cryptography.hazmat.primitives import hashes, serialization
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.x509.oid import NameOID

    key = ec.generate_private_key(ec.SECP256R1())
    name = x509.Name([x509.NameAttribute(NameOID.COMMON_NAME, "mission-control")])
    now = datetime.datetime(2026, 1, 1, tzinfo=datetime.timezone.utc)
    cert = (
        x509.CertificateBuilder()
        .subject_name(name)
        .issuer_name(name)
        .public_key(key.public_key())
        .serial_number(1)
        .not_valid_before(now)
        .not_valid_after(now + datetime.timedelta(days=3650))
        .add_extension(
            x509.SubjectAlternativeName([x509.IPAddress(ipaddress.ip_address("127.0.0.1"))]), False
        )
        .sign(key, hashes.SHA256())
    )
    cert_path, key_path = tmp_path / "server.pem", tmp_path / "server.key"
    cert_path.write_bytes(cert.public_bytes(serialization.Encoding.PEM))
    key_path.write_bytes(
        key.private_bytes(
            serialization.Encoding.PEM, serialization.PrivateFormat.PKCS8, serialization.NoEncryption()
        )
    )
    return cert_path, key_path


def test_off_loopback_the_server_needs_tls_and_offers_no_services(tmp_path):
    import ssl

    cert, key = _self_signed(tmp_path)
    proc = _masonry(
        [
            *("sim", str(CASE_STUDY), "--no-progress", "--format", "json"),
            *("--foxglove", "0.0.0.0:0", "--foxglove-cert", str(cert), "--foxglove-key", str(key)),
        ]
    )
    try:
        url = _line_with(proc, "serving the mission to Foxglove at ").split(" at ", 1)[1].split(" ", 1)[0]
        assert url.startswith("wss://0.0.0.0:")
        _line_with(proc, "Foxglove server stays up")  # the mission is over; its last messages stay served
        trust = ssl.create_default_context(cafile=str(cert))
        local = url.replace("0.0.0.0", "127.0.0.1")
        with connect(local, subprotocols=["foxglove.sdk.v1"], ssl=trust, open_timeout=60) as ws:
            info = json.loads(ws.recv(timeout=WAIT_S))
            assert info["op"] == "serverInfo" and "services" not in info["capabilities"]
            client = FoxgloveClient(ws)
            client.pump(lambda: {"/wall", "/mission/events"} <= set(client.channels), "channels")
            assert not client.services  # read-only off loopback: TLS proves the server, not the viewer
        plain = url.replace("wss://0.0.0.0", "ws://127.0.0.1")  # refused by a TLS server
        with pytest.raises((OSError, EOFError, WebSocketException)), connect(plain, open_timeout=10) as ws:
            ws.recv(timeout=10)
    finally:
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=60)
    assert proc.returncode == 0, err
    assert json.loads(out)["completed"] is True


@pytest.mark.slow
def test_mission_control_is_steered_from_foxglove_and_ctl_at_the_same_desk(tmp_path):
    """``masonry mission-control --foxglove``: a pause from Foxglove is journaled, and ``masonry ctl`` (signed with
    the mission key) then finds the mission paused; its resume shows in Foxglove's event channel."""
    import socket

    from masonry.mission.auth import write_key_file

    key = write_key_file(tmp_path / "mission.key")
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        endpoint = f"tcp/127.0.0.1:{s.getsockname()[1]}"
    name = f"fox-{endpoint.rsplit(':', 1)[1]}"
    journal = tmp_path / "mission.db"
    mc = _masonry(
        [
            *("mission-control", str(CASE_STUDY), "--listen", endpoint),
            *("--key-file", str(key), "--mission-name", name, "--journal", str(journal)),
            *("--startup-timeout", "300", "--max-time", "300", "--foxglove", "127.0.0.1:0"),
        ]
    )
    common = ["--mission", endpoint, "--key-file", str(key), "--mission-name", name]

    def ctl(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-c", MAIN, "ctl", *args, *common],
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )

    try:
        url = _line_with(mc, "serving the mission to Foxglove at ").split(" at ", 1)[1].split(" ", 1)[0]
        with foxglove_client(url) as ws:
            client = FoxgloveClient(ws)
            client.pump(
                lambda: "/mission/pause" in client.services and "/mission/events" in client.channels,
                "services",
            )
            client.subscribe("/mission/events")
            assert client.call("/mission/pause", {}) == {"accepted": True, "reason": ""}
            again = ctl("pause")
            assert (again.returncode, again.stdout) == (1, "pause: refused: already paused\n"), again.stderr
            resume = ctl("resume")
            assert (resume.returncode, resume.stdout) == (0, "resume: accepted\n"), resume.stderr

            def answered() -> list[tuple[str, bool]]:
                ops = [e["fields"] for e in client.events() if e["kind"] == "operator"]
                return [(f["command"], f["accepted"]) for f in ops]

            client.pump(lambda: len(answered()) >= 3, "the operator's events")
            assert answered() == [("pause", True), ("pause", False), ("resume", True)]
            limit = client.call("/mission/limit", {"role": "brick", "limit": 1})
            assert limit == {"accepted": True, "reason": ""}
            assert client.call("/mission/limit", {"role": "crane", "limit": 1})["reason"].startswith(
                "no 'crane' UAVs"
            )
    finally:
        mc.kill()
        mc.communicate(timeout=30)
    import sqlite3

    with sqlite3.connect(journal) as db:  # the journal's record of every command and its answer
        history = json.loads(dict(db.execute("select key, value from meta").fetchall())["operator"])
    assert [(h["command"], h["accepted"]) for h in history] == [
        ("pause", True),
        ("pause", False),
        ("resume", True),
        ("limit", True),
        ("limit", False),
    ]


def test_a_service_request_becomes_the_operators_command_or_is_refused_naming_what_is_wrong():
    from masonry.observe.live import SERVICES, answer

    asked: list[dict[str, Any]] = []

    def desk(c: Any) -> dict[str, Any]:
        asked.append(dict(c))
        return {"accepted": True, "reason": ""}

    command, fields = SERVICES["/mission/limit"]
    assert answer(desk, command, fields, b'{"role": "brick", "limit": 2, "extra": 1}')["accepted"] is True
    assert asked == [{"command": "limit", "role": "brick", "limit": 2}]  # only the service's own fields
    assert answer(desk, "pause", {}, b"") == {"accepted": True, "reason": ""}  # no body: no fields
    assert answer(desk, command, fields, b"{")["reason"].startswith("the request is not JSON")
    assert answer(desk, command, fields, b"[1]")["reason"] == "the request must be a JSON object"
    assert answer(desk, command, fields, b'{"role": "brick"}')["reason"] == "limit needs limit"
    assert len(asked) == 2
