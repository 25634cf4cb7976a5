"""The carried brick's offset on the magnet, seen by the camera (issue 30, masonry.fsm.carried_look): the px4 brick
UAV measures how far its brick hangs off the effector and aims the brick, not the effector, at the drop-off."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from masonry.blueprint import parse_blueprint
from masonry.blueprint_gen import towers
from masonry.fsm.brick import BrickUav
from masonry.fsm.carried_look import CarriedLook
from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.mission.simulate import SimulatedMission
from px4_sitl import ONE_BRICK

YAW = math.radians(30.0)


def _carry_truth_m(mission: SimulatedMission, uav: str) -> np.ndarray:
    """The simulator's truth of the carried brick's offset on the magnet, in the world's x-y (m)."""
    sim = mission.world.uavs[uav]
    bx, by, _ = sim._carry_offset  # body frame
    c, s = math.cos(sim.vehicle.yaw_rad), math.sin(sim.vehicle.yaw_rad)
    return np.array([c * bx - s * by, s * bx + c * by])


def test_nothing_seen_is_no_offset() -> None:
    look = CarriedLook()
    assert look.frames == 0
    assert np.array_equal(look.world_m(1.0), np.zeros(3))
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).carried_look is True  # (it acts only with align_on_wall)
    assert uav_settings("px4", {"carried_look": False})["carried_look"] is False


@pytest.mark.slow
def test_the_offset_on_the_magnet_is_measured_and_the_brick_lands_on_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The px4 model, a tower of three turned 30 degrees, seed 1: at each release the offset the camera measured
    over the placement is the simulator's carry offset (the conical guide's residual) to 0.5 mm, and the brick's
    target is the effector's less it."""
    bp = towers(1, 3, spacing_m=1.0, yaw_rad=YAW, clearance_m=1.0, brick_uavs=1, adhesion_uavs=1)
    mission = SimulatedMission.from_blueprint(bp, seed=1, vehicle="px4")
    seen: list[tuple[int, np.ndarray, np.ndarray]] = []
    release = BrickUav.enter_place_release

    def record(self: BrickUav, *args: object, **kwargs: object) -> None:
        truth = _carry_truth_m(mission, self.config.name)
        seen.append((self._wall.carried.frames, truth, self._wall.carried.world_m(self._place_yaw_rad())[:2]))
        release(self, *args, **kwargs)

    monkeypatch.setattr(BrickUav, "enter_place_release", record)
    assert mission.run().completed
    assert len(seen) == 3
    for frames, truth, measured in seen:
        assert frames >= 10
        assert (
            float(np.hypot(*truth)) > 0.0005
        )  # a real offset to find (the guide leaves a fifth of the pickup's)
        assert float(np.hypot(*(measured - truth))) < 0.0005, (truth, measured)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_a_lone_bricks_target_is_its_design_less_the_offset_on_the_magnet(
    monkeypatch: pytest.MonkeyPatch, seed: int
) -> None:
    """Issue 29's one-brick scenario (tests/px4_sitl.py ``ONE_BRICK``) on the px4 model: a lone brick has no wall
    to align on, and its target was its design whatever the offset on the magnet, which then added to where the
    gate let go (the real PX4: 4.1 mm the gate's way, a brick let go 7.0 mm off rested 10.0 mm off; branch
    ``px447``). At the release the target is the design less the offset the camera measured over the placement,
    and that is the simulator's carry offset to 0.5 mm (seeds 0 and 1: 6.0 and 5.7 mm)."""
    bp = parse_blueprint(yaml.safe_load(ONE_BRICK))
    mission = SimulatedMission.from_blueprint(bp, seed=seed, vehicle="px4")
    seen: list[tuple[int, np.ndarray, np.ndarray]] = []
    release = BrickUav.enter_place_release

    def record(self: BrickUav, *args: object, **kwargs: object) -> None:
        truth = _carry_truth_m(mission, self.config.name)
        target = np.asarray(self.attempt.place_effector_target_m, dtype=float)[:2]
        seen.append((self._wall.carried.frames, truth, target - np.asarray(self.brick_task.position_m[:2])))
        release(self, *args, **kwargs)

    monkeypatch.setattr(BrickUav, "enter_place_release", record)
    assert mission.run().completed
    assert len(seen) == 1
    frames, truth, target_off = seen[0]
    assert frames >= 10
    assert float(np.hypot(*truth)) > 0.005  # an offset to take off (the guide leaves a fifth of the pickup's)
    assert float(np.hypot(*(target_off + truth))) < 0.0005, (truth, target_off)
