"""A UAV that goes out of service with a task queued (battery run down waiting for a column in the air).

Regression: on separation-on walls such a UAV's handler held the queued task back for the battery reserve's
ground-crew swap (60 s) although the machine was ``halted``, then handed it over and the machine refused it at
once, long after mission control had released it (on the ``halted`` heartbeat) and given a conflicting task to
another UAV. The zero-length refusal was counted as a conflict violation (2-4 on the 1,000-brick wall).
"""

from __future__ import annotations

import math
import sys

import pytest

from masonry.blueprint_gen import running_bond
from masonry.fsm import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.mission.handler import UavHandler
from masonry.mission.report import count_violations
from masonry.mission.simulate import SimulatedMission, simulate
from masonry.planner import plan
from masonry.sim import Faults


def _conflict_pair() -> tuple[object, str, str]:
    p = plan(running_bond(2, 4))
    a, b = next(iter(p.conflicts))
    return p, a, b


def test_a_zero_length_refusal_is_never_in_progress():
    p, a, b = _conflict_pair()
    assert count_violations(p, [(a, 0.0, 10.0), (b, 5.0, 5.0)]) == (
        0,
        0,
    )  # refused at once, inside a's interval
    assert count_violations(p, [(a, 0.0, None), (b, 5.0, 5.0)]) == (0, 0)  # inside an open interval
    assert count_violations(p, [(a, 0.0, 5.0), (b, 5.0, 8.0)]) == (0, 0)  # one ends as the other starts


def test_any_overlap_of_positive_length_is_still_counted():
    p, a, b = _conflict_pair()
    assert count_violations(p, [(a, 0.0, 10.0), (b, 9.9, 12.0)])[0] == 1
    assert count_violations(p, [(a, 0.0, None), (b, 50.0, 51.0)])[0] == 1
    assert (
        count_violations(p, [(a, 5.0, 5.5), (b, 0.0, 10.0), (a, 20.0, 30.0)])[0] == 1
    )  # counted once per pair


@pytest.mark.slow
def test_a_retiring_uav_refuses_its_queued_task_before_it_is_released(monkeypatch):
    """Batteries drain fast: adhesion UAVs run down waiting in the air and retire with a task queued.

    The machines are told there is no battery service (as on a link without a ground crew), so that a low
    battery retires them, while the handler's reserve would still wait for a swap before handing a task over.
    Tasks are taken with no waiting budgeted (``battery_wait_budget_s=0``): with the default 60 s the budget keeps
    every battery high enough and no UAV retires; with none, glue-2 gives A1 up waiting for its column and
    retires with A1 queued again.
    """
    monkeypatch.setattr(UavHandler, "swaps_batteries", property(lambda self: False))
    sim_module = sys.modules["masonry.mission.measured"]  # where the simulated report is built
    seen: dict[str, object] = {}
    real = sim_module.control_report

    def spy(mc, the_plan, **kwargs):
        seen["intervals"] = kwargs["intervals"]
        seen["plan"] = the_plan
        return real(mc, the_plan, **kwargs)

    monkeypatch.setattr(sim_module, "control_report", spy)
    report = simulate(
        running_bond(3, 10, brick_uavs=4, adhesion_uavs=2),
        seed=2,
        faults=Faults(battery_drain_per_s=0.004),
        uav_config=UavConfig(
            "template", "brick", (0.0, 0.0, 0.0), **uav_settings("arducopter"), battery_wait_budget_s=0.0
        ),
        reservation="task",  # the executed intervals of conflicting tasks are checked below (the paper's rule)
    )
    retired = [a for a in report.attempts if a.reason == "uav out of service"]
    assert retired, "the scenario must retire a UAV holding a task"
    assert report.conflict_violations == 0
    assert report.dependency_violations == 0
    # Independently of the measurement's rule for zero-length attempts: no executed interval, refusals included,
    # meets a conflicting one even at a single instant inside it (the refusal is not delayed past the release).
    by_task: dict[str, list[tuple[float, float]]] = {}
    for _uav, task_id, start, end in seen["intervals"]:  # type: ignore[attr-defined]
        by_task.setdefault(task_id, []).append((start, math.inf if end is None else end))
    for a, b in seen["plan"].conflicts:  # type: ignore[attr-defined]
        for s1, e1 in by_task.get(a, ()):
            for s2, e2 in by_task.get(b, ()):
                assert not (s1 < e2 and s2 < e1), (a, (s1, e1), b, (s2, e2))
    done = [t.id for t in report.tasks if t.status == "done"]
    assert len(done) == len(set(done))


@pytest.mark.slow
def test_a_battery_run_low_in_the_air_is_swapped_at_home_not_retired():
    """With the ground crew, a UAV whose battery runs low waiting for a column lands, gets a pack, flies on.

    Before, the state machine retired it (out of service) after landing; on this wall three of six did. On the
    default (arducopter) vehicle a put-back then waited 20-50 s for the pallet's column and the UAV ended at the
    critical battery (landing on the pallet, out of service, with 0.005/s packs); with the battery budget
    (docs/state-machines.md, "Battery budget") no UAV in the air comes near it.
    """
    mission = SimulatedMission.from_blueprint(
        running_bond(3, 10, brick_uavs=3, adhesion_uavs=2), seed=0, faults=Faults(battery_drain_per_s=0.0038)
    )
    lowest: list[float] = [1.0]

    def watch(now_s: float) -> None:
        for name in mission.handlers:
            v = mission.world.uavs[name].vehicle
            if not v.on_ground:
                lowest[0] = min(lowest[0], v.battery_fraction)

    mission.tick_hooks.append(watch)
    report = mission.run()
    assert [u.status for u in report.uavs] == ["ok"] * 5
    assert report.completed
    assert (report.conflict_violations, report.dependency_violations) == (0, 0)
    # 3 + 2 UAVs, so that no role has the four the swap stagger needs (docs/dispatch.md): at 4 + 2 the stagger
    # sends the UAVs under 50 % home before any runs low in the air (944 s, 12 swaps, none given up low), and this
    # test is about the path when one does (3 + 2, measured: 1,288 s, 16 swaps, one task given up low in the air,
    # lowest 35 %). With the brick UAVs apart past the width (docs/dispatch.md, issue 27) 0.0033/s no longer takes
    # that path (1,149 s, 14 swaps, none given up low): at 0.0036/s it does (1,225 s, 15 swaps, one task given up low
    # in the air, lowest 32 %). With the sprayers' climb out of their zones kept inside them (issue 27 §4.3, branch
    # envclimb51) 0.0036/s no longer does (none given up low; nor 0.0035/s, 1,223 s); 0.0037-0.0040/s do (0.0038/s:
    # 1,235 s, 16 swaps, one task given up low in the air, lowest 30 %). The figures below were measured at 4 + 2
    # before the stagger.
    # packs of 300 s: the UAVs ran low (and were swapped, since all are in service) many times. Measured with the
    # admission of landed UAVs (docs/dispatch.md): 1,028 s, 13 swaps, 2,894 s in the air over six UAVs; without it
    # 1,347 s, 25 swaps, 5,595 s in the air (the UAVs hovered waiting for columns the admission keeps them off).
    # With the linger (docs/safety.md, "Waiting near the wall"): 1,108 s, 16 swaps, 3,616 s in the air, 2 tasks
    # given up low in the air. No wait on the way home is budgeted here: the pads are 2 m apart (masonry.fsm.budget)
    # With the swaps one after another (docs/dispatch.md, issue 27): 918 s, 14 swaps (5 of them of a UAV idle on
    # its pad), none given up low in the air: the UAVs under 50 % are sent home, one or two at a time. Its second
    # version (a sent UAV stays sent; none sent beside a spare on its pad, nor in a role of fewer than four): 944 s,
    # 12 swaps, none of them idle on a pad and none given up low in the air.
    assert report.makespan_s > 900.0
    assert sum(h.battery_swaps for h in mission.handlers.values()) >= 10
    assert sum(1 for a in report.attempts if (a.reason or "").startswith("battery low")) >= 1
    # measured 30 %, 21 % with the linger (15.0 % without the admission), 37 % with the swaps one after another
    # (26 % with its second version; 35 % at 3 + 2); critical is 10 % (before: 9.8 %)
    assert lowest[0] > 0.15
    done = [t.id for t in report.tasks if t.status == "done"]
    assert len(done) == len(set(done)) == len(report.tasks)
