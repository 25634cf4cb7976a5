"""A resumed mission control keeps the attempts in flight at the stop with their UAVs (chaos campaign, issue 18).

Found by the campaign (seed 106, arducopter): a UAV cut off from mission control finished its segment; the
completion never reached the journal before mission control stopped, and the resumed mission gave the segment
out again: sprayed twice. Now an attempt in progress at the stop stays with its UAV until the UAV is heard: its
completion (said again, first thing) is taken, a heartbeat naming the task keeps it flying, one naming no task
gives it back to the pool without counting an attempt, and silence declares the UAV lost. The in-process
simulation's UAVs keep an unheard completion in the journal file, because a stop of ``masonry sim`` stops them
too.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from masonry.blueprint import UavSpec, load_blueprint
from masonry.errors import PlanningError
from masonry.mission.chaos import ChaosRun, LinkDrop, check_chaos, fly_chaos
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.journal import Journal
from masonry.mission.messages import MISSION_CONTROL, Assign, Heartbeat, Result, decode, encode
from masonry.mission.uav_facts import facts_of
from masonry.planner.dispatch import Dispatcher
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import TaskResult
from masonry.sim import Faults

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def two_bricks() -> Plan:
    """B0 and B1 conflict (0.2 m apart)."""
    return Plan(
        (
            BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),
            BrickTask("B1", 1, False, (0.2, 0, 0.1), 0.0, (5, 1, 0.05)),
        ),
        (),
        (("B0", "B1"),),
    )


def fleet(n: int) -> tuple[UavSpec, ...]:
    return tuple(UavSpec(f"brick-{i + 1}", "brick", (i * 3.0, -3.0, 0.0)) for i in range(n))


class Uav:
    """A UAV on the bus by hand: heartbeats, the assignments it got, results."""

    def __init__(self, bus: InprocBus, name: str) -> None:
        self.name, self.t = name, bus.endpoint(name)
        self.assigned: list[Assign] = []

    def beat(self, now_s: float, task_id: str | None = None, state: str = "idle") -> None:
        self.t.send(
            MISSION_CONTROL,
            encode(Heartbeat(self.name, now_s, state=state, task_id=task_id, **asdict(facts_of(state)))),
        )
        self.read()

    def read(self) -> None:
        for raw in self.t.receive():
            msg = decode(raw)
            if isinstance(msg, Assign):
                self.assigned.append(msg)

    def done(self, now_s: float, task_id: str, attempt: int) -> None:
        res = TaskResult(task_id, "done", 30.0, placement_error_m=0.01)
        self.t.send(
            MISSION_CONTROL, encode(Result(self.name, res, now_s, None, state="idle", attempt=attempt))
        )


def resumed(tmp_path: Path, n: int = 2) -> tuple[InprocBus, MissionControl]:
    """Mission control resumed from a journal whose run stopped while brick-1 flew B0 (its second attempt)."""
    with Journal(tmp_path / "j.db") as j:
        j.record_assignment(1.0, "B0", "brick-1", 1)
        j.record_failure(20.0, "B0", "brick-1", "grasp failed")
        j.record_assignment(21.0, "B0", "brick-1", 2)
        state = j.replay()
    bus = InprocBus()
    mc = MissionControl(
        two_bricks(), fleet(n), bus.endpoint(MISSION_CONTROL), heartbeat_timeout_s=5.0, reservation="task"
    )
    mc.restore(state)
    return bus, mc


def test_an_attempt_in_flight_at_the_stop_stays_with_its_uav_and_its_completion_is_taken(tmp_path):
    bus, mc = resumed(tmp_path)
    b1, b2 = Uav(bus, "brick-1"), Uav(bus, "brick-2")
    assert mc.dispatcher.in_progress == {"B0": "brick-1"}
    now = 60.0
    for _ in range(6):  # brick-1 says it still flies B0; brick-2 is idle
        b1.beat(now, "B0", state="transport")
        b2.beat(now)
        mc.step(now)
        now += 0.5
    b1.read()
    b2.read()
    assert (
        b1.assigned == [] and [a.task.id for a in b2.assigned] == []
    )  # B1 conflicts with B0: nobody flies it
    b1.done(now, "B0", attempt=2)
    mc.step(now)
    b2.beat(now)
    mc.step(now)
    b1.read()
    b2.read()
    assert "B0" in mc.dispatcher.done
    assert [(a.task_id, a.uav, a.attempt, a.status) for a in mc.history if a.task_id == "B0"] == [
        ("B0", "brick-1", 1, "failed"),
        ("B0", "brick-1", 2, "done"),
    ]
    assert [a.task.id for a in b1.assigned + b2.assigned] == ["B1"]  # and only now the conflicting task


def test_a_uav_that_names_no_task_after_the_resume_gives_it_back_without_counting_an_attempt(tmp_path):
    bus, mc = resumed(tmp_path, n=1)
    b1 = Uav(bus, "brick-1")
    now = 60.0
    for _ in range(4):
        b1.beat(now)  # a rebuilt UAV: on its pad, no task
        mc.step(now)
        now += 0.5
    b1.read()
    first = next(a for a in mc.history if a.attempt == 2)
    assert first.status == "failed" and first.reason.startswith("uav dropped the task")
    assert mc.dispatcher.attempts["B0"] == 1  # the grasp failure only
    # flown again, as a new assignment: attempt 3 (its count against the task's limit is still 2: issue 27,
    # branch ``attempt43``; before, it was attempt 2 again, and anything naming the dropped one named it too)
    assert [(a.task.id, a.attempt) for a in b1.assigned] == [("B0", 3)]
    assert mc.dispatcher.attempt_of("B0") == 2


def test_a_uav_never_heard_after_the_resume_is_declared_lost_and_its_task_goes_to_another(tmp_path):
    bus, mc = resumed(tmp_path)
    b2 = Uav(bus, "brick-2")
    now = 60.0
    while not mc.uavs["brick-1"].lost and now < 200.0:
        b2.beat(now, b2.assigned[-1].task.id if b2.assigned else None)
        mc.step(now)
        now += 0.5
    b2.beat(now)
    mc.step(now)
    b2.read()
    assert mc.uavs["brick-1"].lost
    assert [a.task.id for a in b2.assigned][:1] == ["B0"]


def test_a_completion_said_after_the_uavs_loss_is_taken_late(tmp_path):
    """The UAV was declared lost in the journal before the stop (its attempt released): its kept completion, said
    after the resume, is still taken (the journal's loss is a failure ``uav lost``, as in the run that saw it)."""
    with Journal(tmp_path / "j.db") as j:
        j.record_assignment(1.0, "B0", "brick-1", 1)
        j.record_uav_lost(9.0, "brick-1")
        state = j.replay()
    bus = InprocBus()
    mc = MissionControl(two_bricks(), fleet(2), bus.endpoint(MISSION_CONTROL), heartbeat_timeout_s=5.0)
    mc.restore(state)
    assert mc.uavs["brick-1"].lost and mc.dispatcher.in_progress == {}
    b1 = Uav(bus, "brick-1")
    b1.done(12.0, "B0", attempt=1)
    b1.beat(12.0)
    mc.step(12.0)
    assert "B0" in mc.dispatcher.done and not mc.uavs["brick-1"].lost


def test_dispatcher_adopt_checks_what_it_is_given():
    d = Dispatcher(two_bricks(), fleet(2))
    d.restore([], {"B0": 1})
    d.adopt("B0", "brick-1")
    assert d.in_progress == {"B0": "brick-1"} and d.attempt_of("B0") == 2
    assert [a.task_id for a in d.assign()] == []  # B1 conflicts with B0 (``task`` reservation)
    for task, uav in (("B0", "brick-2"), ("B1", "brick-1"), ("B9", "brick-2"), ("B1", "brick-9")):
        with pytest.raises(PlanningError):
            d.adopt(task, uav)


class Keeper:
    def __init__(self, kept: bytes | None = None) -> None:
        self.store = {"brick-1": kept}
        self.writes: list[bytes | None] = []

    def kept(self, uav: str) -> bytes | None:
        return self.store.get(uav)

    def keep(self, uav: str, message: bytes | None) -> None:
        self.store[uav] = message
        self.writes.append(message)


def test_a_restarted_handler_says_its_kept_completion_ahead_of_its_first_heartbeat():
    bus = InprocBus()
    mc_end = bus.endpoint(MISSION_CONTROL)
    kept = encode(Result("brick-1", TaskResult("B0", "done", 30.0), 41.0, None, state="idle", attempt=2))
    keeper = Keeper(kept)
    h = UavHandler("brick-1", bus.endpoint("brick-1"), keeper=keeper)
    h.step(50.0)
    first, second = [decode(m) for m in mc_end.receive()][:2]
    assert isinstance(first, Result) and first.result.task_id == "B0" and first.attempt == 2
    assert isinstance(second, Heartbeat) and second.task_id is None
    mc_end.send("brick-1", encode(Heartbeat(MISSION_CONTROL, 50.5, state="running")))
    h.step(50.5)
    again = [decode(m) for m in mc_end.receive()]
    assert any(isinstance(m, Result) and m.result.task_id == "B0" for m in again)  # once more, when heard
    assert keeper.store["brick-1"] is None  # then forgotten


def test_a_handler_keeps_its_completion_until_mission_control_is_heard():
    keeper = Keeper()
    bus = InprocBus()
    mc_end = bus.endpoint(MISSION_CONTROL)
    h = UavHandler("brick-1", bus.endpoint("brick-1"), keeper=keeper)
    h.step(0.0)
    h.report_result(TaskResult("B0", "done", 30.0))
    assert isinstance(decode(keeper.store["brick-1"]), Result)
    mc_end.send("brick-1", encode(Heartbeat(MISSION_CONTROL, 0.5, state="running")))
    h.step(0.5)
    assert keeper.store["brick-1"] is None
    unreadable = Keeper(b"not a message")
    assert UavHandler("brick-1", InprocBus().endpoint("brick-1"), keeper=unreadable)._kept is None


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_segment_finished_cut_off_is_not_sprayed_again_after_a_stop(tmp_path, vehicle):
    """The case study: glue-1's radio is down from 13.5 s to 21.5 s, over A0's end; mission control stops at 17 s."""
    run = ChaosRun(
        5, load_blueprint(CASE_STUDY), Faults(), (17.0,), (LinkDrop("glue-1", 13.5, 8.0),), vehicle
    )
    out = fly_chaos(run, tmp_path)
    assert check_chaos(out) == []
    a0 = [e for e in out.trace if e.task_id == "A0" and e.status == "done"]
    assert len(a0) == 1 and a0[0].segment == 0  # done before the stop, taken after it
    assert out.report.completed


def test_a_kept_attempts_completion_is_taken_however_soon_after_the_resume_it_comes(tmp_path):
    """The resumed clock starts at the journal's last record (21 s here), not when mission control came back:
    the completion of an attempt kept from before is not judged too short for its task."""
    bus, mc = resumed(tmp_path)
    b1 = Uav(bus, "brick-1")
    b1.done(21.2, "B0", attempt=2)
    mc.step(21.2)
    assert "B0" in mc.dispatcher.done and mc.events.ignored == {}
