"""The operator in the loop (masonry.mission.operator): pause and resume change no outcome, abort lands every
UAV at home and leaves a journal that resumes to completion, recall re-queues the task, limits hold; the
commands' wire messages; ``masonry ctl`` answers."""

from __future__ import annotations

import itertools
import json
import math
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.errors import ProtocolError
from masonry.mission.events import EventList
from masonry.mission.messages import OPERATOR, CommandAnswer, OperatorCommand, Recall, decode, encode
from masonry.mission.simulate import SimulatedMission
from masonry.ports import RECALL_REASON

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
SMALL = ROOT / "blueprints" / "running_bond_small.yaml"


def _fly(blueprint: Path, commands: dict[float, dict], **kw):
    """Fly a simulated mission, submitting each command once mission time reaches its key; the mission, its
    report and the answers (time, command, outcome)."""
    mission = SimulatedMission.from_blueprint(load_blueprint(blueprint), **kw)
    pending = sorted(commands.items())
    answers: list = []

    def operator(now_s: float) -> None:
        while pending and now_s >= pending[0][0]:
            t, c = pending.pop(0)
            mission.control.operator.submit(c, lambda out, t=t, c=c: answers.append((t, c["command"], out)))

    mission.tick_hooks.append(operator)
    report = mission.run()
    return mission, report, answers


def test_pause_then_resume_changes_no_outcome_and_violates_nothing():
    _, plain, _ = _fly(CASE_STUDY, {})
    sink = EventList()
    _, r, answers = _fly(
        CASE_STUDY, {20.0: {"command": "pause"}, 90.0: {"command": "resume"}}, events_sink=sink
    )
    assert [(c, o.accepted) for _, c, o in answers] == [("pause", True), ("resume", True)]
    assert r.completed and plain.completed
    assert {t.id: t.status for t in r.tasks} == {t.id: t.status for t in plain.tasks}
    assert r.conflict_violations == 0 and r.dependency_violations == 0
    # nothing was assigned while paused, and every UAV was on the ground before the resume
    paused = [a for a in r.attempts if 20.1 < a.start_s < 90.0]
    assert paused == []
    landed = {
        e.uav
        for e in sink.events
        if e.kind == "uav" and 80.0 < e.time_s < 90.0 and e.fields["state"] == "idle"
    }
    assert landed == {"brick-1", "glue-1"}
    assert r.makespan_s > plain.makespan_s  # the pause took time
    ops = [e for e in sink.events if e.kind == "operator"]
    assert [e.fields["command"] for e in ops] == ["pause", "resume"] and all(
        e.fields["accepted"] for e in ops
    )


def test_commands_are_refused_with_a_reason():
    _, r, answers = _fly(
        CASE_STUDY,
        {
            5.0: {"command": "resume"},
            6.0: {"command": "recall", "uav": "nobody"},
            7.0: {"command": "limit", "role": "pilot", "limit": 1},
            8.0: {"command": "limit", "role": "brick", "limit": "two"},
            9.0: {"command": "dance"},
        },
    )
    reasons = [(c, o.accepted, o.reason) for _, c, o in answers]
    assert reasons == [
        ("resume", False, "not paused"),
        ("recall", False, "no UAV 'nobody' in this mission"),
        ("limit", False, "no 'pilot' UAVs in this mission (roles: adhesion, brick)"),
        ("limit", False, "the limit must be a whole number >= 0 (or -1: none), got 'two'"),
        ("dance", False, "unknown command 'dance'"),
    ]
    assert r.completed  # refused commands change nothing


def test_abort_lands_every_uav_at_home_and_the_journal_resumes_to_completion(tmp_path):
    journal = tmp_path / "j.sqlite"
    mission, r, answers = _fly(CASE_STUDY, {30.0: {"command": "abort"}}, journal_path=journal)
    assert answers[0][1:] == ("abort", answers[0][2]) and answers[0][2].accepted
    assert not r.completed and 0 < sum(t.status == "done" for t in r.tasks) < 4
    for spec in mission.fleet:
        v = mission.world.uavs[spec.name].vehicle
        assert v.on_ground and not v.armed, spec.name
        assert math.dist(v.position_m[:2], spec.home_m[:2]) < 0.3, (spec.name, v.position_m)
    # the recalled attempt failed for the operator, not for the task
    recalled = [a for a in r.attempts if a.status == "failed"]
    # (a brick on the magnet is put back at its pickup first: the reason says so after the operator's)
    assert recalled and all(a.reason is not None and a.reason.startswith(RECALL_REASON) for a in recalled)
    import sqlite3

    with sqlite3.connect(journal) as db:
        metas = dict(db.execute("select key, value from meta").fetchall())
    assert "aborted" in metas and "operator" in metas
    again = SimulatedMission.from_blueprint(
        load_blueprint(CASE_STUDY), journal_path=journal, resume=True
    ).run()
    assert again.completed
    assert again.conflict_violations == 0 and again.dependency_violations == 0


def test_recall_mid_task_requeues_the_task_and_the_mission_completes():
    sink = EventList()
    # B0 is assigned to brick-1 at about 15 s and takes a minute: recalled at 25 s, resumed at 70 s
    _, r, answers = _fly(
        CASE_STUDY,
        {25.0: {"command": "recall", "uav": "brick-1"}, 70.0: {"command": "resume"}},
        events_sink=sink,
    )
    assert [o.accepted for _, _, o in answers] == [True, True]
    b0 = [a for a in r.attempts if a.task_id == "B0"]
    assert [a.status for a in b0] == ["failed", "done"]
    assert b0[0].reason in (RECALL_REASON, f"{RECALL_REASON}; brick 0 put back at its pickup")
    # a recall costs the task no attempt (as a battery swap does): the report counts 1; the flight after it is an
    # assignment of its own, numbered 2 (issue 27, branch ``attempt43``)
    assert [a.attempt for a in b0] == [1, 2] and next(t for t in r.tasks if t.id == "B0").attempts == 1
    assert b0[0].end_s is not None and b0[0].end_s < 70.0 <= b0[1].start_s
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    # it came home and landed before it flew again
    states = [
        e.fields["state"]
        for e in sink.events
        if e.kind == "uav" and e.uav == "brick-1" and 25 < e.time_s < 70
    ]
    assert states[-1] == "idle"


@pytest.mark.slow
def test_a_fleet_limit_keeps_one_brick_uav_flying_at_once():
    sink = EventList()
    _, r, answers = _fly(SMALL, {0.0: {"command": "limit", "role": "brick", "limit": 1}}, events_sink=sink)
    assert answers[0][2].accepted
    assert r.completed and r.conflict_violations == 0 and r.dependency_violations == 0
    bricks = sorted((a.start_s, a.end_s) for a in r.attempts if a.kind == "brick")
    assert all(e0 is not None and e0 <= s1 for (_, e0), (s1, _) in itertools.pairwise(bricks))


def test_the_operator_messages_round_trip_and_are_checked():
    fleet = ["brick-1", "glue-1"]
    for m in (
        OperatorCommand(OPERATOR, "recall", 1.0, "7", uav="brick-1"),
        OperatorCommand(OPERATOR, "limit", 2.0, "8", role="brick", limit=1),
        CommandAnswer("mission-control", "7", "recall", False, "no such UAV", 1.5),
        Recall("mission-control", "glue-1", 3.0, RECALL_REASON),
    ):
        assert decode(encode(m), fleet) == m
    bad = json.loads(encode(OperatorCommand(OPERATOR, "pause", 1.0)))
    for change, match in (
        ({"sender": "brick-1"}, "only 'operator' sends commands"),
        ({"command": "fly-away"}, "must be one of"),
        ({"limit": -3}, "integer >= -1"),
    ):
        with pytest.raises(ProtocolError, match=match):
            decode(json.dumps({**bad, **change}), fleet)
    with pytest.raises(ProtocolError, match="only 'mission-control'"):
        decode(encode(Recall("brick-1", "glue-1", 1.0, "x")), fleet)


def test_a_heartbeat_may_carry_the_battery():
    from masonry.mission.messages import Heartbeat

    fleet = ["brick-1"]
    hb = Heartbeat("brick-1", 3.0, "idle", None, (1.0, 2.0, 0.0), battery=0.75)
    assert decode(encode(hb), fleet) == hb
    assert "battery" not in json.loads(encode(Heartbeat("brick-1", 3.0)))  # left out when unknown
    bad = json.loads(encode(hb))
    for value in (1.5, -0.1, "full", True):
        with pytest.raises(ProtocolError, match="battery"):
            decode(json.dumps({**bad, "battery": value}), fleet)
