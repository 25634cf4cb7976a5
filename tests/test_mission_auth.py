"""The mission network under attack: authenticated frames, result checks, task checks.

Mission control and the UAVs run over the in-process bus, each endpoint wrapped in an
:class:`~masonry.mission.auth.AuthenticatedTransport`; an attacker has a raw endpoint on the same bus (like a
process that reached the Zenoh port) and, for the checks that hold even against a key holder, a keyed one.
"""

from __future__ import annotations

import os
import stat
import time
from dataclasses import replace
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.errors import InputError
from masonry.fingerprint import wall_digest
from masonry.mission import auth
from masonry.mission.auth import AuthenticatedTransport, is_loopback, load_key, write_key_file
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, Assign, Heartbeat, Result, decode, encode
from masonry.planner import min_durations_s, plan
from masonry.ports import TaskResult

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
KEY = bytes(range(32))
OTHER_KEY = bytes(range(1, 33))


class Tap:
    """A transport that passes everything through and keeps a copy of each frame it sends (to replay them)."""

    def __init__(self, inner):
        self.inner, self.sent = inner, []

    @property
    def name(self):
        return self.inner.name

    def send(self, to, payload):
        self.sent.append((to, payload))
        self.inner.send(to, payload)

    def receive(self):
        return self.inner.receive()

    def close(self):
        self.inner.close()


def keyed(bus, name, key=KEY, mission="default"):
    tap = Tap(bus.endpoint(name))
    return AuthenticatedTransport(tap, key, mission=mission), tap


# -- the frame layer ---------------------------------------------------------------------------------------
def test_frames_round_trip_and_every_forgery_is_dropped_and_counted(monkeypatch):
    bus = InprocBus()
    mc, mc_tap = keyed(bus, MISSION_CONTROL)
    uav, tap = keyed(bus, "brick-1")
    eve = bus.endpoint("eve")
    wrong, _ = keyed(bus, "glue-1", key=OTHER_KEY)
    hb = encode(Heartbeat("brick-1", 1.0))

    uav.send(MISSION_CONTROL, hb)
    assert mc.receive() == [hb]

    eve.send(MISSION_CONTROL, hb)  # no key: plain JSON in a UAV's name
    wrong.send(MISSION_CONTROL, encode(Heartbeat("glue-1", 1.0)))  # another key
    _, frame = tap.sent[-1]
    eve.send(MISSION_CONTROL, frame)  # replayed
    altered = bytearray(frame)
    altered[-40] ^= 1  # a byte of the payload changed
    eve.send(MISSION_CONTROL, bytes(altered))
    uav.send(MISSION_CONTROL, encode(Heartbeat("glue-1", 2.0)))  # a key holder in another UAV's name
    assert mc.receive() == []
    assert mc.dropped == {"malformed": 1, "bad-mac": 2, "replay": 1, "sender-mismatch": 1}
    assert mc.dropped_total == 5 and mc.accepted == 1

    # a frame for brick-1 is worthless to glue-1, and one of mission "a" to mission "b"
    glue, _ = keyed(bus, "glue-2")
    mc.send("brick-1", encode(Heartbeat(MISSION_CONTROL, 3.0)))
    bus.endpoint("eve-2").send("glue-2", mc_tap.sent[-1][1])
    other = AuthenticatedTransport(bus.endpoint("mc-b"), KEY, mission="b")
    other.send("glue-2", encode(Heartbeat(MISSION_CONTROL, 3.0)))
    assert glue.receive() == [] and glue.dropped == {"bad-mac": 2}

    # a frame recorded long ago (an earlier run with the same key) is stale
    real_ns = time.time_ns
    monkeypatch.setattr(auth.time, "time_ns", lambda: real_ns() - int(600e9))
    old = AuthenticatedTransport(Tap(bus.endpoint("old")), KEY)
    old.send("glue-2", encode(Heartbeat("old", 0.0)))
    monkeypatch.setattr(auth.time, "time_ns", real_ns)
    assert glue.receive() == [] and glue.dropped["stale"] == 1


def test_counters_keep_increasing_across_a_restart_of_the_sender():
    bus = InprocBus()
    mc, _ = keyed(bus, MISSION_CONTROL)
    first = AuthenticatedTransport(bus.endpoint("brick-1"), KEY)
    for t in range(3):
        first.send(MISSION_CONTROL, encode(Heartbeat("brick-1", float(t))))
    first.close()
    again = AuthenticatedTransport(bus.endpoint("brick-1"), KEY)  # a new process: counters from the clock
    again.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 9.0)))
    assert len(mc.receive()) == 4 and not mc.dropped


# -- mission control ---------------------------------------------------------------------------------------
def _mission(key=KEY, **kw):
    bp = load_blueprint(CASE_STUDY)
    p = plan(bp)
    bus = InprocBus()
    mc_t, _ = keyed(bus, MISSION_CONTROL, key=key) if key else (bus.endpoint(MISSION_CONTROL), None)
    mc = MissionControl(
        p,
        bp.fleet,
        mc_t,
        heartbeat_timeout_s=5.0,
        startup_timeout_s=30.0,
        wall_digest=wall_digest(bp),
        min_durations_s=min_durations_s(p),
        **kw,
    )
    return bp, p, bus, mc


def test_a_forged_heartbeat_before_a_uav_joins_does_not_get_it_declared_lost():
    # unauthenticated (the old behaviour, still that of a keyless mission on loopback): the forgery counts as
    # brick-1 joining, and 5 s of silence later brick-1 is lost for good
    _, _, bus, mc = _mission(key=None)
    bus.endpoint("eve").send(MISSION_CONTROL, encode(Heartbeat("brick-1", 0.0)))
    for t in range(8):
        mc.step(float(t))
    assert mc.uavs["brick-1"].lost

    _, _, bus, mc = _mission()
    eve = bus.endpoint("eve")
    eve.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 0.0)))
    forger, _ = keyed(bus, "nobody", key=OTHER_KEY)
    forger.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 0.0)))
    for t in range(8):
        mc.step(float(t))
    link = mc.uavs["brick-1"]
    assert link.last_heard_s is None and not link.lost
    assert mc.transport.dropped == {"malformed": 1, "bad-mac": 1}
    brick, _ = keyed(bus, "brick-1")
    glue, _ = keyed(bus, "glue-1")
    brick.send(MISSION_CONTROL, encode(Heartbeat("brick-1", 8.0)))
    glue.send(MISSION_CONTROL, encode(Heartbeat("glue-1", 8.0)))
    mc.step(8.0)
    assert sorted(mc.online) == ["brick-1", "glue-1"] and mc.started_at_s == 8.0


def _assignments(transport):
    return [m for m in map(decode, transport.receive()) if isinstance(m, Assign)]


def test_forged_completions_are_dropped_or_ignored_and_the_mission_runs_as_without_them():
    bp, p, bus, mc = _mission()
    least = min_durations_s(p)
    keyed_uavs = {u.name: keyed(bus, u.name) for u in bp.fleet}
    uavs = {name: tr for name, (tr, _) in keyed_uavs.items()}
    eve = bus.endpoint("eve")

    def done(sender, task_id, attempt, t):
        return encode(Result(sender, TaskResult(task_id, "done", 1.0), t, attempt=attempt))

    now = 0.0
    for name, tr in uavs.items():
        tr.send(MISSION_CONTROL, encode(Heartbeat(name, now)))
    mc.step(now)
    running = {name: (a, now) for name, tr in uavs.items() for a in _assignments(tr)}
    holder, (first, _) = next(iter(running.items()))
    other = next(n for n in uavs if n != holder)
    tid, attempt = first.task.id, first.attempt

    # the attacks, all while the task is in flight
    eve.send(MISSION_CONTROL, done(holder, tid, attempt, 0.5))  # no key
    AuthenticatedTransport(bus.endpoint("wrong"), OTHER_KEY).send(
        MISSION_CONTROL, done(holder, tid, attempt, 0.5)
    )
    uavs[holder].send(MISSION_CONTROL, encode(Heartbeat(holder, 0.5)))
    replayable = keyed_uavs[holder][1].sent[-1][1]
    uavs[other].send(MISSION_CONTROL, done(other, tid, attempt, 0.5))  # not the assigned UAV
    uavs[holder].send(MISSION_CONTROL, done(holder, tid, attempt + 1, 0.5))  # not the current attempt
    uavs[holder].send(MISSION_CONTROL, done(holder, tid, 0, 0.5))  # no attempt at all
    uavs[holder].send(MISSION_CONTROL, done(holder, tid, attempt, 0.5))  # sooner than physically possible
    now = 0.5
    mc.step(now)
    eve.send(MISSION_CONTROL, replayable)  # a replayed frame
    mc.step(now)
    assert tid in mc.dispatcher.in_progress and not mc.dispatcher.finished
    assert mc.transport.dropped == {"malformed": 1, "bad-mac": 1, "replay": 1}
    assert mc.events.ignored == {"not-assigned": 1, "wrong-attempt": 2, "too-short": 1}

    # the real UAVs now fly every task for its least duration: the mission ends as it would have
    for _ in range(200):
        now += 0.5
        for name, tr in uavs.items():
            tr.send(MISSION_CONTROL, encode(Heartbeat(name, now)))
            job = running.get(name)
            if job is not None and now - job[1] >= least[job[0].task.id]:
                tr.send(MISSION_CONTROL, done(name, job[0].task.id, job[0].attempt, now))
                del running[name]
        mc.step(now)
        for name, tr in uavs.items():
            for a in _assignments(tr):
                running[name] = (a, now)
        if mc.ended_at_s is not None:
            break
    assert mc.finished
    done_attempts = [a for a in mc.history if a.status == "done"]
    assert sorted(a.task_id for a in done_attempts) == sorted(t.id for t in p.tasks if not t.done)
    assert all(a.end_s - a.start_s >= 0.9 * least[a.task_id] for a in done_attempts)
    assert all(a.attempt == 1 for a in mc.history)


def test_checks_on_results_hold_without_a_key():
    bp, _, bus, mc = _mission(key=None)
    eve = bus.endpoint("eve")
    for u in bp.fleet:
        eve.send(MISSION_CONTROL, encode(Heartbeat(u.name, 0.0)))
    mc.step(0.0)
    tid, uav = next(iter(mc.dispatcher.in_progress.items()))
    eve.send(MISSION_CONTROL, encode(Result(uav, TaskResult(tid, "done", 0.8), 0.8, attempt=1)))
    mc.step(0.8)
    assert mc.events.ignored == {"too-short": 1} and tid in mc.dispatcher.in_progress


def test_a_completion_said_again_after_it_was_taken_is_neither_acted_on_nor_counted():
    """The handler repeats a completion when mission control's heartbeats paused around it (a busy computer
    does that too): the repeat of a result already taken is no security event, while the same result from
    another UAV or for another attempt still is."""
    bp, _, bus, mc = _mission(key=None)
    least = min_durations_s(plan(bp))
    eve = bus.endpoint("eve")
    for u in bp.fleet:
        eve.send(MISSION_CONTROL, encode(Heartbeat(u.name, 0.0)))
    mc.step(0.0)
    tid, uav = next(iter(mc.dispatcher.in_progress.items()))
    other = next(u.name for u in bp.fleet if u.name != uav)
    t = least[tid] + 1.0
    for now in (1.0, 3.0, t):  # heard all along (a silent UAV's results are screened differently)
        for u in bp.fleet:
            eve.send(MISSION_CONTROL, encode(Heartbeat(u.name, now, task_id=mc.dispatcher.task_of(u.name))))
        mc.step(now)
    done = Result(uav, TaskResult(tid, "done", 1.0), t, attempt=1)
    eve.send(MISSION_CONTROL, encode(done))
    mc.step(t)
    assert tid in mc.dispatcher.done and mc.events.ignored == {}
    eve.send(MISSION_CONTROL, encode(replace(done, time_s=t + 1.0)))
    mc.step(t + 1.0)
    assert mc.events.ignored == {}
    assert [a.status for a in mc.history if a.task_id == tid] == ["done"]
    eve.send(MISSION_CONTROL, encode(replace(done, sender=other)))
    eve.send(MISSION_CONTROL, encode(replace(done, attempt=2)))
    mc.step(t + 2.0)
    assert mc.events.ignored == {"not-assigned": 2}


# -- the UAV handler ---------------------------------------------------------------------------------------
class Idle:
    finished = True
    state = "idle"

    def step(self, now_s):
        pass


@pytest.mark.parametrize(
    "forge, why",
    [
        (lambda a, bp: replace(a, task=replace(a.task, id="B99")), "not a task of this UAV's blueprint"),
        (lambda a, bp: replace(a, task=replace(a.task, position_m=(30.0, 30.0, 0.1))), "geometry differs"),
        (lambda a, bp: replace(a, wall="0123456789abcdef"), "is for the wall 0123456789abcdef"),
        (lambda a, bp: replace(a, wall=""), "(none given)"),
        (
            lambda a, bp: replace(a, task=next(t for t in plan(bp).tasks if t.kind == "adhesion")),
            "is adhesion work",
        ),
    ],
)
def test_a_uav_refuses_a_task_that_is_not_its_blueprints_and_reports_it(forge, why):
    bp = load_blueprint(CASE_STUDY)
    p = plan(bp)
    spec = next(u for u in bp.fleet if u.role == "brick")
    bus = InprocBus()
    mc = bus.endpoint(MISSION_CONTROL)
    h = UavHandler(
        spec.name, bus.endpoint(spec.name), tasks=p.tasks, role=spec.role, wall_digest=wall_digest(bp)
    )
    h.attach(Idle())
    brick = next(t for t in p.tasks if t.kind == "brick")
    good = Assign(MISSION_CONTROL, spec.name, brick, 1, 0.0, wall_digest(bp))
    mc.send(spec.name, encode(forge(good, bp)))
    h.step(0.0)
    assert h.poll_task() is None and len(h.refused) == 1 and why in h.refused[0]
    answers = [decode(m) for m in mc.receive()]
    results = [m for m in answers if isinstance(m, Result)]
    assert len(results) == 1 and results[0].result.status == "failed"
    assert results[0].result.reason.startswith("refused: ") and why in results[0].result.reason
    mc.send(spec.name, encode(good))  # the real assignment is taken
    h.step(0.1)
    assert h.poll_task() == brick
    # while B0 is in hand, a forgery of B0 is refused without an answer (which would cancel the real one)
    forged = forge(good, bp)
    mc.send(spec.name, encode(forged))
    h.step(0.2)
    answers = [m for m in map(decode, mc.receive()) if isinstance(m, Result)]
    assert len(h.refused) == 2 and len(answers) == (0 if forged.task.id == brick.id else 1)


# -- key files, the CLI ------------------------------------------------------------------------------------
def test_key_files(tmp_path):
    path = write_key_file(tmp_path / "mission.key")
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    text = path.read_text()
    assert len(text.strip()) == 64 and text.endswith("\n")
    assert load_key(path) == bytes.fromhex(text.strip())
    with pytest.raises(InputError, match="already exists"):
        write_key_file(path)
    assert load_key(write_key_file(path, force=True)) != bytes.fromhex(text.strip())
    os.chmod(path, 0o644)
    with pytest.raises(InputError, match="readable by group or others"):
        load_key(path)
    bad = tmp_path / "bad.key"
    for content in (b"", b"abc\n", b"zz" * 32, bytes(32), b"00" * 33):
        bad.write_bytes(content)
        os.chmod(bad, 0o600)
        with pytest.raises(InputError, match="64 hexadecimal digits"):
            load_key(bad)
    with pytest.raises(InputError, match="No such file"):
        load_key(tmp_path / "missing.key")


@pytest.mark.parametrize(
    "endpoint, loop",
    [
        ("tcp/127.0.0.1:7447", True),
        ("tcp/127.1.2.3:1", True),
        ("tcp/localhost:7447", True),
        ("tcp/[::1]:7447", True),
        ("tls/127.0.0.1:7447", True),
        ("tcp/0.0.0.0:7447", False),
        ("tcp/10.0.0.1:7447", False),
        ("tcp/[::]:7447", False),
        ("tcp/uav-base.local:7447", False),
    ],
)
def test_loopback_endpoints(endpoint, loop):
    assert is_loopback(endpoint) is loop


runner = CliRunner()


def test_cli_refuses_a_network_endpoint_without_a_key(tmp_path):
    r = runner.invoke(app, ["mission-control", str(CASE_STUDY), "--listen", "tcp/0.0.0.0:7447"])
    assert r.exit_code == 2
    assert r.stderr.strip().splitlines() == [
        (
            "error: --listen/--connect tcp/0.0.0.0:7447 is not loopback: give --key-file FILE (masonry keygen -o "
            "FILE) to authenticate the mission, or --insecure to run it unauthenticated"
        )
    ]
    r = runner.invoke(
        app,
        ["fly", "--uav", "brick", "--sim", "--blueprint", str(CASE_STUDY), "--mission", "tcp/10.0.0.1:7447"],
    )
    assert r.exit_code == 2 and len(r.stderr.strip().splitlines()) == 1
    assert "--mission/--listen tcp/10.0.0.1:7447 is not loopback" in r.stderr
    bad = tmp_path / "k"
    bad.write_text("not a key\n")
    os.chmod(bad, 0o600)
    r = runner.invoke(app, ["mission-control", str(CASE_STUDY), "--key-file", str(bad)])
    assert r.exit_code == 2 and r.stderr.strip().splitlines() == [
        f"error: --key-file {bad}: a key file holds 64 hexadecimal digits (make one with masonry keygen -o FILE)"
    ]
    r = runner.invoke(
        app, ["mission-control", str(CASE_STUDY), "--zenoh-config", str(tmp_path / "none.json5")]
    )
    assert r.exit_code == 2 and "--zenoh-config" in r.stderr and len(r.stderr.strip().splitlines()) == 1
    broken = tmp_path / "broken.json5"
    broken.write_text("{ transport:\n")
    r = runner.invoke(app, ["mission-control", str(CASE_STUDY), "--zenoh-config", str(broken)])
    assert r.exit_code == 2 and r.stderr.strip().splitlines() == [
        (
            f"error: --zenoh-config {broken}: not a valid Zenoh configuration: line 2, column 1: expected array, "
            "boolean, null, number, object, or string"
        )
    ]


def test_default_listen_is_loopback():
    from masonry.cli.mission import DEFAULT_LISTEN

    r = runner.invoke(app, ["mission-control", "--help"])
    assert DEFAULT_LISTEN == "tcp/127.0.0.1:7447" and "0.0.0.0" not in r.stdout


def test_keygen_writes_a_key_and_refuses_to_overwrite_it(tmp_path):
    out = tmp_path / "m.key"
    r = runner.invoke(app, ["keygen", "-o", str(out)])
    assert r.exit_code == 0, r.output
    key = load_key(out)
    assert len(key) == 32 and f"wrote {out}" in r.stderr
    r = runner.invoke(app, ["keygen", "-o", str(out)])
    assert r.exit_code == 2 and r.stderr.strip().splitlines() == [
        f"error: {out} already exists: pass --force to replace it (every peer then needs the new key)"
    ]
    assert load_key(out) == key
    r = runner.invoke(app, ["keygen", "-o", str(out), "--force"])
    assert r.exit_code == 0 and load_key(out) != key
