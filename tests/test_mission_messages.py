"""Mission protocol messages: round trips, and every way a bad message is rejected with ProtocolError."""

from __future__ import annotations

import json

import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.errors import ProtocolError
from masonry.mission.messages import (
    MISSION_CONTROL,
    PROTOCOL_VERSION,
    Assign,
    Heartbeat,
    MissionEnd,
    Progress,
    Result,
    decode,
    encode,
)
from masonry.planner.tasks import AdhesionTask, BrickTask
from masonry.ports import TaskResult

FLEET = {"brick-1", "glue-1"}
BRICK = BrickTask("B3", 3, False, (1.0, 2.0, 0.15), 0.5, (4.0, 0.0, 0.05), (0.3, 0.15, 0.1))
GLUE = AdhesionTask("A0", 1, 3, (0.8, 2.0, 0.1), (1.2, 2.0, 0.1), 0.4)

MESSAGES = [
    Heartbeat("brick-1", 1.5, state="pickup_goto", task_id="B3", position_m=(1.0, 2.0, 1.2)),
    Heartbeat(MISSION_CONTROL, 2.0, state="running"),
    Assign(MISSION_CONTROL, "brick-1", BRICK, 2, 10.0),
    Assign(MISSION_CONTROL, "glue-1", GLUE, 1, 0.0),
    Progress("glue-1", "A0", "spray", 12.25, (0.8, 2.0, 0.45)),
    Result("brick-1", TaskResult("B3", "done", 71.4, placement_error_m=0.012), 80.0, (1.0, 2.0, 1.2)),
    Result("glue-1", TaskResult("A0", "failed", 5.0, reason="battery low"), 9.0),
    MissionEnd(MISSION_CONTROL, 400.0, True),
    Heartbeat("glue-1", 3.0, state="idle", battery=0.45, swaps_batteries=True, on_pad=True),
]


@pytest.mark.parametrize("msg", MESSAGES, ids=lambda m: type(m).__name__)
def test_round_trip(msg):
    assert decode(encode(msg), FLEET) == msg


@given(st.floats(allow_nan=False, allow_infinity=False, width=64), st.integers(1, 10**6))
def test_assign_round_trip_any_time_and_attempt(t, attempt):
    msg = Assign(MISSION_CONTROL, "brick-1", BRICK, attempt, t)
    assert decode(encode(msg), FLEET) == msg


def _body(msg):
    return json.loads(encode(msg))


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda d: d.update(v=PROTOCOL_VERSION + 1), "protocol version"),
        (lambda d: d.pop("v"), "protocol version"),
        (lambda d: d.update(type="teleport"), "unknown message type"),
        (lambda d: d.update(sender="brick-9"), "not a UAV of the blueprint's fleet"),
        (lambda d: d.pop("time_s"), "'time_s' is missing"),
        (lambda d: d.update(time_s="soon"), "'time_s' must be a finite number"),
        (lambda d: d.update(position_m=[1, 2]), "'position_m' must be a list of 3"),
        (lambda d: d.update(swaps_batteries="yes"), "'swaps_batteries' must be true or false"),
    ],
)
def test_bad_heartbeat_rejected(mutate, match):
    d = _body(MESSAGES[0])
    mutate(d)
    with pytest.raises(ProtocolError, match=match):
        decode(json.dumps(d), FLEET)


def test_assign_to_unknown_uav_rejected():
    d = _body(MESSAGES[2])
    d["uav"] = "intruder"
    with pytest.raises(ProtocolError, match="uav 'intruder' is not a UAV"):
        decode(json.dumps(d), FLEET)


def test_assign_from_a_uav_rejected():
    d = _body(MESSAGES[2])
    d["sender"] = "glue-1"
    with pytest.raises(ProtocolError, match="only 'mission-control' may send"):
        decode(json.dumps(d), FLEET)


@pytest.mark.parametrize(
    "mutate, match",
    [
        (lambda t: t.update(kind="mortar"), "'kind' must be 'brick' or 'adhesion'"),
        (lambda t: t.update(brick="3"), "'brick' must be an integer"),
        (lambda t: t.update(position_m=[0, 0, float("inf")]), "not valid JSON|'position_m'"),
        (lambda t: t.pop("yaw_rad"), "'yaw_rad' is missing"),
    ],
)
def test_bad_task_rejected(mutate, match):
    d = _body(MESSAGES[2])
    mutate(d["task"])
    with pytest.raises(ProtocolError, match=match):
        decode(json.dumps(d), FLEET)


def test_bad_result_status_and_attempt_rejected():
    d = _body(MESSAGES[5])
    d["result"]["status"] = "meh"
    with pytest.raises(ProtocolError, match="'status' must be 'done' or 'failed'"):
        decode(json.dumps(d), FLEET)
    a = _body(MESSAGES[2])
    a["attempt"] = 0
    with pytest.raises(ProtocolError, match="'attempt' must be >= 1"):
        decode(json.dumps(a), FLEET)


@pytest.mark.parametrize("raw", [b"", b"{not json", b"[1, 2]", b"\xff\xfe"])
def test_garbage_rejected(raw):
    with pytest.raises(ProtocolError):
        decode(raw, FLEET)


def test_without_fleet_any_uav_name_accepted():
    d = _body(MESSAGES[0])
    d["sender"] = "brick-9"
    assert decode(json.dumps(d)).sender == "brick-9"


def test_non_finite_numbers_are_never_encoded():
    with pytest.raises(ValueError):
        encode(Heartbeat("brick-1", float("nan")))
