"""Every assignment mission control makes has its own number (issue 27 §2, branch ``attempt43``).

A recall names the task and the attempt it recalls, and a result the attempt it answers (protocol version 6). The
attempt number was the count of the task's attempts that counted against its ``max_attempts``, plus one: a flight
that failed for a reason that is not the task's (a lost link, the operator's recall, the battery, mission control
lost, a task its UAV forgot) was followed by one with the same number, and a stale recall or result of the first
flight matched the second. Now the attempt ledger numbers each assignment of a task, one more each time, journaled
with it and carried on by a resumed mission control; how many attempts count against the task's limit is the
dispatcher's, as before, and is what the report's ``attempts`` says.
"""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus, InprocTransport
from masonry.mission.journal import Journal
from masonry.mission.messages import MISSION_CONTROL, Assign, Heartbeat, Recall, Result, decode, encode
from masonry.mission.report import control_report
from masonry.mission.uav_facts import facts_of
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import BATTERY_LOW_REASON, RECALL_REASON, TaskResult
from test_recall_names_task import Machine  # the scripted UAV machine (no physics)

UAV = "brick-1"
FLEET = (UavSpec(UAV, "brick", (0.0, -3.0, 0.0)),)
PLAN = Plan((BrickTask("B0", 0, False, (0.0, 0.0, 0.1), 0.0, (5.0, 0.0, 0.05)),), (), ())
STALE_WHY = "the glue under B0 expired"


class Recorded:
    """A UAV's transport that keeps every frame it sent, so that the network can deliver one again."""

    def __init__(self, inner: InprocTransport) -> None:
        self.inner = inner
        self.sent: list[bytes] = []

    @property
    def name(self) -> str:
        return self.inner.name

    def send(self, to: str, payload: bytes) -> None:
        self.sent.append(payload)
        self.inner.send(to, payload)

    def receive(self) -> list[bytes]:
        return self.inner.receive()

    def close(self) -> None:
        self.inner.close()


class Site:
    """Mission control with its defaults and one brick UAV (a real handler, a scripted machine) on one bus."""

    def __init__(self, journal: Journal | None = None) -> None:
        self.bus = InprocBus()
        self.mc = MissionControl(PLAN, FLEET, self.bus.endpoint(MISSION_CONTROL), journal=journal)
        self.link = Recorded(self.bus.endpoint(UAV))
        self.handler = UavHandler(UAV, self.link, position=lambda: (0.0, -3.0, 0.0))
        self.machine = Machine(self.handler)
        self.handler.attach(self.machine)
        self.now_s = 0.0

    def step(self, n: int = 1) -> None:
        for _ in range(n):
            self.handler.step(self.now_s)
            self.mc.step(self.now_s)
            self.now_s += 0.5

    def command(self, **command: str) -> None:
        self.mc.operator.submit(command)
        self.step(4)

    def number(self) -> int:
        """The number of the attempt mission control has running for B0."""
        return self.mc.ledger.running["B0"].attempt


def _first_flight_recalled_by_the_operator(site: Site) -> tuple[int, bytes]:
    """B0 given to brick-1, recalled by the operator (not counted), given to it again: the first flight's number
    and the frame of its failure, as the handler sent it."""
    site.step(6)
    assert site.machine.task is not None and site.machine.task.id == "B0"
    first = site.number()
    site.command(command="recall", uav=UAV)
    failed = [raw for raw in site.link.sent if isinstance(m := decode(raw), Result) and m.result.reason]
    assert len(failed) == 1 and site.machine.task is None
    site.command(command="resume")
    assert site.machine.task is not None and site.machine.task.id == "B0"  # flown again by the same UAV
    return first, failed[0]


def test_a_stale_recall_or_result_of_a_flight_the_operator_recalled_does_not_end_the_next_one() -> None:
    """B0's first flight is recalled by the operator (not counted) and B0 given to the same UAV again. Then the
    network delivers the first flight's failure again, and a recall naming the first flight (one said again, or
    late: the glue under the brick expired while it flew): the second flight flies on and completes."""
    site = Site()
    first, failure = _first_flight_recalled_by_the_operator(site)
    second = site.number()
    site.link.inner.send(MISSION_CONTROL, failure)  # the first flight's failure, delivered again
    site.mc.recall(UAV, site.now_s, STALE_WHY, "B0", first)  # a recall naming the first flight
    site.step(4)
    assert [(a.attempt, a.status) for a in site.mc.history] == [(first, "failed"), (second, "running")]
    assert site.machine.task is not None and site.machine.task.id == "B0"  # the second flight flies on
    assert site.mc.dispatcher.in_progress == {"B0": UAV} and site.number() == second
    assert site.handler.stale_recalls == 1 and site.mc.events.ignored == {"wrong-attempt": 1}
    site.machine.finish = True
    site.step(4)
    assert site.mc.finished
    history = [(a.attempt, a.status, a.reason) for a in site.mc.history]
    assert history == [(first, "failed", RECALL_REASON), (second, "done", None)] and second == first + 1
    # the retry limit counts only what counts: one attempt, the one that placed the brick
    assert site.mc.dispatcher.attempts == {"B0": 1}
    (task,) = control_report(site.mc, PLAN, policy="critical-path").to_dict()["tasks"]
    assert task["attempts"] == 1 and [d["outcome"] for d in task["attempts_detail"]] == ["failed", "done"]


def test_a_recall_naming_the_second_flight_still_ends_it() -> None:
    """The other half: a recall naming the assignment flown now drops it (not counted), and the next one is 3."""
    site = Site()
    _first_flight_recalled_by_the_operator(site)
    site.mc.recall(UAV, site.now_s, f"{RECALL_REASON}: B0 was done by brick-2", "B0", site.number())
    site.step(4)
    assert [(a.attempt, a.status) for a in site.mc.history] == [(1, "failed"), (2, "failed"), (3, "running")]
    assert site.mc.dispatcher.attempts == {} and site.handler.stale_recalls == 0


class ByHand:
    """brick-1 on the bus by hand: its heartbeats name the task it holds (its latest assignment until it reports
    on it or forgets it), it keeps its assignments and recalls, and sends results."""

    def __init__(self, bus: InprocBus) -> None:
        self.t = bus.endpoint(UAV)
        self.assigned: list[Assign] = []
        self.recalls: list[Recall] = []
        self.holding: Assign | None = None

    def beat(self, now_s: float) -> None:
        task_id = None if self.holding is None else self.holding.task.id
        state = "idle" if task_id is None else "transport"
        hb = Heartbeat(UAV, now_s, state=state, task_id=task_id, **asdict(facts_of(state)))
        self.t.send(MISSION_CONTROL, encode(hb))
        for raw in self.t.receive():
            msg = decode(raw)
            if isinstance(msg, Assign):
                self.assigned.append(msg)
                self.holding = msg
            elif isinstance(msg, Recall):
                self.recalls.append(msg)

    def result(self, now_s: float, reason: str | None = None, attempt: int | None = None) -> None:
        """A result of the assignment held (or of attempt ``attempt``): done, or failed with ``reason``."""
        if attempt is None:
            assert self.holding is not None
            attempt, self.holding = self.holding.attempt, None
        r = TaskResult("B0", "failed" if reason else "done", 40.0, reason=reason, placement_error_m=0.01)
        self.t.send(MISSION_CONTROL, encode(Result(UAV, r, now_s, None, state="idle", attempt=attempt)))


def _run(mc: MissionControl, uav: ByHand, now_s: float, steps: int) -> float:
    for _ in range(steps):
        uav.beat(now_s)
        mc.step(now_s)
        now_s += 0.5
    return now_s


def test_a_late_completion_of_a_lost_flight_is_told_from_the_next_assignment_to_the_same_uav() -> None:
    """brick-1 flies B0 (attempt 1), falls silent and is declared lost (released, not counted); heard again with no
    task it rejoins and is given B0 again (attempt 2). Then its completion of attempt 1 arrives, said again once
    mission control was heard: B0 was placed by the first flight. It is taken late, and the second flight is
    recalled by its number (before, both flights were attempt 1: the completion was taken for the second, which
    flew on to a place already taken)."""
    bus = InprocBus()
    mc = MissionControl(PLAN, FLEET, bus.endpoint(MISSION_CONTROL), heartbeat_timeout_s=5.0)
    b1 = ByHand(bus)
    now = _run(mc, b1, 0.0, 4)
    assert [(a.task.id, a.attempt) for a in b1.assigned] == [("B0", 1)]
    for _ in range(16):  # silent for 8 s
        mc.step(now)
        now += 0.5
    assert mc.uavs[UAV].lost and [a.reason.split(" (")[0] for a in mc.history] == ["uav lost"]
    b1.holding = None  # it placed B0 meanwhile, its completion unheard
    now = _run(mc, b1, now, 4)  # on its pad, holding nothing: back, and given B0 again
    assert [(a.task.id, a.attempt) for a in b1.assigned] == [("B0", 1), ("B0", 2)]
    b1.result(now, attempt=1)  # the first flight's completion, heard late
    now = _run(mc, b1, now, 2)
    assert "B0" in mc.dispatcher.done
    assert [(a.attempt, a.status) for a in mc.history] == [(1, "done"), (2, "failed")]
    assert [(r.task_id, r.attempt) for r in b1.recalls] == [("B0", 2)]
    assert mc.dispatcher.attempts == {"B0": 1}


def test_a_resumed_mission_control_never_gives_a_number_twice(tmp_path: Path) -> None:
    """The operator recalls B0's first flight (not counted) and mission control stops before giving it again: the
    resumed one gives it as attempt 2. It stops again while attempt 2 flies; brick-1's restarted handler holds
    nothing (the task goes back to the pool, not counted): given as attempt 3. The count against the limit is 0
    throughout; the journal keeps each assignment's number, and each failure names its own."""
    path = tmp_path / "j.db"
    with Journal(path) as journal:
        site = Site(journal)
        site.step(6)
        site.command(command="recall", uav=UAV)
        assert [(a.attempt, a.status) for a in site.mc.history] == [(1, "failed")]
    with Journal(path) as journal:
        state = journal.replay()
        site = Site(journal)
        site.mc.restore(state)
        site.now_s = state.last_time_s
        site.step(6)
        assert [(a.attempt, a.status) for a in site.mc.history] == [(1, "failed"), (2, "running")]
        assert dict(state.numbers) == {"B0": 1} and dict(state.attempts) == {} and state.running == ()
    with Journal(path) as journal:
        state = journal.replay()
        bus = InprocBus()
        mc = MissionControl(PLAN, FLEET, bus.endpoint(MISSION_CONTROL), journal=journal)
        mc.restore(state)
        b1 = ByHand(bus)
        _run(mc, b1, state.last_time_s + 10.0, 4)  # a restarted handler: on its pad, no task
        assert [(a.task.id, a.attempt) for a in b1.assigned] == [("B0", 3)]
        assert [(a.attempt, a.status) for a in mc.history] == [(1, "failed"), (2, "failed"), (3, "running")]
        assert mc.dispatcher.attempts == {}
        assert dict(state.numbers) == {"B0": 2}
        assert [(r.task_id, r.attempt) for r in state.running] == [("B0", 2)]
    with Journal(path) as journal:
        state = journal.replay()
        assert [(f.attempt, f.reason.split(" (")[0]) for f in state.failures] == [
            (1, RECALL_REASON),
            (2, "uav dropped the task"),
        ]
        assert dict(state.numbers) == {"B0": 3} and dict(state.attempts) == {}


def test_the_retry_limit_counts_only_failures_that_count() -> None:
    """max_attempts 2: two battery aborts, an operator recall and a task its UAV forgot (none counted) around a grasp
    failure (counted): B0 is still tried; stuck at the second grasp failure, its sixth assignment (numbered 6)."""
    bus = InprocBus()
    mc = MissionControl(PLAN, FLEET, bus.endpoint(MISSION_CONTROL), max_attempts=2)
    b1 = ByHand(bus)
    now = _run(mc, b1, 0.0, 4)
    for failure in [BATTERY_LOW_REASON, "grasp failed", BATTERY_LOW_REASON, RECALL_REASON, "forgotten"]:
        if failure == "forgotten":  # its handler restarted: released after the heartbeat timeout, not counted
            b1.holding = None
            now = _run(mc, b1, now, 14)
        else:
            b1.result(now, failure)
            now = _run(mc, b1, now, 2)
    assert mc.dispatcher.attempts == {"B0": 1} and not mc.dispatcher.stuck
    b1.result(now, "grasp failed")
    now = _run(mc, b1, now, 2)
    assert [a.attempt for a in b1.assigned] == [1, 2, 3, 4, 5, 6]
    assert mc.dispatcher.stuck == {"B0"} and mc.dispatcher.attempts == {"B0": 2}
    (task,) = control_report(mc, PLAN, policy="critical-path").to_dict()["tasks"]
    assert task["status"] == "stuck" and task["attempts"] == 2 and len(task["attempts_detail"]) == 6


# -- the numbering over any sequence of assignments, failures and stops --------------------------------------------

FAILURE = st.sampled_from(["grasp failed", BATTERY_LOW_REASON, RECALL_REASON, "stop"])


def _mission_control(journal: Journal) -> tuple[MissionControl, ByHand]:
    bus = InprocBus()
    mc = MissionControl(PLAN, FLEET, bus.endpoint(MISSION_CONTROL), journal=journal, max_attempts=9)
    return mc, ByHand(bus)


@settings(max_examples=60, deadline=None)
@given(st.lists(FAILURE, min_size=1, max_size=8))
def test_over_any_sequence_numbers_only_grow_and_the_count_is_the_counted_failures(
    tmp_path_factory, failures: list[str]
) -> None:
    """B0 given to brick-1, which ends each flight with a failure, counted or not, or mission control stops
    (resumed from its journal; the flight in progress is kept and then forgotten by the restarted handler, not
    counted): every assignment has a number one more than the one before, across every resume, and the count
    against the limit (``max_attempts`` 9) is the counted failures."""
    path = tmp_path_factory.mktemp("numbers") / "j.db"
    numbers: list[int] = []
    counted = 0
    journal = Journal(path).open()
    mc, b1 = _mission_control(journal)
    now = _run(mc, b1, 0.0, 4)
    try:
        for failure in failures:
            numbers.append(b1.assigned[-1].attempt)
            assert b1.holding is not None and b1.holding.attempt == numbers[-1]
            if failure == "stop":
                journal.close()
                journal = Journal(path).open()
                state = journal.replay()
                mc, b1 = _mission_control(journal)
                mc.restore(state)
                now = _run(mc, b1, state.last_time_s + 10.0, 8)  # it holds nothing: released, given again
            else:
                b1.result(now, failure)
                counted += failure == "grasp failed"
                now = _run(mc, b1, now, 2)
            assert b1.assigned and b1.assigned[-1].attempt not in numbers
    finally:
        journal.close()
    numbers.append(b1.assigned[-1].attempt)
    assert numbers == list(range(1, len(failures) + 2))
    assert mc.dispatcher.attempts.get("B0", 0) == counted and mc.ledger.number_of("B0") == numbers[-1]
