"""A recall names the assignment it recalls (issue 27 §2, branch ``recall42``; protocol version 6).

The guide: "treat the network as hostile". Mission control says a recall again on each heartbeat naming a task that
waits in vain (``recall_again``), and a recall can cross its task's result on the way. A recall naming no task could
then fail whatever the UAV held when it arrived: the next task. Now a recall names the task and its attempt, and
the UAV's handler drops only that assignment, queued or in hand, ignoring (and counting) one naming an assignment
it does not hold. The operator's recall names none: it drops whatever the UAV holds when it reads it."""

from __future__ import annotations

import json
import logging

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.errors import ProtocolError
from masonry.mission.auth import AuthenticatedTransport
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.ledger import AttemptLedger
from masonry.mission.messages import (
    MISSION_CONTROL,
    PROTOCOL_VERSION,
    Assign,
    Heartbeat,
    Recall,
    Result,
    decode,
    encode,
)
from masonry.mission.transport import Transport
from masonry.planner.tasks import BrickTask, Task
from masonry.ports import TaskResult

UAV = "brick-1"
FLEET = {UAV}
KEY = bytes(range(32))


def brick(task_id: str) -> BrickTask:
    n = int(task_id[1:])
    return BrickTask(task_id, n, False, (float(n), 0.0, 0.15), 0.0, (5.0, 0.0, 0.05))


class Machine:
    """A scripted UAV machine (no physics): takes the next task when it has none, holds it until ``finish`` is
    set, and may always abort (it reports the failure and drops the task)."""

    def __init__(self, link: UavHandler) -> None:
        self.link = link
        self.task: Task | None = None
        self.finish = False
        self.now_s = 0.0
        self.state = "idle"

    @property
    def finished(self) -> bool:
        return self.task is None

    def may_abort(self) -> bool:
        return True

    def abort(self, reason: str) -> None:
        assert self.task is not None
        self.link.report_result(TaskResult(self.task.id, "failed", 1.0, reason=reason))
        self.task, self.state = None, "idle"

    def step(self, now_s: float) -> None:
        self.now_s = now_s
        if self.task is not None and self.finish:
            self.finish = False
            self.link.report_result(TaskResult(self.task.id, "done", 1.0, placement_error_m=0.01))
            self.task = None
        if self.task is None:
            self.task = self.link.poll_task()
        self.state = "idle" if self.task is None else "transport"


class Rig:
    """One UAV handler with a scripted machine, and mission control's raw endpoint on the same bus."""

    def __init__(self, wrap: bool = False) -> None:
        bus = InprocBus()
        mc: Transport = bus.endpoint(MISSION_CONTROL)
        uav: Transport = bus.endpoint(UAV)
        if wrap:
            mc, uav = AuthenticatedTransport(mc, KEY), AuthenticatedTransport(uav, KEY)
        self.mc = mc
        self.h = UavHandler(UAV, uav)
        self.machine = Machine(self.h)
        self.h.attach(self.machine)
        self.now_s = 0.0
        self.results: list[Result] = []

    def send(self, msg: Assign | Recall) -> None:
        self.mc.send(UAV, encode(msg))

    def assign(self, task_id: str, attempt: int = 1) -> None:
        self.send(Assign(MISSION_CONTROL, UAV, brick(task_id), attempt, self.now_s))

    def recall(self, reason: str, task_id: str | None = None, attempt: int = 0) -> None:
        self.send(Recall(MISSION_CONTROL, UAV, self.now_s, reason, task_id, attempt))

    def step(self) -> list[Result]:
        """Mission control's heartbeat, then one tick of the handler; the results it sent in that tick."""
        self.mc.send(UAV, encode(Heartbeat(MISSION_CONTROL, self.now_s, state="running")))
        self.h.step(self.now_s)
        self.now_s += 0.5
        new = [m for m in map(decode, self.mc.receive()) if isinstance(m, Result)]
        self.results += new
        return new


def said(results: list[Result]) -> list[tuple[str, int, str, str | None]]:
    return [(r.result.task_id, r.attempt, r.result.status, r.result.reason) for r in results]


@pytest.mark.parametrize("wrap", [False, True], ids=["plain", "authenticated"])
@pytest.mark.parametrize("recall_first", [True, False], ids=["recall-then-assign", "assign-then-recall"])
def test_a_recall_of_a_task_the_uav_has_finished_does_not_fail_the_next_one(
    wrap: bool, recall_first: bool
) -> None:
    """The UAV places B1 while mission control recalls it (the recall crossed its result), then is given B2: the
    recall of B1, read in the same batch as B2's assignment (either order), is ignored, and B2 is flown."""
    rig = Rig(wrap)
    rig.assign("B1")
    rig.step()
    assert rig.machine.task is not None and rig.machine.task.id == "B1"
    rig.machine.finish = True
    assert said(rig.step()) == [("B1", 1, "done", None)]
    if recall_first:
        rig.recall("B0 under B1 was given up", "B1", 1)
        rig.assign("B2")
    else:
        rig.assign("B2")
        rig.recall("B0 under B1 was given up", "B1", 1)
    rig.step()
    rig.step()
    assert rig.machine.task is not None and rig.machine.task.id == "B2"  # B2 in hand, not failed back
    assert said(rig.results) == [("B1", 1, "done", None)]
    assert rig.h.stale_recalls == 1 and rig.h.stale[0].task_id == "B1"
    rig.machine.finish = True
    rig.step()
    assert said(rig.results)[-1] == ("B2", 1, "done", None)


def test_a_recall_of_another_attempt_of_the_same_task_is_ignored() -> None:
    """B1's first attempt recalled (said again, late) while the UAV flies B1's second: the second flies on."""
    rig = Rig()
    rig.assign("B1", attempt=2)
    rig.step()
    rig.recall("the glue under B1 expired", "B1", 1)
    rig.step()
    assert rig.machine.task is not None and rig.machine.task.id == "B1" and rig.results == []
    rig.recall("the glue under B1 expired", "B1", 2)
    rig.step()
    assert said(rig.results) == [("B1", 2, "failed", "the glue under B1 expired")]


def test_a_recall_of_a_queued_task_drops_only_that_one() -> None:
    """B1 in hand, B2 and B3 queued: the recall of B2 fails B2 back at once; B1 and B3 are flown."""
    rig = Rig()
    rig.assign("B1")
    rig.step()
    rig.assign("B2")
    rig.assign("B3")
    rig.recall("recalled", "B2", 1)
    assert said(rig.step()) == [("B2", 1, "failed", "recalled")]
    for _ in range(2):
        rig.machine.finish = True
        rig.step()
    assert said(rig.results) == [
        ("B2", 1, "failed", "recalled"),
        ("B1", 1, "done", None),
        ("B3", 1, "done", None),
    ]


def test_the_operators_recall_names_no_task_and_drops_whatever_the_uav_holds_when_it_reads_it() -> None:
    """``masonry ctl recall`` (and return-all, abort): whatever the UAV holds, in hand and queued, when it reads
    the recall; an assignment read after it in the same batch (the operator resumed meanwhile) is flown."""
    rig = Rig()
    rig.assign("B1")
    rig.step()
    rig.assign("B2")
    rig.recall("recalled by the operator")
    rig.assign("B3")
    assert sorted(said(rig.step())) == [
        ("B1", 1, "failed", "recalled by the operator"),
        ("B2", 1, "failed", "recalled by the operator"),
    ]
    rig.step()
    assert rig.machine.task is not None and rig.machine.task.id == "B3"
    assert rig.h.stale_recalls == 0
    rig.machine.finish = True
    rig.step()
    rig.recall("recalled by the operator")  # nothing held: nothing to drop, nothing stale
    rig.step()
    assert said(rig.results)[-1] == ("B3", 1, "done", None) and rig.h.stale_recalls == 0


def test_the_recall_names_its_assignment_on_the_wire() -> None:
    for msg in (
        Recall(MISSION_CONTROL, UAV, 3.0, "A0 under B1 was given up", "B1", 2),
        Recall(MISSION_CONTROL, UAV, 3.0, "recalled by the operator"),
    ):
        body = json.loads(encode(msg))
        assert body["v"] == PROTOCOL_VERSION >= 6  # (7: the plan progress, branch progress51)
        assert (body["task_id"], body["attempt"]) == (msg.task_id, msg.attempt)
        assert decode(encode(msg), FLEET) == msg


@pytest.mark.parametrize(
    "task_id, attempt, match",
    [
        ("B1", 0, "'attempt' must be >= 1 for task B1"),
        (None, 2, "'attempt' must be 0 when no task is named"),
        ("", 1, "'task_id' must be a non-empty string"),
        ("B1", "1", "'attempt' must be an integer"),
    ],
)
def test_a_recall_naming_its_assignment_badly_is_refused(
    task_id: object, attempt: object, match: str
) -> None:
    body = json.loads(encode(Recall(MISSION_CONTROL, UAV, 3.0, "recalled")))
    body.update(task_id=task_id, attempt=attempt)
    with pytest.raises(ProtocolError, match=match):
        decode(json.dumps(body), FLEET)


@pytest.mark.parametrize("wrap", [False, True], ids=["plain", "authenticated"])
def test_a_version_5_recall_is_refused_with_one_line_and_nothing_is_dropped(
    wrap: bool, caplog: pytest.LogCaptureFixture
) -> None:
    """A mission control of the previous version recalls with no task named: the handler refuses the frame (one
    warning line naming both versions, counted in ``rejected``) and flies on; inside authenticated frames too."""
    rig = Rig(wrap)
    rig.assign("B1")
    rig.step()
    old = json.loads(encode(Recall(MISSION_CONTROL, UAV, 1.0, "recalled by the operator")))
    old["v"] = 5
    del old["task_id"], old["attempt"]
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="masonry.mission.handler"):
        rig.mc.send(UAV, json.dumps(old).encode())
        rig.step()
    lines = [r.getMessage() for r in caplog.records if "rejected" in r.getMessage()]
    assert lines == [
        f"{UAV} rejected a message: message has protocol version 5; this side speaks {PROTOCOL_VERSION}"
    ]
    assert rig.h.rejected == 1 and rig.results == []
    assert rig.machine.task is not None and rig.machine.task.id == "B1"


# -- interleavings ----------------------------------------------------------------------------------------------

EVENT = st.one_of(
    st.tuples(st.just("assign"), st.sampled_from(["B1", "B2", "B3"])),
    st.tuples(
        st.just("recall"), st.integers(0, 8)
    ),  # names the k-th assignment sent so far (mod), or none (8)
    st.tuples(st.just("finish"), st.just("")),
    st.tuples(st.just("step"), st.just("")),
)


@settings(max_examples=300, deadline=None)
@given(st.lists(EVENT, min_size=1, max_size=40))
def test_over_any_interleaving_a_recall_fails_only_what_it_names_and_held_when_read(events: list) -> None:
    """Assignments, recalls (of any assignment sent so far, or of none), completions and ticks in any order: each
    assignment has at most one result; a failure always comes from a recall read after its assignment that named
    it (or none); and a recall read while its assignment is held fails it in that tick. The assignments are
    numbered as mission control numbers them (its :class:`AttemptLedger`: one more for each assignment of a task,
    whether what ended the one before counted or not, issue 27 branch ``attempt43``), so a task given again after
    its recall (not counted) is a new assignment that a recall of the old one cannot fail."""
    rig = Rig()
    assigns: list[tuple[str, int]] = []  # in the order sent
    ledger = AttemptLedger(None)  # (mission control's numbering of the assignments)
    recalls: list[tuple[str | None, int, int]] = []  # (task, attempt, assignments sent before it)
    pending: list[int] = []  # recalls sent, not read yet
    read_at: dict[int, int] = {}  # recall -> the tick it was read in
    result_at: dict[tuple[str, int], tuple[int, Result]] = {}
    tick = 0

    def step() -> None:
        nonlocal tick
        for k in pending:
            read_at[k] = tick
        pending.clear()
        for r in rig.step():
            key = (r.result.task_id, r.attempt)
            assert key not in result_at, f"two results for {key}"
            result_at[key] = (tick, r)
        tick += 1

    for kind, arg in [*events, ("step", ""), ("step", "")]:
        if kind == "assign":
            number = ledger.begin(arg, UAV, rig.now_s).attempt
            assigns.append((arg, number))
            rig.assign(arg, number)
        elif kind == "recall":
            k = len(recalls)
            task, attempt = assigns[arg % len(assigns)] if assigns and arg < 8 else (None, 0)
            recalls.append((task, attempt, len(assigns)))
            rig.recall(f"r{k}", task, attempt)
            pending.append(k)
        elif kind == "finish":
            rig.machine.finish = True
        else:
            step()

    for key, (at, r) in result_at.items():
        assert key in assigns
        if r.result.status == "failed":
            k = int((r.result.reason or "")[1:])
            task, attempt, before = recalls[k]
            assert task is None or (task, attempt) == key, f"{key} failed by a recall of {(task, attempt)}"
            assert assigns.index(key) < before and read_at[k] == at
    for k, (task, attempt, before) in enumerate(recalls):
        if k not in read_at:
            continue
        named = [a for a in assigns[:before] if task is None or a == (task, attempt)]
        for key in named:
            done_before = key in result_at and result_at[key][0] < read_at[k]
            if not done_before:  # held when the recall was read: failed in that tick, by a recall read then
                at, r = result_at[key]
                assert at == read_at[k] and r.result.status == "failed", f"recall r{k} of {key} not applied"
