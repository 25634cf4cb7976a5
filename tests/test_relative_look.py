"""The as-built pose relative to the wall (issue 30, ``masonry.fsm.relative_look``): the placed brick's offset from
a neighbour seen in the same frames cancels the position source's error, which the world-frame pose carries."""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from masonry.blueprint_gen import running_bond
from masonry.fsm.relative_look import RelativeLook
from masonry.mission.messages import Result, decode, encode
from masonry.mission.simulate import SimulatedMission
from masonry.perception.types import AsBuiltPose
from masonry.ports import TaskResult, Telemetry
from masonry.sim.vehicle import SimVehicle

BIAS_M = (0.10, 0.0, 0.0)


class BiasedVehicle(SimVehicle):
    """A vehicle whose reported position is off by a constant 10 cm (a GNSS offset that never moves)."""

    def telemetry(self, *, link_ok: bool = True) -> Telemetry:
        tel = super().telemetry(link_ok=link_ok)
        return dataclasses.replace(tel, position_m=tuple(p + b for p, b in zip(tel.position_m, BIAS_M)))


def biased_vehicle(spec: object, config: object, **kw: object) -> SimVehicle:
    return BiasedVehicle(config, **kw)  # type: ignore[arg-type]


def _true_top(mission: SimulatedMission, bid: int) -> np.ndarray:
    brick = mission.world.bricks[bid]
    return np.asarray(brick.position_m) + np.array([0.0, 0.0, brick.blueprint.size_m[2] / 2.0])


@pytest.fixture(scope="module")
def biased_run() -> tuple[SimulatedMission, object]:
    """A 2 x 3 running bond flown by UAVs whose position is 10 cm off in x (simulated time, seed 1)."""
    mission = SimulatedMission.from_blueprint(running_bond(2, 3), seed=1, vehicle_model=biased_vehicle)
    return mission, mission.run()


def test_a_constant_10_cm_position_bias_cancels_in_the_relative_estimate(biased_run) -> None:
    mission, report = biased_run
    assert report.completed
    relative = 0
    for tid, pose in report.as_built.items():
        bid = int(tid[1:])
        truth = mission.world.bricks[bid].position_m
        # the world-frame pose carries the bias whole: the camera's view placed by the biased position
        assert 0.08 < math.dist(pose.position_m, truth) < 0.12
        if pose.relative_to is None:
            continue
        relative += 1
        assert pose.relative_offset_m is not None and pose.relative_deviation_m is not None
        true_offset = _true_top(mission, bid) - _true_top(mission, pose.relative_to)
        # the relative one does not: a few millimetres of camera noise
        assert float(np.linalg.norm(np.subtract(pose.relative_offset_m, true_offset))) < 0.005
        design = mission.blueprint.brick(bid).position_m
        ref = mission.blueprint.brick(pose.relative_to).position_m
        designed = np.subtract(design, ref)  # (bricks of one height: the tops' offset is the centres')
        assert pose.relative_deviation_m == pytest.approx(
            float(np.linalg.norm(np.subtract(pose.relative_offset_m, designed))), abs=1e-9
        )
        assert mission.world.bricks[pose.relative_to].state == "placed"
    assert relative == len(report.as_built) - 1  # all but the first brick placed saw one placed before


def test_the_report_json_carries_the_relative_fields(biased_run) -> None:
    _, report = biased_run
    data = json.loads(report.to_json())
    with_ref = {tid: p for tid, p in data["as_built"].items() if "relative_to" in p}
    assert with_ref
    for tid, p in with_ref.items():
        pose = report.as_built[tid]
        assert p["relative_to"] == pose.relative_to and isinstance(p["relative_to"], int)
        assert p["relative_offset_m"] == pytest.approx(pose.relative_offset_m, abs=1e-4)
        # what the JSON says is the report's figure (the placement itself is judged by bench_as_built.py)
        assert p["relative_deviation_m"] == pytest.approx(pose.relative_deviation_m, abs=1e-4)
    assert f"as-built relative to a neighbour ({len(with_ref)} bricks): deviation from the design mean" in (
        report.summary()
    )


WALL = {1: np.array([0.0, 0.0, 0.1]), 2: np.array([0.3, 0.0, 0.1]), 3: np.array([0.15, 0.0, 0.2])}


def test_the_neighbour_seen_most_is_the_reference_and_ties_go_to_the_nearest() -> None:
    look = RelativeLook(window_size=5, sigma_tol_m=0.04)
    own = np.array([0.16, 0.01, 0.2])
    look.add(3, own, {1: np.array([0.0, 0.0, 0.1]), 2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {1: np.array([0.0, 0.0, 0.1]), 2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {2: np.array([0.3, 0.0, 0.1])}, WALL)
    rel = look.pose(3, WALL)
    assert rel is not None and rel.relative_to == 2 and rel.frames == 3
    assert rel.offset_m == pytest.approx((-0.14, 0.01, 0.1))
    assert rel.deviation_m == pytest.approx(math.hypot(0.01, 0.01))
    tie = RelativeLook(window_size=5, sigma_tol_m=0.04)
    for _ in range(2):
        tie.add(3, own, {2: np.array([0.3, 0.0, 0.1]), 1: np.array([0.0, 0.0, 0.1])}, WALL)
    assert tie.pose(3, WALL).relative_to == 1  # type: ignore[union-attr]  # (equidistant: the lower id)


def test_bricks_off_the_wall_the_own_brick_and_a_single_frame_are_no_reference() -> None:
    look = RelativeLook(window_size=3, sigma_tol_m=0.04)
    own = np.array([0.15, 0.0, 0.2])
    for _ in range(4):  # brick 1 on its pallet (1 m from its design), brick 9 not in the wall
        look.add(3, own, {1: np.array([1.0, 0.0, 0.1]), 3: own, 9: np.array([0.2, 0.0, 0.1])}, WALL)
    look.add(3, own, {2: np.array([0.3, 0.0, 0.1])}, WALL)  # one frame only: no confidence
    assert look.pose(3, WALL) is None
    look.add(3, own, {2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {2: np.array([0.5, 0.0, 0.1])}, WALL)  # the window is full: the first frames are kept
    assert look.pose(3, WALL).offset_m == pytest.approx((-0.15, 0.0, 0.1))  # type: ignore[union-attr]
    assert look.pose(7, WALL) is None  # (the wall has no design for it)
    look.begin()
    assert look.pose(3, WALL) is None


REL = AsBuiltPose((1.0, 2.0, 0.15), 0.5, 0.012, 0.9, 4, (0.25, 0.0, 0.0), 0.003)


def test_the_relative_fields_go_over_the_wire_and_bad_ones_are_refused() -> None:
    assert AsBuiltPose.from_dict(REL.to_dict()) == REL
    plain = AsBuiltPose((1.0, 2.0, 0.15), 0.5, 0.012, 0.9)
    assert set(plain.to_dict()) == {"position_m", "yaw_rad", "deviation_m", "confidence"}
    msg = Result("brick-1", TaskResult("B3", "done", 71.4, placement_error_m=0.01, as_built=REL), 80.0)
    assert decode(encode(msg)) == msg
    for bad in ({"relative_to": "B4"}, {"relative_deviation_m": -1.0}, {"relative_offset_m": [0.0, 1.0]}):
        with pytest.raises(ValueError, match="relative"):
            AsBuiltPose.from_dict({**REL.to_dict(), **bad})
    missing = REL.to_dict()
    del missing["relative_deviation_m"]
    with pytest.raises(ValueError, match="has no 'relative_deviation_m'"):
        AsBuiltPose.from_dict(missing)


def test_every_neighbour_seen_in_two_frames_is_reported_with_its_frames() -> None:
    look = RelativeLook(window_size=5, sigma_tol_m=0.04)
    own = np.array([0.16, 0.01, 0.2])
    look.add(3, own, {1: np.array([0.0, 0.0, 0.1]), 2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {1: np.array([0.0, 0.0, 0.1]), 2: np.array([0.3, 0.0, 0.1])}, WALL)
    look.add(3, own, {2: np.array([0.3, 0.0, 0.1]), 4: np.array([0.45, 0.0, 0.1])}, WALL)  # (4: one frame)
    every = look.poses(3, WALL)
    assert [(r.relative_to, r.frames) for r in every] == [(1, 2), (2, 3)]
    assert every[0].offset_m == pytest.approx((0.16, 0.01, 0.1))
    assert every[1] == look.pose(3, WALL)  # (the reference among them)
    assert look.poses(7, WALL) == ()


EVERY = dataclasses.replace(REL, relative_offsets=((2, (0.3, 0.0, 0.1), 12), (4, (0.25, 0.0, 0.0), 30)))


def test_every_neighbours_offset_goes_over_the_wire_and_the_journal_not_into_the_report() -> None:
    assert AsBuiltPose.from_dict(EVERY.to_dict()) == EVERY
    assert AsBuiltPose.from_dict(json.loads(json.dumps(EVERY.to_dict()))) == EVERY
    assert "relative_offsets" not in EVERY.to_dict(4)  # (the report's and the events' fields as they were)
    msg = Result("brick-1", TaskResult("B3", "done", 71.4, placement_error_m=0.01, as_built=EVERY), 80.0)
    assert decode(encode(msg)) == msg
    bad_items: list[object] = [
        "B2",
        [[2, [0.3, 0.0], 12]],
        [[2, [0.3, 0.0, 0.1], 0]],
        [[-1, [0.3, 0.0, 0.1], 3]],
        [[True, [0.3, 0.0, 0.1], 3]],
        [[2, [math.inf, 0.0, 0.1], 3]],
        [[2, [0.3, 0.0, 0.1], 3]] * 65,
    ]
    for bad in bad_items:
        with pytest.raises(ValueError, match="relative_offsets"):
            AsBuiltPose.from_dict({**EVERY.to_dict(), "relative_offsets": bad})
