"""MissionControl + UavHandler over the in-process transport, with scripted UAV machines (no physics).

Property tests over random plans, fleets, seeds and faults check the safety invariants mission control
must keep: no conflicting tasks in progress at once, dependency order respected, every task completed
exactly once; lost UAVs release their task; bad messages are rejected without stopping the mission.
"""

from __future__ import annotations

import logging
import random

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.blueprint import UavSpec
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.ledger import AttemptLedger
from masonry.mission.messages import MISSION_CONTROL, Heartbeat, decode, encode
from masonry.mission.report import count_violations
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan
from masonry.ports import TaskResult


class ScriptedUav:
    """A stand-in state machine: takes a task from the link, 'flies' it for a fixed time, reports."""

    def __init__(self, link, durations, rng, fail_p=0.0):
        self.link, self.durations, self.rng, self.fail_p = link, durations, rng, fail_p
        self.task, self.t0, self.state = None, 0.0, "idle"

    @property
    def finished(self):
        return self.task is None

    def step(self, now_s):
        if self.task is None:
            self.task = self.link.poll_task()
            if self.task is not None:
                self.t0, self.state = now_s, "working"
                self.link.report_progress(self.task.id, "working", now_s)
            return
        if now_s - self.t0 >= self.durations[self.task.id]:
            status = "failed" if self.rng.random() < self.fail_p else "done"
            self.link.report_result(
                TaskResult(
                    self.task.id,
                    status,
                    now_s - self.t0,
                    reason="grasp failed" if status == "failed" else None,
                )
            )
            self.task, self.state = None, "idle"


def random_plan(rng, n):
    tasks = []
    for i in range(n):
        if rng.random() < 0.6:
            tasks.append(BrickTask(f"B{i}", i, False, (rng.uniform(0, 5), 0.0, 0.1), 0.0, (8.0, 2.0, 0.05)))
        else:
            tasks.append(
                AdhesionTask(f"A{i}", i, i + 1, (rng.uniform(0, 5), 0, 0.1), (rng.uniform(0, 5), 0, 0.1), 0.3)
            )
    ids = [t.id for t in tasks]
    deps = {(ids[u], ids[v]) for u in range(n) for v in range(u) if rng.random() < 0.15}
    conflicts = {(ids[a], ids[b]) for a in range(n) for b in range(a + 1, n) if rng.random() < 0.2}
    return Plan(tuple(tasks), tuple(sorted(deps)), tuple(sorted(conflicts)))


def run_mission(
    plan, fleet, *, seed=0, fail_p=0.0, lose=None, policy="critical-path", dt=0.5, t_max=5000.0, **mc_options
):
    # The paper's rule (Algorithm 1): these scripted UAVs fly no airspace, so the ``site`` reservation's gate
    # (mission control's default) has nothing to keep apart; task intervals are what the invariants check.
    mc_options.setdefault("reservation", "task")
    rng = random.Random(seed)
    durations = {t.id: rng.uniform(2.0, 20.0) for t in plan.tasks}
    bus = InprocBus()
    mc = MissionControl(
        plan, fleet, bus.endpoint(MISSION_CONTROL), policy=policy, heartbeat_timeout_s=3.0, **mc_options
    )
    handlers = {}
    for u in fleet:
        h = UavHandler(u.name, bus.endpoint(u.name), position=lambda u=u: u.home_m)
        h.attach(ScriptedUav(h, durations, rng, fail_p))
        handlers[u.name] = h
    lose = lose or {}
    now = 0.0
    while mc.ended_at_s is None and now < t_max:
        for name, h in handlers.items():
            if now < lose.get(name, float("inf")):
                h.step(now)
        mc.step(now)
        now += dt
    # a UAV that died stopped flying its task when it died
    intervals = [
        (e.task_id, e.start_s, e.end_s if e.end_s is not None else lose.get(name))
        for name, h in handlers.items()
        for e in h.executions
    ]
    return mc, handlers, intervals


def _fly_until_the_end(mc, h, t_max, dt=0.5):
    """Step one UAV handler and mission control every ``dt`` until the mission ends or ``t_max``."""
    now = 0.0
    while mc.ended_at_s is None and now < t_max:
        h.step(now)
        mc.step(now)
        now += dt


def fleet_of(nb, na):
    return tuple(
        [UavSpec(f"brick-{i + 1}", "brick", (i * 3.0, -3.0, 0.0)) for i in range(nb)]
        + [UavSpec(f"glue-{i + 1}", "adhesion", (i * 3.0, -6.0, 0.0)) for i in range(na)]
    )


@settings(max_examples=40)
@given(
    st.integers(1, 30),
    st.integers(1, 4),
    st.integers(1, 3),
    st.integers(0, 10**6),
    st.sampled_from(["fifo", "critical-path", "nearest"]),
)
def test_invariants_without_faults(n, nb, na, seed, policy):
    plan = random_plan(random.Random(seed), n)
    mc, handlers, intervals = run_mission(plan, fleet_of(nb, na), seed=seed, policy=policy)
    assert mc.finished and mc.ended_at_s is not None
    assert count_violations(plan, intervals) == (0, 0)
    done = [e.task_id for h in handlers.values() for e in h.executions if e.status == "done"]
    assert sorted(done) == sorted(t.id for t in plan.tasks)  # each task completed exactly once


@settings(max_examples=40)
@given(
    st.integers(1, 25),
    st.integers(1, 3),
    st.integers(1, 3),
    st.integers(0, 10**6),
    st.floats(0.0, 0.4),
    st.data(),
)
def test_invariants_with_failures_and_lost_uavs(n, nb, na, seed, fail_p, data):
    plan = random_plan(random.Random(seed), n)
    fleet = fleet_of(nb, na)
    lose = data.draw(
        st.dictionaries(st.sampled_from([u.name for u in fleet]), st.floats(0.0, 60.0), max_size=2)
    )
    mc, handlers, intervals = run_mission(plan, fleet, seed=seed, fail_p=fail_p, lose=lose)
    assert mc.ended_at_s is not None, "mission control must end: finished or blocked"
    assert count_violations(plan, intervals) == (0, 0)
    done = [e.task_id for h in handlers.values() for e in h.executions if e.status == "done"]
    assert len(done) == len(set(done)), "a task was completed twice"
    assert set(done) == set(mc.dispatcher.done)
    if mc.finished:
        assert set(done) == {t.id for t in plan.tasks}
    else:
        assert mc.blocked
    for name, t in lose.items():
        # a silent UAV is declared lost once the timeout has passed, unless the mission was over before
        assert mc.uavs[name].lost or mc.ended_at_s <= t + 3.0 + 0.5


def test_lost_uav_releases_its_task_to_another():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    fleet = fleet_of(2, 0)
    bus = InprocBus()
    mc = MissionControl(plan, fleet, bus.endpoint(MISSION_CONTROL), heartbeat_timeout_s=2.0)
    hs = {}
    for u in fleet:
        h = UavHandler(u.name, bus.endpoint(u.name))
        h.attach(ScriptedUav(h, {"B0": 10.0}, random.Random(0)))
        hs[u.name] = h
    now = 0.0
    while mc.ended_at_s is None and now < 100:
        for name, h in hs.items():
            if name != "brick-1" or now < 3.0:  # brick-1 goes silent at 3 s, mid-task
                h.step(now)
        mc.step(now)
        now += 0.25
    assert mc.finished
    # last heartbeat at 2 s (period 1 s), timeout 2 s
    assert mc.uavs["brick-1"].lost and 4.0 < mc.uavs["brick-1"].lost_at_s <= 4.5
    assert [(a.uav, a.status, a.reason) for a in mc.history] == [
        ("brick-1", "failed", "uav lost"),
        ("brick-2", "done", None),
    ]
    assert mc.history[1].start_s == mc.uavs["brick-1"].lost_at_s


def test_all_uavs_of_a_role_lost_blocks_the_mission():
    plan = Plan(
        (
            AdhesionTask("A0", 0, 1, (0, 0, 0.1), (0.3, 0, 0.1), 0.3),
            BrickTask("B1", 1, False, (0, 0, 0.2), 0.0, (5, 0, 0.05)),
        ),
        (("B1", "A0"),),
        (),
    )
    mc, _handlers, _ = run_mission(plan, fleet_of(1, 1), lose={"glue-1": 1.0})
    assert mc.blocked and not mc.finished
    assert set(mc.dispatcher.remaining) == {"A0", "B1"}


def test_stuck_task_after_max_attempts():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    mc, _handlers, _ = run_mission(plan, fleet_of(1, 0), fail_p=1.0)
    assert mc.blocked and set(mc.dispatcher.stuck) == {"B0"}
    assert [a.attempt for a in mc.history] == [1, 2, 3]
    assert all(a.status == "failed" for a in mc.history)


def test_a_task_abandoned_for_the_battery_is_not_an_attempt_of_the_task():
    class LowBatteryFirst(ScriptedUav):
        """Abandons its first five tasks for its battery, then works."""

        aborted = 0

        def step(self, now_s):
            if self.task is not None and LowBatteryFirst.aborted < 5:
                LowBatteryFirst.aborted += 1
                self.link.report_result(TaskResult(self.task.id, "failed", 0.0, reason="battery low (19%)"))
                self.task = None
                return
            super().step(now_s)

    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    bus = InprocBus()
    mc = MissionControl(plan, fleet_of(1, 0), bus.endpoint(MISSION_CONTROL), max_attempts=3)
    h = UavHandler("brick-1", bus.endpoint("brick-1"), position=lambda: (0.0, -3.0, 0.0))
    h.attach(LowBatteryFirst(h, {"B0": 2.0}, random.Random(0)))
    _fly_until_the_end(mc, h, 200.0)
    assert mc.finished and "B0" in mc.dispatcher.done
    assert [a.status for a in mc.history] == ["failed"] * 5 + ["done"]  # five battery aborts, none counted
    assert mc.dispatcher.attempts.get("B0") == 1  # only the attempt that placed it counts


def test_unknown_uav_and_garbage_are_rejected_not_fatal():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    bus = InprocBus()
    mc = MissionControl(plan, fleet_of(1, 0), bus.endpoint(MISSION_CONTROL))
    rogue = bus.endpoint("brick-9")
    rogue.send(MISSION_CONTROL, encode(Heartbeat("brick-9", 0.0)))
    rogue.send(MISSION_CONTROL, b"{garbage")
    mc.step(0.0)
    assert mc.events.rejected == 2
    assert "not a UAV of the blueprint's fleet" in mc.events.errors[0]
    assert "brick-9" not in mc.uavs


def test_mission_control_waits_for_the_fleet_then_starts_without_the_missing():
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    bus = InprocBus()
    mc = MissionControl(plan, fleet_of(2, 0), bus.endpoint(MISSION_CONTROL), startup_timeout_s=10.0)
    b2 = bus.endpoint("brick-2")
    for t in range(12):
        b2.send(MISSION_CONTROL, encode(Heartbeat("brick-2", float(t))))
        mc.step(float(t))
        if t < 10:
            assert mc.started_at_s is None
    assert mc.started_at_s == 10.0
    assert mc.uavs["brick-1"].lost
    assert mc.dispatcher.in_progress == {"B0": "brick-2"}
    assigned = [decode(m) for m in b2.receive()]
    assert any(getattr(m, "uav", None) == "brick-2" for m in assigned)


def test_count_violations_detects_overlaps_and_early_starts():
    plan = Plan(
        (
            BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, None),
            BrickTask("B1", 1, False, (0, 0, 0.2), 0.0, None),
            BrickTask("B2", 2, False, (9, 0, 0.1), 0.0, None),
        ),
        (("B1", "B0"),),
        (("B0", "B2"),),
    )
    assert count_violations(plan, [("B0", 0, 10), ("B1", 10, 20), ("B2", 10, 15)]) == (0, 0)
    assert count_violations(plan, [("B0", 0, 10), ("B1", 9, 20), ("B2", 9.5, 15)]) == (1, 1)
    assert count_violations(plan, [("B0", 0, None), ("B2", 50, 60)]) == (1, 0)  # B0 never ended


class HaltingUav(ScriptedUav):
    """Goes out of service (state ``halted``) after its first task and then refuses every task, like BrickUav."""

    def step(self, now_s):
        if self.state == "halted":
            task = self.link.poll_task()
            if task is not None:
                self.link.report_result(
                    TaskResult(task.id, "failed", 0.0, reason="out of service: battery low")
                )
            return
        was = self.task
        super().step(now_s)
        if was is not None and self.task is None:
            self.state = "halted"


def test_out_of_service_uav_is_retired_without_burning_attempts():
    plan = Plan(
        tuple(BrickTask(f"B{i}", i, False, (i * 3.0, 0, 0.1), 0.0, (5, 0, 0.05)) for i in range(4)), (), ()
    )
    fleet = fleet_of(2, 0)
    bus = InprocBus()
    mc = MissionControl(plan, fleet, bus.endpoint(MISSION_CONTROL), policy="fifo")
    hs = {}
    for u in fleet:
        h = UavHandler(u.name, bus.endpoint(u.name))
        cls = HaltingUav if u.name == "brick-1" else ScriptedUav
        h.attach(cls(h, {t.id: 5.0 for t in plan.tasks}, random.Random(0)))
        hs[u.name] = h
    now = 0.0
    while mc.ended_at_s is None and now < 200:
        for h in hs.values():
            h.step(now)
        mc.step(now)
        now += 0.25
    assert mc.finished
    assert mc.uavs["brick-1"].status == "out of service"
    assert not mc.dispatcher.stuck and max(mc.dispatcher.attempts.values()) == 1
    assert [a.uav for a in mc.history if a.status == "done"].count("brick-1") == 1


@pytest.mark.parametrize("heard", [False, True])
def test_battery_reserve_holds_the_task_until_the_pack_is_swapped(heard: bool):
    """Under the handler's 40 % reserve a task waits for the swap: held by the handler when mission control does
    not hear the low charge (the heartbeats report another battery, e.g. a remote autopilot's), not given at all
    when it does (``swap_stagger``: the UAV is swapped idle on its pad, then given the task)."""
    plan = Plan((BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),), (), ())
    bus = InprocBus()
    mc = MissionControl(plan, fleet_of(1, 0), bus.endpoint(MISSION_CONTROL))
    pack = {"charge": 0.3, "swaps_at": 4.0}

    def swap():
        return h.now_s >= pack["swaps_at"] and pack.update(charge=1.0) is None

    h = UavHandler(
        "brick-1",
        bus.endpoint("brick-1"),
        battery=lambda: pack["charge"],
        swap_battery=swap,
        report_battery=None if heard else (lambda: 0.9),
    )
    h.attach(ScriptedUav(h, {"B0": 2.0}, random.Random(0)))
    _fly_until_the_end(mc, h, 50.0)
    assert mc.finished and h.battery_swaps == 1
    assert h.executions[0].start_s >= 4.0  # flown after the swap
    if heard:
        assert h.top_ups == 1 and mc.history[0].start_s >= 4.0  # swapped idle, assigned with the fresh pack
    else:
        assert h.top_ups == 0 and mc.history[0].start_s < 4.0  # assigned at once, held by its handler


def test_transit_layers_start_over_what_is_built_and_rise_with_assignments_and_a_resumed_journal(tmp_path):
    from masonry.blueprint_gen import running_bond
    from masonry.mission.airspace import layer_base_m, task_work_altitude_m
    from masonry.mission.journal import Journal
    from masonry.planner import plan as make_plan

    bp = running_bond(8, 2, placed_courses=2, brick_uavs=1, adhesion_uavs=1)
    plan = make_plan(bp)
    final, cruise = layer_base_m(bp), bp.cruise_altitude_m

    def work(ids):
        return max(task_work_altitude_m(plan.task(i), cruise) for i in ids)

    placed = [t.id for t in plan.tasks if t.done]
    mc = MissionControl(
        plan, bp.fleet, InprocBus().endpoint(MISSION_CONTROL), layer_base_m=final, layer_floor_m=cruise
    )
    assert mc.columns.layer_base_m == max(cruise, work(placed)) < final
    mc._dispatch(0.0)  # both UAVs take their first task
    running = mc.ledger.running
    assert running and mc.columns.layer_base_m == max(cruise, work(placed + list(running)))
    # a resumed mission starts over everything the journal says was done or was being worked on
    high = [t.id for t in plan.tasks if not t.done and t.kind == "brick"][-3:]
    with Journal(tmp_path / "j.sqlite") as j:
        j.record_assignment(1.0, high[0], "brick-1", 1)
        j.record_completion(9.0, high[0], "brick-1")
        j.record_assignment(10.0, high[1], "brick-1", 1)
        state = j.replay()
    resumed = MissionControl(
        plan, bp.fleet, InprocBus().endpoint(MISSION_CONTROL), layer_base_m=final, layer_floor_m=cruise
    )
    resumed.restore(state)
    assert resumed.columns.layer_base_m == work(high[:2]) > work(placed)
    fixed = MissionControl(plan, bp.fleet, InprocBus().endpoint(MISSION_CONTROL), layer_base_m=final)
    assert fixed.columns.layer_base_m == final  # without a floor: above the finished wall from the start


def test_the_first_progress_a_uav_reports_on_its_attempt_is_said_once(caplog):
    """`masonry mission-control --verbose` says when a UAV is on its task (the line the multi-process tests wait
    for before they kill a process mid-task, instead of a guess of seconds); once per attempt, only its UAV's."""
    caplog.set_level(logging.INFO, logger="masonry.mission.control")
    plan = Plan(
        (
            BrickTask("B0", 0, False, (0, 0, 0.1), 0.0, (5, 0, 0.05)),
            BrickTask("B1", 1, False, (2, 0, 0.1), 0.0, (5, 0, 0.05)),
        ),
        (("B1", "B0"),),
        (),
    )
    mc, _handlers, _ = run_mission(plan, fleet_of(1, 0))
    assert mc.finished
    said = [r.getMessage().split(" at ")[0] for r in caplog.records if "under way" in r.getMessage()]
    assert said == ["B0 under way on brick-1 (attempt 1)", "B1 under way on brick-1 (attempt 1)"]
    ledger = AttemptLedger(None)
    ledger.begin("B0", "brick-1", 0.0)
    assert ledger.under_way("B0", "brick-2") is None  # not its attempt
    att = ledger.under_way("B0", "brick-1")
    assert att is not None and att.attempt == 1
    assert ledger.under_way("B0", "brick-1") is None  # said once
    ledger.end(att, 1.0, "failed", "uav lost")
    ledger.begin("B0", "brick-1", 2.0)
    assert ledger.under_way("B0", "brick-1") is not None  # the next attempt is said again
