"""A resume recalls a UAV kept on a task that waits for a given-up one (issue 27, branch ``resume41``).

The guide: "a mission interrupted by a fault or a crash resumes without repeating or skipping work", and no timer
breaks a wait. Mission control stopped after the third failure of segment A0 was journaled (A0 given up) but before
the failure of B1, fetched while A0 was sprayed and recalled in that same event, reached the journal. The resumed
mission control keeps B1 on brick-1 and recalls it at once with the same reason as the run that gave A0 up
(tests/test_given_up_release.py), instead of leaving it at its hold point until ``hold_patience_s`` (240 s)."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from masonry.errors import PlanningError
from masonry.mission.control import MissionControl
from masonry.mission.control_results import given_up_reason
from masonry.mission.inproc import InprocBus
from masonry.mission.journal import Journal
from masonry.mission.messages import MISSION_CONTROL, Assign, Heartbeat, Recall, Result, decode, encode
from masonry.mission.uav_facts import facts_of
from masonry.planner.dispatch import Dispatcher
from masonry.ports import TaskResult
from test_given_up_release import FLEET, PLAN

STOP_S = 62.0  # the journal's last record: the resumed clock


class Uav:
    """A UAV on the bus by scripted steps: it holds the task it is given (or kept), fails it when recalled (a
    recall naming it, or none) and places B2 ``fly_s`` after it is given."""

    def __init__(self, bus: InprocBus, name: str, task_id: str | None = None, attempt: int = 0) -> None:
        self.name, self.link = name, bus.endpoint(name)
        self.task_id, self.attempt, self.t0_s = task_id, attempt, 0.0
        self.recalls: list[tuple[float, str]] = []

    def step(self, now_s: float, fly_s: float = 10.0) -> None:
        for msg in map(decode, self.link.receive()):
            if isinstance(msg, Assign):
                self.task_id, self.attempt, self.t0_s = msg.task.id, msg.attempt, now_s
            elif isinstance(msg, Recall) and self.task_id is not None and msg.task_id in (None, self.task_id):
                self.recalls.append((msg.time_s, msg.reason))
                self.result(now_s, TaskResult(self.task_id, "failed", now_s - self.t0_s, reason=msg.reason))
        if self.task_id == "B2" and now_s - self.t0_s >= fly_s:
            self.result(now_s, TaskResult("B2", "done", now_s - self.t0_s, placement_error_m=0.01))
        self.beat(now_s)

    def beat(self, now_s: float) -> None:
        state = "idle" if self.task_id is None else "transport"
        beat = Heartbeat(self.name, now_s, state=state, task_id=self.task_id, **asdict(facts_of(state)))
        self.link.send(MISSION_CONTROL, encode(beat))

    def result(self, now_s: float, r: TaskResult) -> None:
        msg = Result(self.name, r, now_s, None, state="idle", attempt=self.attempt)
        self.link.send(MISSION_CONTROL, encode(msg))
        self.task_id = None


def fly_to_the_end(mc: MissionControl, uavs: dict[str, Uav]) -> None:
    """Step the scripted UAVs and mission control every 0.5 s from the resume until the mission ends (600 s at most)."""
    now_s = STOP_S
    while mc.ended_at_s is None and now_s < STOP_S + 600.0:
        for u in uavs.values():
            u.step(now_s)
        mc.step(now_s)
        now_s += 0.5


def test_a_uav_kept_on_a_task_over_a_given_up_segment_is_recalled_at_the_resume(tmp_path: Path) -> None:
    with Journal(tmp_path / "j.db") as j:
        for k, (start_s, end_s) in enumerate(((1.0, 20.0), (21.0, 40.0), (41.0, STOP_S))):
            j.record_assignment(start_s, "A0", "glue-1", k + 1)
            if k == 2:  # B1 fetched while A0 is sprayed the third time
                j.record_assignment(45.0, "B1", "brick-1", 1)
            j.record_failure(end_s, "A0", "glue-1", "the nozzle is clogged")
        state = j.replay()
    assert state.attempts == {"A0": 3} and dict(state.in_progress) == {"B1": "brick-1"}
    bus = InprocBus()
    uavs = {
        "brick-1": Uav(bus, "brick-1", "B1", 1),
        "brick-2": Uav(bus, "brick-2"),
        "glue-1": Uav(bus, "glue-1"),
    }
    mc = MissionControl(
        PLAN,
        FLEET,
        bus.endpoint(MISSION_CONTROL),
        reservation="site",
        max_attempts=3,
        heartbeat_timeout_s=5.0,
    )
    mc.restore(state)
    assert mc.dispatcher.stuck == {"A0"} and mc.dispatcher.in_progress == {"B1": "brick-1"}  # B1 kept
    fly_to_the_end(mc, uavs)
    why = given_up_reason("A0", "B1")
    assert uavs["brick-1"].recalls == [(STOP_S, why)]  # at the resume: not after 240 s
    b1 = [(a.uav, a.attempt, a.status, a.reason, a.end_s) for a in mc.history if a.task_id == "B1"]
    assert b1 == [("brick-1", 1, "failed", why, STOP_S)]  # its failure taken, in the first step
    assert mc.ended_at_s is not None and mc.ended_at_s - STOP_S <= 15.0  # ended once B2 is placed
    assert "B2" in mc.dispatcher.done and not mc.finished


def test_adopt_takes_a_prefetched_brick_only_under_the_site_reservation() -> None:
    for a0_attempts in (3, 1):  # A0 given up; A0 failed once, given out again after B1 (journaled after it)
        site = Dispatcher(PLAN, FLEET, reservation="site")
        site.restore([], {"A0": a0_attempts})
        site.adopt("B1", "brick-1")
        assert site.waiting_on("A0") == {"B1": "brick-1"}
        assert ("A0" in site.stuck) == (a0_attempts == 3)
    site.adopt("A0", "glue-1")
    assert site.in_progress == {"B1": "brick-1", "A0": "glue-1"}
    task = Dispatcher(PLAN, FLEET, reservation="task")
    task.restore([], {"A0": 3})
    with pytest.raises(PlanningError, match="prerequisites"):
        task.adopt("B1", "brick-1")
