"""A UAV recalled before its take-off has lifted it lands and takes off afresh for its next task.

On the shaped ``arducopter`` vehicle a take-off needs a few tenths of a second to leave the pad. A recall then
(``masonry sim --serve``'s operator key pressed at once) sent the machine ``home`` while still on the ground,
and the next task turned it back from there: it flew ``pickup_goto`` on its pad, where an autopilot ignores
velocity setpoints, for 30 s per attempt, until the task was stuck (found by tests/test_live_view.py).
"""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.mission.simulate import SimulatedMission

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


@pytest.mark.parametrize("recall_s", [0.1, 0.2, 0.3])
def test_a_recall_during_the_take_off_then_a_resume_completes_the_mission(recall_s: float) -> None:
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), vehicle="arducopter")
    world, operator = mission.world, mission.control.operator
    step = world.step
    sent: set[str] = set()

    def steer(dt_s: float) -> None:
        step(dt_s)
        t = world.clock.now_s()
        if t >= recall_s and "recall" not in sent:
            sent.add("recall")
            operator.submit({"command": "recall", "uav": "brick-1"})
        if t >= recall_s + 0.1 and "resume" not in sent:
            sent.add("resume")
            operator.submit({"command": "resume"})

    world.step = steer  # type: ignore[method-assign]
    report = mission.run()
    assert report.completed, [t.tries for t in report.tasks if t.status != "done"]
    b0 = next(t for t in report.tasks if t.id == "B0")
    assert [a.reason for a in b0.tries if a.reason] == ["recalled by the operator"]
