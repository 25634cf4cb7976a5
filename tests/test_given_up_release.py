"""A wait ended by the model, not a timer (issue 27, branch ``stuck41``; docs/safety.md, "Site reservation").

Under the ``site`` reservation a brick UAV fetches a brick while the segment under it is sprayed, and waits for
that segment at a hold point. When the segment is given up (it ran out of attempts), mission control recalls the
brick's UAV in the same event, its attempt failing with the reason, instead of leaving the wait to
``hold_patience_s`` (240 s)."""

from __future__ import annotations

import pytest

from masonry.blueprint import UavSpec
from masonry.blueprint_gen import running_bond
from masonry.fsm.adhesion import AdhesionUav
from masonry.mission.control import MissionControl
from masonry.mission.control_results import given_up_reason
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.simulate import SimulatedMission
from masonry.planner.dispatch import Dispatcher
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.ports import TaskResult

# A0 under B1 (B1 after A0); B2 on the ground, depending on nothing
PLAN = Plan(
    (
        AdhesionTask("A0", 0, 1, (0.0, 0.0, 0.1), (0.2, 0.0, 0.1), 0.3),
        BrickTask("B1", 1, False, (0.1, 0.0, 0.15), 0.0, (5.0, 0.0, 0.05)),
        BrickTask("B2", 2, False, (3.0, 0.0, 0.1), 0.0, (5.0, 0.0, 0.05)),
    ),
    (("B1", "A0"),),
    (),
)
FLEET = (
    UavSpec("brick-1", "brick", (0.0, -3.0, 0.0)),
    UavSpec("brick-2", "brick", (3.0, -3.0, 0.0)),
    UavSpec("glue-1", "adhesion", (0.0, -6.0, 0.0)),
)


class Machine:
    """A scripted UAV (no physics): a segment's spray always fails after ``fly_s`` (its nozzle is clogged); a
    brick whose segment is not done waits (at its hold point) until it is recalled; B2 is placed after ``fly_s``."""

    def __init__(self, link: UavHandler, fly_s: float) -> None:
        self.link, self.fly_s = link, fly_s
        self.task: AdhesionTask | BrickTask | None = None
        self.t0_s = 0.0
        self.now_s = 0.0
        self.aborted: list[tuple[float, str]] = []

    @property
    def finished(self) -> bool:
        return self.task is None

    def may_abort(self) -> bool:
        return True

    def abort(self, reason: str) -> None:
        assert self.task is not None
        self.aborted.append((self.now_s, reason))
        self.link.report_result(TaskResult(self.task.id, "failed", self.now_s - self.t0_s, reason=reason))
        self.task = None

    def step(self, now_s: float) -> None:
        self.now_s = now_s
        if self.task is None:
            self.task = self.link.poll_task()
            self.t0_s = now_s
            return
        if now_s - self.t0_s < self.fly_s or self.task.id == "B1":
            return  # (B1 waits for A0, which is never done)
        status, reason = ("failed", "the nozzle is clogged") if self.task.id == "A0" else ("done", None)
        self.link.report_result(TaskResult(self.task.id, status, now_s - self.t0_s, reason=reason))
        self.task = None


def test_a_waiting_brick_is_recalled_when_the_segment_under_it_is_given_up() -> None:
    bus = InprocBus()
    mc = MissionControl(PLAN, FLEET, bus.endpoint(MISSION_CONTROL), reservation="site", max_attempts=3)
    machines: dict[str, Machine] = {}
    for u in FLEET:
        h = UavHandler(u.name, bus.endpoint(u.name), position=lambda u=u: u.home_m)
        machines[u.name] = Machine(h, 10.0)
        h.attach(machines[u.name])
    handlers = {m.link.name: m.link for m in machines.values()}
    now_s, given_up_s = 0.0, None
    while mc.ended_at_s is None and now_s < 600.0:
        for h in handlers.values():
            h.step(now_s)
        mc.step(now_s)
        if given_up_s is None and "A0" in mc.dispatcher.stuck:
            given_up_s = now_s
        now_s += 0.5
    assert given_up_s is not None and mc.ended_at_s is not None
    carrier = next(a.uav for a in mc.history if a.task_id == "B1")
    (at_s, why), *_ = machines[carrier].aborted
    assert why == given_up_reason("A0", "B1") == "A0 under B1 was given up"
    assert at_s - given_up_s <= 1.0  # recalled in the same event, one tick later at most: not after 240 s
    b1 = [a for a in mc.history if a.task_id == "B1"]
    assert [(a.status, a.reason) for a in b1] == [("failed", why)]
    assert "B2" in mc.dispatcher.done and not mc.finished  # the rest of the wall is built
    assert mc.ended_at_s - given_up_s <= 5.0  # the mission ends at once, blocked, saying why


def test_waiting_on_follows_the_dependents_through_in_progress_tasks() -> None:
    d = Dispatcher(PLAN, FLEET, reservation="site")
    given = {a.task_id: a.uav for a in d.assign()}
    assert set(given) >= {"A0", "B1"}  # B1 fetched while A0 is sprayed
    assert d.waiting_on("A0") == {"B1": given["B1"]}
    assert d.waiting_on("B2") == {} and d.waiting_on("B1") == {}


@pytest.mark.slow
def test_in_a_simulated_mission_the_brick_on_a_clogged_segment_is_put_back_at_once() -> None:
    """A 3 x 6 running bond at 2 + 2, seed 1: B9 is fetched while A7 under it is sprayed (175.6 s); every spray of
    A7 fails (its nozzle clogged: injected here, the simulator has no such fault); the third failure gives A7 up
    (215.9 s) and brick-2 turns back at once (abandoned in the same tick), puts B9 back on its pallet and the
    mission goes on: every task not on A7 is built, the report saying why B9 and the rest were not. Before, brick-2
    hovered at its hold point until ``hold_patience_s`` (240 s)."""
    mission = SimulatedMission.from_blueprint(running_bond(3, 6, brick_uavs=2, adhesion_uavs=2), seed=1)
    clogged = "A7"
    for name, h in mission.handlers.items():
        machine = h.model
        if name.startswith("glue") and isinstance(machine, AdhesionUav):
            clog(machine, clogged)
    report = mission.run()
    stuck_s = max(a.end_s or 0.0 for a in report.attempts if a.task_id == clogged)
    (b9,) = [a for a in report.attempts if a.task_id == "B9"]
    assert b9.start_s < stuck_s  # fetched while A7 was sprayed
    assert b9.status == "failed" and (b9.reason or "").startswith(given_up_reason(clogged, "B9"))
    (flown,) = [e for e in mission.handlers[b9.uav].executions if e.task_id == "B9"]
    assert flown.abandoned_s is not None and flown.abandoned_s - stuck_s <= 1.0  # not after 240 s
    assert not report.completed and "B9" in report.stuck  # the report says why B9 was not placed:
    assert f"  B9: its attempt 1 failed: {b9.reason}" in report.stuck_why()
    on_a7 = depends_on(mission.plan, clogged)
    done = {a.task_id for a in report.attempts if a.status == "done"}
    assert done == {t.id for t in mission.plan.tasks if not t.done} - on_a7 - {clogged}


def clog(machine: AdhesionUav, segment: str) -> None:
    """Every spray of ``segment`` by ``machine`` fails when its pass ends (a clogged nozzle)."""
    sprayed = machine.sprayed

    def clogged_nozzle(*args: object, **kwargs: object) -> None:
        if machine.adhesion_task.id == segment:
            machine.abort(reason=f"the nozzle is clogged over {segment}")
            return
        sprayed(*args, **kwargs)

    machine.sprayed = clogged_nozzle  # type: ignore[method-assign]


def depends_on(plan: Plan, task_id: str) -> set[str]:
    """The tasks that depend on ``task_id``, directly or through others."""
    after: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        after.setdefault(v, []).append(u)
    seen: set[str] = set()
    todo = [task_id]
    while todo:
        for u in after.get(todo.pop(), []):
            if u not in seen:
                seen.add(u)
                todo.append(u)
    return seen
