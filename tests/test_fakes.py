"""The scripted fakes behave like the ports they stand for (and like the simulated adapters where both apply)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from masonry.blueprint import Blueprint, Brick, MarkerSpec, UavSpec
from masonry.errors import CommandRejected, HardwareError, LinkLost
from masonry.fakes import (
    FakeBrick,
    FakeCamera,
    FakeClock,
    FakeFlightController,
    FakeGripper,
    FakeSprayer,
    QueueMissionLink,
)
from masonry.planner.tasks import AdhesionTask
from masonry.ports import Camera, Clock, FlightController, Gripper, MissionLink, Sprayer, TaskResult


def test_every_fake_satisfies_its_protocol() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock)
    assert isinstance(clock, Clock)
    assert isinstance(fc, FlightController)
    assert isinstance(FakeGripper(), Gripper)
    assert isinstance(FakeSprayer(), Sprayer)
    assert isinstance(FakeCamera(fc), Camera)
    assert isinstance(QueueMissionLink(), MissionLink)


def test_clock_advances_only_when_told() -> None:
    clock = FakeClock(5.0)
    assert clock.now_s() == 5.0
    clock.sleep(1.5)
    clock.advance(0.5)
    assert clock.now_s() == 7.0
    with pytest.raises(ValueError):
        clock.advance(-1.0)


def _fly(clock: FakeClock, fc: FakeFlightController, seconds: float, velocity=(0.0, 0.0, 0.0)) -> None:
    for _ in range(round(seconds / 0.05)):
        if velocity != (0.0, 0.0, 0.0):
            fc.send_velocity(velocity, 0.0)
        clock.advance(0.05)


def test_flight_controller_takeoff_move_land() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock, position_m=(1.0, 2.0, 0.0))
    assert fc.telemetry().on_ground and not fc.telemetry().armed
    fc.arm()
    fc.takeoff(1.2)
    _fly(clock, fc, 4.0)
    tel = fc.telemetry()
    assert tel.position_m[2] == pytest.approx(1.2, abs=0.05)
    assert not tel.on_ground
    _fly(clock, fc, 2.0, velocity=(0.5, 0.0, 0.0))
    assert fc.telemetry().position_m[0] == pytest.approx(2.0, abs=0.1)
    fc.land()
    _fly(clock, fc, 5.0)
    tel = fc.telemetry()
    assert tel.on_ground and not tel.armed and tel.position_m[2] == 0.0
    assert [c[1] for c in fc.commands] == ["arm", "takeoff", "land"]


def test_flight_controller_refuses_with_typed_errors() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock, arm_rejection="pre-arm check failed")
    with pytest.raises(CommandRejected, match="pre-arm check failed"):
        fc.arm()
    with pytest.raises(CommandRejected, match="not armed"):
        fc.takeoff(1.0)
    with pytest.raises(CommandRejected, match="no position"):
        FakeFlightController(clock, position_ok=False).arm()


def test_flight_controller_scripted_link_loss_lands_by_itself() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock)
    fc.arm()
    fc.takeoff(1.0)
    fc.at(3.0, link_ok=False)
    _fly(clock, fc, 2.9)
    assert fc.telemetry().link_ok
    clock.advance(0.2)
    assert not fc.telemetry().link_ok
    with pytest.raises(LinkLost):
        fc.send_velocity((0.0, 0.0, 0.0), 0.0)
    clock.advance(10.0)
    assert fc.telemetry().on_ground  # the autopilot's own failsafe landed it


def test_flight_controller_scripted_failure_and_battery() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock, battery_drain_per_s=0.01)
    fc.arm()
    fc.takeoff(1.0)
    fc.at(2.0, failure="motor failure")
    clock.advance(1.0)
    assert fc.telemetry().battery_fraction == pytest.approx(0.99)
    clock.advance(1.5)
    with pytest.raises(HardwareError, match="motor failure"):
        fc.telemetry()
    assert fc.position_m[2] < 1.0  # falling
    with pytest.raises(AttributeError):
        fc.at(1.0, no_such_knob=1)


def test_flight_controller_floor_blocks_descent() -> None:
    clock = FakeClock()
    fc = FakeFlightController(clock)
    fc.arm()
    fc.takeoff(1.5)
    _fly(clock, fc, 4.0)
    fc.floor_z_m = 1.0
    _fly(clock, fc, 3.0, velocity=(0.0, 0.0, -0.5))
    assert fc.telemetry().position_m[2] == pytest.approx(1.0)


def test_gripper_scripted_failures_contact_and_stuck_release() -> None:
    touching = {"now": False}
    g = FakeGripper(contact=lambda: touching["now"], failures=1, stuck_releases=1)
    g.set_magnet(True)
    touching["now"] = True
    assert not g.is_attached()  # first attempt fails
    g.set_magnet(False)
    g.set_magnet(True)
    assert g.attempts == 2 and g.is_attached()
    g.set_magnet(False)
    assert g.is_attached()  # stuck once
    g.set_magnet(False)
    assert not g.is_attached()
    g.set_joint_locked(False)
    assert not g.joint_locked


def test_sprayer_records_open_intervals() -> None:
    clock = FakeClock()
    s = FakeSprayer(clock)
    s.set_valve(True)
    clock.advance(2.0)
    s.set_valve(False)
    assert s.intervals == [(0.0, 2.0)] and not s.is_valve_open()
    with pytest.raises(CommandRejected):
        FakeSprayer(clock, open_rejection="canister empty").set_valve(True)


def _hovering_fc(xy=(0.0, 0.0), z=1.2, yaw=0.0) -> tuple[FakeClock, FakeFlightController]:
    clock = FakeClock()
    fc = FakeFlightController(clock, position_m=(xy[0], xy[1], z), yaw_rad=yaw)
    return clock, fc


def test_camera_sees_markers_where_they_are() -> None:
    clock, fc = _hovering_fc(yaw=0.7)
    brick = FakeBrick(3, (0.1, -0.05, 0.10), yaw_rad=0.4)
    cam = FakeCamera(fc, [brick])
    frame = cam.read()
    assert frame is not None and frame.tags is not None
    assert sorted(t.marker_id for t in frame.tags) == [6, 7]
    T = cam.T_world_cam()
    for tag in frame.tags:
        p_world = T[:3, :3] @ tag.position_m + T[:3, 3]
        sign = 1.0 if tag.marker_id == 6 else -1.0
        expected = np.array(brick.top_center_m) + sign * 0.0875 * np.array(
            [math.cos(0.4), math.sin(0.4), 0.0]
        )
        assert np.allclose(p_world, expected, atol=1e-9)
        R_world_marker = T[:3, :3] @ tag.R_cam_marker
        assert math.atan2(R_world_marker[1, 0], R_world_marker[0, 0]) == pytest.approx(0.4)
    assert cam.read() is None  # next frame only after 1/rate_hz
    clock.advance(0.04)
    assert cam.read() is not None


def test_camera_field_of_view_hidden_dropout_blind() -> None:
    clock, fc = _hovering_fc()
    far = FakeBrick(0, (1.5, 0.0, 0.1))
    cam = FakeCamera(fc, [far, FakeBrick(1, (0.0, 0.0, 0.1))], hidden=frozenset({3}))
    frame = cam.read()
    assert frame is not None and [t.marker_id for t in frame.tags or ()] == [2]
    cam.at(0.1, blind=True)
    clock.advance(0.1)
    assert cam.read() is None
    cam2 = FakeCamera(fc, [FakeBrick(1, (0.0, 0.0, 0.1))], dropout=1.0)
    frame2 = cam2.read()
    assert frame2 is not None and frame2.tags == ()


def test_camera_noise_is_seeded() -> None:
    _, fc = _hovering_fc()
    a = FakeCamera(fc, [FakeBrick(0, (0.0, 0.0, 0.1))], noise_sigma_m=0.01, seed=4).read()
    b = FakeCamera(fc, [FakeBrick(0, (0.0, 0.0, 0.1))], noise_sigma_m=0.01, seed=4).read()
    assert a is not None and b is not None and a.tags and b.tags
    assert np.array_equal(a.tags[0].position_m, b.tags[0].position_m)


def test_queue_mission_link() -> None:
    task = AdhesionTask("A0", 0, 1, (0.0, 0.0, 0.2), (0.3, 0.0, 0.2), 0.3)
    link = QueueMissionLink([task])
    assert link.pending == 1
    assert link.poll_task() is task
    assert link.poll_task() is None
    link.report_progress("A0", "spray", 3.0)
    link.report_result(TaskResult("A0", "done", 10.0))
    assert link.progress == [("A0", "spray", 3.0)] and link.results[0].status == "done"


# -- one contract, two implementations: the fake and the simulated flight controller ----------------------------


def _sim_fc() -> tuple[object, object, object]:
    from masonry.sim import World

    bp = Blueprint(
        bricks=(Brick(0, (5.0, 5.0, 0.05), placed=True),),
        fleet=(UavSpec("u", "brick", (0.0, 0.0, 0.0)),),
        markers=MarkerSpec(),
    )
    world = World(bp, seed=1)
    uav = world.add_uav(bp.fleet[0])
    return uav.fc, world.clock, world.step


def _fake_fc() -> tuple[object, object, object]:
    clock = FakeClock()
    return FakeFlightController(clock), clock, clock.advance


@pytest.mark.parametrize("make", [_fake_fc, _sim_fc], ids=["fake", "sim"])
def test_flight_controller_contract(make) -> None:
    fc, _, advance = make()
    fc.connect()
    z0 = fc.telemetry().position_m[2]
    assert fc.telemetry().on_ground
    fc.arm()
    fc.takeoff(1.0)
    for _ in range(120):
        advance(0.05)
    tel = fc.telemetry()
    assert tel.armed and not tel.on_ground
    assert tel.position_m[2] - z0 == pytest.approx(1.0, abs=0.08)
    x0 = tel.position_m[0]
    for _ in range(40):
        fc.send_velocity((0.5, 0.0, 0.0), 0.0)
        advance(0.05)
    assert fc.telemetry().position_m[0] - x0 == pytest.approx(1.0, abs=0.25)
    fc.land()
    for _ in range(200):
        advance(0.05)
    tel = fc.telemetry()
    assert tel.on_ground and not tel.armed
    fc.close()


def test_scripted_clearance_link_answers_then_grants() -> None:
    from masonry.fakes import ScriptedClearanceLink
    from masonry.ports import ClearanceLink

    clock = FakeClock()
    link = ScriptedClearanceLink(
        [], clock, layer_m=2.4, answer_after_s=1.0, grant_after_s=3.0, hold_m=(1, 1, 2.4)
    )
    assert isinstance(link, ClearanceLink) and isinstance(link, MissionLink) and not link.swaps_batteries
    site = (2.0, 0.0, 1.2)
    assert link.request_clearance(site) is None
    clock.advance(1.5)
    answer = link.request_clearance(site, 2.0)
    assert (
        answer is not None and not answer.granted and answer.layer_m == 2.4 and answer.hold_m == (1, 1, 2.4)
    )
    clock.advance(1.5)
    answer = link.request_clearance(site)
    assert answer is not None and answer.granted and answer.hold_m is None
    assert link.asked == {site: 0.0}
    link.end_transit(site)
    assert link.arrived == [site]
    assert ScriptedClearanceLink([], clock, swaps_batteries=True).swaps_batteries
    assert not isinstance(QueueMissionLink([]), ClearanceLink)
