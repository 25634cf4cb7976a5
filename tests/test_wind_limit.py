"""max_wind_mps: above it mission control gives no task, the UAVs finish theirs and land, and the mission goes on
when the wind drops (masonry.mission.wind_limit)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.errors import InputError
from masonry.mission.simulate import SimulatedMission
from masonry.mission.wind_limit import WindLimit
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"
#: calm, then 9 m/s (above the default 8 m/s limit, still within a hexacopter's authority) from 30 s to 200 s
GUST_FRONT = ((0.0, 1.0), (30.0, 1.0), (35.0, 9.0), (200.0, 9.0), (205.0, 1.0))


def test_the_limit_grounds_and_frees_with_a_margin() -> None:
    speed = {"now": 5.0}
    limit = WindLimit({"a": 8.0, "b": 10.0}, lambda t: speed["now"])
    assert not limit.update(0.0) and limit.allows("a")
    speed["now"] = 9.0
    assert limit.update(1.0) and not limit.allows("a") and limit.allows("b")
    speed["now"] = 7.8  # below the limit, not yet below it less the margin
    assert not limit.update(2.0) and not limit.allows("a")
    speed["now"] = 7.4
    assert limit.update(3.0) and limit.allows("a")
    with pytest.raises(InputError, match="max_wind_mps of a"):
        WindLimit({"a": 0.0}, lambda t: None)


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_wind_above_the_limit_holds_the_mission_and_it_resumes(vehicle: str) -> None:
    bp = load_blueprint(CASE_STUDY)
    faults = Faults(wind=WindConfig(direction_deg=270.0, schedule=GUST_FRONT))
    mission = SimulatedMission.from_blueprint(bp, seed=0, faults=faults, vehicle=vehicle, max_time_s=900.0)
    airborne_in_the_hold: list[float] = []

    def watch(now_s: float) -> None:
        if 120.0 <= now_s <= 200.0:
            flying = [u.name for u in mission.world.uavs.values() if not u.vehicle.on_ground]
            if flying:
                airborne_in_the_hold.append(now_s)

    mission.tick_hooks.append(watch)
    report = mission.run()
    assert report.completed, report
    tasks = json.loads(report.to_json())["tasks"]
    attempts = [a for t in tasks for a in t["attempts_detail"]]
    assert sorted(t["id"] for t in tasks if t["status"] == "done") == ["A0", "A1", "B0", "B1"]
    assert all(t["attempts"] == 1 for t in tasks), [(t["id"], t["attempts"]) for t in tasks]
    # nothing started while the wind was above the limit (from 33 s, where it passes 8 m/s, to 200.6 s, where
    # it falls below the limit less the margin, 7.5 m/s)
    assert not [a for a in attempts if 34.0 <= a["start_s"] <= 200.5], attempts
    assert any(a["start_s"] > 200.5 for a in attempts)
    assert not airborne_in_the_hold, airborne_in_the_hold[:3]  # everyone had landed
