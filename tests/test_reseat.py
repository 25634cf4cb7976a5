"""Re-seating a brick placed out of place (issue 30, masonry.fsm.reseat): the as-built look sees the brick off its
designed offsets to its neighbours, the UAV lifts it and places it again, within the glue's open time only."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

import masonry.sim.release as release_module
import masonry.sim.world as world_module
from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint
from masonry.blueprint_gen import pyramid
from masonry.fsm.config import UavConfig
from masonry.mission.messages import Clearance, decode, encode
from masonry.mission.report import MissionReport
from masonry.mission.simulate import SimulatedMission
from masonry.perception.types import AsBuiltPose
from masonry.sim.release import Pose
from masonry.sim.world import SimUav, World

OFF_M = 0.03  # the first release of the brick lets go this far off (+x), a bad release


def _first_release_off(monkeypatch: pytest.MonkeyPatch, brick_id: int) -> None:
    """Brick ``brick_id``'s first release lets go ``OFF_M`` off where the magnet holds it (later ones as they are)."""
    real = release_module.release_brick
    done: list[bool] = []

    def off(world: World, uav: SimUav, pose: Pose | None = None, at_s: float | None = None) -> None:
        if uav.carried_brick == brick_id and not done:
            done.append(True)
            if pose is None:
                brick = world.field.bricks[brick_id]
                world._carry_pose(uav, brick)
                pose = (brick.position_m, brick.yaw_rad)
            (x, y, z), yaw = pose
            pose = ((x + OFF_M, y, z), yaw)
        real(world, uav, pose, at_s)

    monkeypatch.setattr(release_module, "release_brick", off)
    monkeypatch.setattr(world_module, "release_brick", off)


def _fly(bp: Blueprint, **settings: float) -> tuple[MissionReport, SimulatedMission]:
    config = UavConfig("template", "brick", (0.0, 0.0, 0.0), **settings)  # type: ignore[arg-type]
    mission = SimulatedMission.from_blueprint(bp, seed=0, uav_config=config)
    return mission.run(), mission


def reseat_mission_states(monkeypatch: pytest.MonkeyPatch) -> set[str]:
    """The brick machine's states a mission whose top brick is let go 3 cm off visits (the re-seat's among them):
    what tests/test_fsm_scenarios.py's rig cannot fly (its fake camera does not see a placed brick)."""
    _first_release_off(monkeypatch, 2)
    _, mission = _fly(pyramid(2), reseat_over_m=0.018, align_on_wall=True)
    return {state for h in mission.handlers.values() if h.model.KIND == "brick" for _, state in h.model.trace}


def _off_neighbours_m(mission: SimulatedMission, brick_id: int, neighbours: tuple[int, ...]) -> float:
    """What benchmarks/bench_as_built.py measures: the brick's true offset from its design less its neighbours'."""
    design = {b.id: np.asarray(b.position_m) for b in mission.blueprint.bricks}
    off = {b: np.asarray(mission.world.bricks[b].position_m) - design[b] for b in design}
    return float(np.linalg.norm(off[brick_id] - np.mean([off[n] for n in neighbours], axis=0)))


def test_a_brick_let_go_3_cm_off_its_neighbours_is_reseated_within_2_cm(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A 3-brick pyramid, the top brick B2 (on B0 and B1) let go 3 cm off: left alone it is 3 cm off its
    neighbours; with the re-seat (the px4 preset's 1.8 cm) its UAV lifts it and places it again, within 2 cm, and says so."""
    _first_release_off(monkeypatch, 2)
    report, mission = _fly(pyramid(2), reseat_over_m=0.0, align_on_wall=True)
    assert report.completed
    assert _off_neighbours_m(mission, 2, (0, 1)) > 0.025
    assert report.as_built["B2"].reseats == 0

    _first_release_off(monkeypatch, 2)
    report, mission = _fly(pyramid(2), reseat_over_m=0.018, align_on_wall=True)
    assert report.completed
    assert report.as_built["B2"].reseats == 1
    assert _off_neighbours_m(mission, 2, (0, 1)) < 0.02
    assert report.to_dict()["as_built"]["B2"]["reseats"] == 1  # type: ignore[index]
    trace = [s for h in mission.handlers.values() if h.model.KIND == "brick" for _, s in h.model.trace]
    i = trace.index("reseat_descend")
    assert trace[i - 1 : i + 4] == [
        "place_ascend",
        "reseat_descend",
        "reseat_grasp",
        "reseat_ascend",
        "place_align",
    ]
    assert not [a for a in report.attempts if a.status == "failed"]


def test_the_glue_s_open_time_forbids_a_reseat_that_would_press_the_brick_too_late(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The same bad release with glue under B2: open 600 s, the re-seat is made (mission control's grant says how
    long the glue stays open); open 45 s, it would press the brick too late: left as placed, no open-time
    violation either way (the world measures the glue's age at each release)."""
    bp = pyramid(2)
    _first_release_off(monkeypatch, 2)
    report, mission = _fly(
        dataclasses.replace(bp, adhesive=Adhesive(open_time_s=600.0)), reseat_over_m=0.018, align_on_wall=True
    )
    assert report.completed and report.as_built["B2"].reseats == 1
    assert mission.world.glue.open_violations == []

    _first_release_off(monkeypatch, 2)
    report, mission = _fly(
        dataclasses.replace(bp, adhesive=Adhesive(open_time_s=45.0)), reseat_over_m=0.018, align_on_wall=True
    )
    assert report.completed and report.as_built["B2"].reseats == 0
    assert mission.world.glue.open_violations == []
    assert _off_neighbours_m(mission, 2, (0, 1)) > 0.02


def test_the_reseats_and_the_open_time_go_over_the_wire() -> None:
    pose = AsBuiltPose((0.1, 0.2, 0.05), 0.0, 0.01, 0.9, reseats=2)
    assert AsBuiltPose.from_dict(pose.to_dict()) == pose
    assert "reseats" not in dataclasses.replace(pose, reseats=0).to_dict()
    with pytest.raises(ValueError, match="reseats"):
        AsBuiltPose.from_dict({**pose.to_dict(), "reseats": -1})
    answer = Clearance("mission-control", "brick-1", (0.0, 0.0, 0.1), 0.5, 12.0, True, open_for_s=41.5)
    assert decode(encode(answer)) == answer
    assert decode(encode(dataclasses.replace(answer, open_for_s=None))).open_for_s is None  # type: ignore[union-attr]
