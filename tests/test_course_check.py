"""A brick found off its course height after its release is misplaced, not done (issue 30,
masonry.mission.course_check): on GNSS a brick landed on a misplaced neighbour, a course too high, and the
mission reported it placed and complete."""

from __future__ import annotations

import math
import random
import re
from dataclasses import replace

import pytest

from masonry.blueprint_gen import pyramid
from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.mission.control import MissionControl
from masonry.mission.course_check import CourseCheck, is_misplaced
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL
from masonry.mission.report import control_report
from masonry.mission.simulate import SimulatedMission
from masonry.perception.types import AsBuiltPose
from masonry.planner import plan
from masonry.planner.tasks import BrickTask, Plan
from masonry.ports import TaskResult
from test_mission_control import ScriptedUav, _fly_until_the_end, fleet_of

WALL = pyramid(3, yaw_rad=math.radians(30.0), clearance_m=1.0)  # B0-B2, B3-B4 on them, B5 on top


def _seen(relative_to: int, dz_m: float) -> AsBuiltPose:
    """A pose whose top-face centre stands ``dz_m`` above brick ``relative_to``'s, as the relative look says."""
    return AsBuiltPose((0.0, 0.0, 0.0), 0.0, 0.0, 1.0, relative_to, (0.3, 0.0, dz_m), 0.0)


def test_the_course_error_is_measured_against_the_neighbour_and_carried_up() -> None:
    check = CourseCheck(plan(WALL).tasks)
    assert check.misplaced("B1", 1, AsBuiltPose((0.0, 0.0, 0.05), 0.0, 0.0, 1.0)) is None  # no neighbour seen
    assert check.misplaced("B0", 0, _seen(1, 0.003)) is None  # beside it, 3 mm: at its course height
    reason = check.misplaced("B2", 2, _seen(1, 0.104))
    assert reason is not None and is_misplaced(reason)
    assert reason.startswith("misplaced: B2 rests 10.4 cm above its course height (measured against B1")
    # B4 seen 10 cm below B2, which stands a course too high: B4 is at its course height (0.1 m over the first)
    assert check.misplaced("B4", 4, _seen(2, 0.0)) is None
    assert check.errors_m[4] == pytest.approx(0.004)
    low = check.misplaced("B3", 3, _seen(1, 0.0))  # level with a first-course brick: a course too low
    assert low is not None and "B3 rests 10.0 cm below its course height" in low


def test_a_brick_a_course_too_high_is_reported_misplaced_not_done() -> None:
    """The px4 model placing on GNSS alone (the wall's markers off): some brick, released beside its place, rests a
    course too high (the simulator's truth), and the relative look says so within a centimetre. Before, the mission
    said such a brick done and completed.
    Which seed and brick it is moves with every change to a flight's timing (seed 8's B2 on the first px4 model;
    seeds 14, 30, 17, 24, 13 and 10 since; seeds 4 and 6 on 2026-12-05's afternoon main, where seeds 1-60 had seven
    such bricks and dozens a course too low): the test flies seeds in order until one has a brick a course too high,
    and checks every such brick of that mission against the truth. (With the markers on, the default, seed 8 did
    the same on an earlier model until the px4 preset's 3 s gate window; docs/performance/fleet.md, the linger's
    section.)"""
    settings = {**uav_settings("px4"), "align_on_wall": False}
    template = UavConfig("template", "brick", (0.0, 0.0, 0.0), **settings)
    for seed in range(1, 41):
        mission = SimulatedMission.from_blueprint(WALL, seed=seed, vehicle="px4", uav_config=template)
        report = mission.run()
        failed = {a.task_id: a.reason or "" for a in mission.control.history if a.status == "failed"}
        high = {
            task_id: found
            for task_id, reason in failed.items()
            if (
                found := re.match(rf"misplaced: {task_id} rests (\d+\.\d) cm above its course height", reason)
            )
        }
        if high:
            break
    else:
        pytest.fail("no brick a course too high on seeds 1-40: the scenario needs another wall or model")
    assert not report.completed, seed
    # and no brick of that mission a course too high went unreported
    truly_high = {
        f"B{b.id}"
        for b in WALL.bricks
        if mission.world.bricks[b.id].position_m[2] - b.position_m[2] > b.size_m[2] / 2
    }
    assert truly_high == set(high), (seed, truly_high, failed)
    for task_id, found in high.items():
        brick = int(task_id[1:])
        # (the figure is the relative look's, from frames of the brick's climb; the simulator's truth is one course)
        course_m = WALL.bricks[brick].size_m[2]
        true_m = mission.world.bricks[brick].position_m[2] - WALL.bricks[brick].position_m[2]
        assert true_m == pytest.approx(course_m, abs=0.005), (seed, task_id)
        assert float(found.group(1)) / 100.0 == pytest.approx(true_m, abs=0.01), (seed, failed[task_id])
    # it, and a brick that would stand on it (which brick is high moves with the flights' timing: B3 until the
    # sprayers' climb out of their zones changed, issue 27 §4.3; another since)
    waits_on = plan(WALL).prerequisites()
    for task_id in high:
        assert task_id in report.stuck, (seed, task_id, report.stuck)
        over, todo = set(), [task_id]
        while todo:
            below = todo.pop()
            for t, pre in waits_on.items():
                if below in pre and t not in over:
                    over.add(t)
                    todo.append(t)
        assert {t for t in over if t.startswith("B")} & set(report.stuck), (seed, task_id, report.stuck)
    done = {a.task_id for a in mission.control.history if a.status == "done"}
    for b in mission.blueprint.bricks:  # no brick counted placed is off its course (the simulator's truth)
        if f"B{b.id}" in done:
            assert mission.world.bricks[b.id].position_m[2] == pytest.approx(b.position_m[2], abs=0.02)


@pytest.mark.parametrize("seed", [1, 2])
def test_the_default_px4_pyramid_still_completes(seed: int) -> None:
    report = SimulatedMission.from_blueprint(WALL, seed=seed, vehicle="px4").run()
    assert report.completed and not report.stuck


class _Reporting(ScriptedUav):
    """A scripted brick UAV whose brick B1 ends with ``result`` (B0 is placed as designed)."""

    def __init__(self, link, result: TaskResult) -> None:
        super().__init__(link, {"B0": 2.0, "B1": 2.0, "B2": 2.0}, random.Random(0))
        self.result = result

    def step(self, now_s: float) -> None:
        if self.task is not None and self.task.id == "B1" and now_s - self.t0 >= 2.0:
            self.link.report_result(replace(self.result, duration_s=now_s - self.t0))
            self.task, self.state = None, "idle"
            return
        super().step(now_s)


def _mission_control(result: TaskResult) -> MissionControl:
    """B0 and B1 side by side, B2 on them; B1's UAV says ``result``."""
    size = (0.3, 0.15, 0.1)
    plan = Plan(
        (
            BrickTask("B0", 0, False, (0.0, 0.0, 0.05), 0.0, (5, 0, 0.05), size),
            BrickTask("B1", 1, False, (0.3, 0.0, 0.05), 0.0, (5, 1, 0.05), size),
            BrickTask("B2", 2, False, (0.15, 0.0, 0.15), 0.0, (5, 2, 0.05), size),
        ),
        (("B2", "B0"), ("B2", "B1")),
        (),
    )
    bus = InprocBus()
    mc = MissionControl(plan, fleet_of(1, 0), bus.endpoint(MISSION_CONTROL), max_attempts=3)
    h = UavHandler("brick-1", bus.endpoint("brick-1"), position=lambda: (0.0, -3.0, 0.0))
    h.attach(_Reporting(h, result))
    _fly_until_the_end(mc, h, 200.0)
    return mc


def test_mission_control_does_not_count_a_brick_off_its_course_and_builds_nothing_on_it() -> None:
    high = AsBuiltPose((0.3, 0.0, 0.05), 0.0, 0.0, 1.0, 0, (0.3, 0.0, 0.1), 0.1)  # 10 cm above B0's top
    mc = _mission_control(TaskResult("B1", "done", 0.0, as_built=high))
    assert mc.ended_at_s is not None and mc.dispatcher.done == {"B0"}
    assert mc.dispatcher.stuck == {"B1"} and mc.dispatcher.attempts["B1"] == 1  # not tried again
    assert [(a.task_id, a.status) for a in mc.history] == [("B0", "done"), ("B1", "failed")]
    assert mc.history[1].reason.startswith(
        "misplaced: B1 rests 10.0 cm above its course height (measured against B0"
    )


def test_a_release_refused_on_a_taken_place_is_not_tried_again() -> None:
    why = "place taken: B0 seen 10.0 cm into the place of B1; not released there; brick 1 put back at its pickup"
    mc = _mission_control(TaskResult("B1", "failed", 0.0, reason=why))
    assert mc.dispatcher.stuck == {"B1"} and mc.dispatcher.attempts["B1"] == 1
    assert "B2" not in mc.dispatcher.done
    # not silently stuck: the report says why each task left undone is
    text = control_report(mc, mc.plan, policy="fifo").summary()
    assert f"  B1: its attempt 1 failed: {why}" in text.splitlines(), text
    assert "  B2: waits for dependency B1" in text.splitlines(), text
