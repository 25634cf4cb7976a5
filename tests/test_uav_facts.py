"""A UAV's typed facts (issue 27 §2): the handler reads them off its machine, the wire carries them inside the
message (version 5), the decoder refuses a bad one, and mission control decides from them, not from state names."""

from __future__ import annotations

import json
from dataclasses import replace

import pytest

from masonry.blueprint import UavSpec
from masonry.errors import ProtocolError
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import (
    MISSION_CONTROL,
    PROTOCOL_VERSION,
    Assign,
    Heartbeat,
    Progress,
    Result,
    decode,
    encode,
)
from masonry.mission.uav_facts import UavFacts, facts_of
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import TaskResult

FLEET = {"brick-1", "brick-2"}
FACTS = ("carrying", "flying_home", "on_pad", "finishing", "out_of_service")


def test_the_protocol_version_went_up_for_the_facts() -> None:
    assert PROTOCOL_VERSION >= 5  # (6: the recall's task, issue 27 branch recall42)
    assert json.loads(encode(Heartbeat("brick-1", 1.0)))["v"] == PROTOCOL_VERSION


@pytest.mark.parametrize(
    "msg",
    [
        Heartbeat("brick-1", 1.0, state="putback_goto", carrying=True, flying_home=True),
        Heartbeat("brick-1", 1.0, state="idle", on_pad=True),
        Heartbeat("brick-1", 1.0, state="place_release", finishing=True, battery=0.5),
        Progress("brick-1", "B0", "transport", 2.0, (1.0, 2.0, 3.0), carrying=True),
        Progress("brick-1", "B0", "home", 2.0, flying_home=True),
    ],
    ids=lambda m: f"{type(m).__name__}-{m.state}",
)
def test_the_facts_round_trip_inside_the_message(msg: Heartbeat | Progress) -> None:
    body = json.loads(encode(msg))
    assert all(type(body[name]) is bool for name in FACTS)  # always on the wire, as booleans
    assert decode(encode(msg), FLEET) == msg
    assert decode(encode(msg)) == msg  # (the fast path of a heartbeat gives the same value)


def test_facts_left_out_are_false() -> None:
    body = json.loads(encode(Heartbeat("brick-1", 1.0, state="idle", on_pad=True)))
    for name in FACTS:
        body.pop(name)
    assert decode(json.dumps(body), FLEET) == Heartbeat("brick-1", 1.0, state="idle")


@pytest.mark.parametrize("name", FACTS)
@pytest.mark.parametrize("bad", [1, 0, "true", None, [True], {"v": True}])
@pytest.mark.parametrize("kind", ["heartbeat", "progress"])
def test_a_fact_that_is_not_a_boolean_is_refused_by_name(name: str, bad: object, kind: str) -> None:
    msg = (
        Heartbeat("brick-1", 1.0, state="idle")
        if kind == "heartbeat"
        else Progress("brick-1", "B0", "x", 1.0)
    )
    body = json.loads(encode(msg))
    body[name] = bad
    for fleet in (FLEET, None):
        with pytest.raises(ProtocolError, match=rf"{kind} message: field '{name}' must be true or false"):
            decode(json.dumps(body), fleet)


def test_the_uav_side_reads_its_facts_off_its_machine() -> None:
    assert facts_of("idle") == UavFacts(on_pad=True)
    assert facts_of("transport") == UavFacts(carrying=True)
    assert facts_of("putback_goto") == UavFacts(carrying=True, flying_home=True)
    assert facts_of("putback_release") == UavFacts(flying_home=True)
    assert facts_of("home") == UavFacts(flying_home=True)
    assert facts_of("place_descend") == UavFacts(carrying=True, finishing=True)
    assert facts_of("spray") == UavFacts(finishing=True)
    assert facts_of("halted") == UavFacts(out_of_service=True)
    assert facts_of("") == UavFacts()


def test_a_results_out_of_service_fact_round_trips_and_is_checked() -> None:
    msg = Result("brick-1", TaskResult("B0", "failed", 1.0, reason="x"), 3.0, state="halted", attempt=1)
    for m in (msg, replace(msg, out_of_service=True)):
        assert decode(encode(m), FLEET) == m
    body = json.loads(encode(msg))
    body["out_of_service"] = "yes"
    with pytest.raises(ProtocolError, match="result message: field 'out_of_service' must be true or false"):
        decode(json.dumps(body), FLEET)
    body.pop("out_of_service")
    assert decode(json.dumps(body), FLEET) == msg


def test_the_handlers_heartbeat_and_progress_carry_its_machines_facts() -> None:
    bus = InprocBus()
    mc_end = bus.endpoint(MISSION_CONTROL)
    h = UavHandler("brick-1", bus.endpoint("brick-1"))

    class Machine:
        state, finished = "putback_goto", True

        def step(self, now_s: float) -> None:
            pass

    h.attach(Machine())
    h.step(0.0)
    h.report_progress("B0", "place_release", 0.5)
    got = [decode(raw) for raw in mc_end.receive()]
    hb = next(m for m in got if isinstance(m, Heartbeat))
    assert (hb.state, hb.carrying, hb.flying_home, hb.on_pad, hb.finishing) == (
        "putback_goto",
        True,
        True,
        False,
        False,
    )
    pr = next(m for m in got if isinstance(m, Progress))
    assert (pr.state, pr.carrying, pr.finishing) == ("place_release", False, True)


def _lost_while(state: str, facts: UavFacts) -> str:
    """The reason of the attempt of brick-1, last heard in ``state`` with ``facts`` on its task, then silent."""
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    fleet = tuple(UavSpec(f"brick-{i + 1}", "brick", (i * 3.0, -3.0, 0.0)) for i in range(2))
    bus = InprocBus()
    mc = MissionControl(plan, fleet, bus.endpoint(MISSION_CONTROL), heartbeat_timeout_s=5.0)
    ends = {u.name: bus.endpoint(u.name) for u in fleet}
    tasks: dict[str, str | None] = dict.fromkeys(ends)

    def beat(name: str, now_s: float, msg_state: str, msg_facts: UavFacts) -> None:
        f = msg_facts
        hb = Heartbeat(
            name,
            now_s,
            state=msg_state,
            task_id=tasks[name],
            carrying=f.carrying,
            flying_home=f.flying_home,
            on_pad=f.on_pad,
            finishing=f.finishing,
        )
        ends[name].send(MISSION_CONTROL, encode(hb))
        for raw in ends[name].receive():
            msg = decode(raw)
            if isinstance(msg, Assign):
                tasks[name] = msg.task.id

    now = 0.0
    while now < 2.0:
        if tasks["brick-1"] is None:
            beat("brick-1", now, "idle", facts_of("idle"))
        else:
            beat("brick-1", now, state, facts)
        beat("brick-2", now, "idle", facts_of("idle"))
        mc.step(now)
        now += 0.5
    assert tasks["brick-1"] == "B0"
    while not mc.uavs["brick-1"].lost:  # brick-1 falls silent
        beat("brick-2", now, "idle", facts_of("idle"))
        mc.step(now)
        now += 0.5
    first = mc.history[0]
    assert (first.uav, first.status) == ("brick-1", "failed")
    return first.reason or ""


def test_mission_control_decides_carrying_from_the_fact_not_the_state_name() -> None:
    # an unfamiliar state name, but the UAV says a brick is on its magnet: lost with it
    assert _lost_while("hauling", UavFacts(carrying=True)) == (
        "uav lost (last heard in hauling, with brick 0 on its magnet)"
    )
    # a state name that used to mean carrying, but the UAV says it is not: lost without it
    assert _lost_while("transport", UavFacts()) == "uav lost"
