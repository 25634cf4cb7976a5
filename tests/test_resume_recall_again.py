"""A resume's recall lost on the way is said again (issue 27, branch ``recall41``).

The guide: "treat the network as hostile", and no timer breaks a wait. The resumed mission control recalls the UAV
kept on a task that waits for a given-up one (tests/test_resume_given_up.py), but over Zenoh a message sent straight
after the session opens can be lost before it finds its peers. Each heartbeat naming such a task brings the recall
again, with the same reason, until the UAV's failure is taken. The recall names the task and its attempt (protocol
version 6, branch ``recall42``): the handler ignores one naming an assignment it does not hold, so one said again
cannot fail an assignment that comes after it."""

from __future__ import annotations

from pathlib import Path

from masonry.mission.control import MissionControl
from masonry.mission.control_results import given_up_reason
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus, InprocTransport
from masonry.mission.journal import Journal
from masonry.mission.journal_state import JournalState
from masonry.mission.messages import MISSION_CONTROL, Assign, Recall, Result, decode, encode
from test_given_up_release import FLEET, PLAN
from test_resume_given_up import STOP_S, Uav, fly_to_the_end

WHY = given_up_reason("A0", "B1")


class LosesFirstRecall:
    """Mission control's transport on a hostile network: the first recall to ``uav`` is lost; every recall sent
    to it is counted."""

    def __init__(self, inner: InprocTransport, uav: str) -> None:
        self.inner, self.uav = inner, uav
        self.recalls: list[Recall] = []
        self.lost = 0

    @property
    def name(self) -> str:
        return self.inner.name

    def send(self, to: str, payload: bytes) -> None:
        msg = decode(payload)
        if to == self.uav and isinstance(msg, Recall):
            self.recalls.append(msg)
            if len(self.recalls) == 1:
                self.lost += 1
                return
        self.inner.send(to, payload)

    def receive(self) -> list[bytes]:
        return self.inner.receive()

    def close(self) -> None:
        self.inner.close()


def journal_with_a0_given_up(path: Path) -> JournalState:
    """The journal of tests/test_resume_given_up.py: A0 given up, B1 still on brick-1 at the stop."""
    with Journal(path) as j:
        for k, (start_s, end_s) in enumerate(((1.0, 20.0), (21.0, 40.0), (41.0, STOP_S))):
            j.record_assignment(start_s, "A0", "glue-1", k + 1)
            if k == 2:
                j.record_assignment(45.0, "B1", "brick-1", 1)
            j.record_failure(end_s, "A0", "glue-1", "the nozzle is clogged")
        return j.replay()


def resumed(tmp_path: Path, bus: InprocBus) -> tuple[MissionControl, LosesFirstRecall]:
    out = LosesFirstRecall(bus.endpoint(MISSION_CONTROL), "brick-1")
    mc = MissionControl(PLAN, FLEET, out, reservation="site", max_attempts=3, heartbeat_timeout_s=5.0)
    mc.restore(journal_with_a0_given_up(tmp_path / "j.db"))
    return mc, out


def test_the_resumes_recall_lost_is_sent_again_on_the_heartbeat_naming_the_task(tmp_path: Path) -> None:
    bus = InprocBus()
    uavs = {
        "brick-1": Uav(bus, "brick-1", "B1", 1),
        "brick-2": Uav(bus, "brick-2"),
        "glue-1": Uav(bus, "glue-1"),
    }
    mc, out = resumed(tmp_path, bus)
    assert out.lost == 1 and out.recalls[0].reason == WHY  # the resume's recall: lost
    assert (out.recalls[0].task_id, out.recalls[0].attempt) == ("B1", 1)  # it names what it recalls
    fly_to_the_end(mc, uavs)
    assert uavs["brick-1"].recalls == [(STOP_S, WHY)]  # its first heartbeat brought it: the same reason
    assert [(r.reason, r.task_id, r.attempt) for r in out.recalls] == [(WHY, "B1", 1)] * 2  # lost once, sent
    # once again: its failure then taken
    b1 = [(a.uav, a.attempt, a.status, a.reason, a.end_s) for a in mc.history if a.task_id == "B1"]
    assert b1 == [("brick-1", 1, "failed", WHY, STOP_S + 0.5)]  # one step later than with no loss
    assert mc.ended_at_s is not None and mc.ended_at_s - STOP_S <= 15.0
    assert "B2" in mc.dispatcher.done and not mc.finished


def test_each_heartbeat_naming_the_task_brings_the_recall_until_the_failure_is_taken(tmp_path: Path) -> None:
    bus = InprocBus()
    brick_1 = Uav(bus, "brick-1", "B1", 1)
    mc, out = resumed(tmp_path, bus)
    for k in range(3):  # three heartbeats said before the UAV reads a message (a storm, or a slow UAV)
        brick_1.beat(STOP_S + k)
        mc.step(STOP_S + k)
    sent = [(r.time_s, r.reason) for r in out.recalls]
    assert sent == [
        (STOP_S, WHY),
        (STOP_S, WHY),
        (STOP_S + 1.0, WHY),
        (STOP_S + 2.0, WHY),
    ]  # one per heartbeat
    brick_1.step(STOP_S + 3.0)  # it reads the three: fails B1 once, the later two finding no task
    assert brick_1.recalls == [(STOP_S, WHY)]
    mc.step(STOP_S + 3.0)
    assert mc.dispatcher.task_of("brick-1") is None and len(out.recalls) == 4  # its failure taken
    # (its heartbeat names no task now: no recall more)
    brick_1.step(STOP_S + 4.0)
    mc.step(STOP_S + 4.0)
    assert len(out.recalls) == 4


def test_a_recall_said_again_does_not_fail_the_assignment_after_it() -> None:
    bus = InprocBus()
    mc_end = bus.endpoint(MISSION_CONTROL)
    h = UavHandler("brick-2", bus.endpoint("brick-2"))
    b2 = PLAN.tasks[2]
    mc_end.send(
        "brick-2", encode(Recall(MISSION_CONTROL, "brick-2", 1.0, WHY, "B1", 1))
    )  # said again: B1 is over
    mc_end.send("brick-2", encode(Assign(MISSION_CONTROL, "brick-2", b2, 1, 1.0)))
    h.step(1.0)
    h.step(1.5)
    sent = [decode(raw) for raw in mc_end.receive()]
    assert not [m for m in sent if isinstance(m, Result)]  # B2 not failed back
    assert h.busy and h.poll_task() == b2
    assert h.stale_recalls == 1 and [(r.task_id, r.attempt) for r in h.stale] == [
        ("B1", 1)
    ]  # ignored, visible
