"""One Gripper contract, run against the scripted fake, the simulator's gripper and the Arduino adapter on its fake
firmware (a pseudo-terminal).

Each rig says how its gripper meets a brick (``touch``: the fake's contact, the simulated UAV lowered onto a brick,
the board's brick sensor) and how time passes (``settle``). What every Gripper must do: start released, attach
only with the magnet on and a brick in contact, let go when the magnet goes off, accept repeated commands, and let
go at a time asked (``release_at``) by then, or say it cannot (False) and have let go at once.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import pytest

from masonry.ports import Gripper


@dataclass
class Rig:
    gripper: Gripper
    touch: Callable[[], None]  # bring the magnet onto a brick
    settle: Callable[[], None]  # let the device and the world react (0.3 s of its clock at least)
    now_s: Callable[[], float]  # the gripper's clock (the UAV's)


def _fake_rig() -> Iterator[Rig]:
    from masonry.fakes import FakeClock, FakeGripper

    contact = {"on": False}
    clock = FakeClock()
    gripper = FakeGripper(contact=lambda: contact["on"], clock=clock)
    yield Rig(gripper, lambda: contact.update(on=True), lambda: clock.advance(0.3), clock.now_s)


def _sim_rig() -> Iterator[Rig]:
    from sim_helpers import hover, take_off
    from test_sim_world import TARGET, descend_on, world

    w = world(seed=1)
    uav = w.uavs["brick-1"]
    take_off(w, uav)

    def touch() -> None:
        x, y, top = w.bricks[TARGET.id].top_center_m
        assert descend_on(w, uav, (x, y), top), "the simulated UAV did not reach the brick"

    yield Rig(uav.gripper, touch, lambda: hover(w, uav, 0.3), w.clock.now_s)


def _arduino_rig() -> Iterator[Rig]:
    from masonry.adapters.arduino import ArduinoActuators
    from masonry.adapters.arduino_fake import FakeArduino

    with FakeArduino() as board, ArduinoActuators(board.port, boot_wait_s=0.05, timeout_s=0.5) as actuators:
        # the guide's brick switch; the board lets go when told (its magnet off clears the switch)
        yield Rig(actuators, lambda: board.logic.set_attached(True), lambda: None, time.monotonic)


RIGS = {"fake": _fake_rig, "sim": _sim_rig, "arduino": _arduino_rig}


@pytest.fixture(params=sorted(RIGS))
def rig(request) -> Iterator[Rig]:
    yield from RIGS[request.param]()


def test_is_a_gripper_and_starts_released(rig: Rig) -> None:
    assert isinstance(rig.gripper, Gripper)
    assert rig.gripper.is_attached() is False


def test_magnet_on_a_brick_attaches_and_magnet_off_lets_go(rig: Rig) -> None:
    g = rig.gripper
    g.set_joint_locked(False)  # the ball joint free to align the magnet with the brick's face
    g.set_magnet(True)
    rig.touch()
    rig.settle()
    assert g.is_attached() is True
    g.set_magnet(False)
    rig.settle()
    assert g.is_attached() is False


def test_magnet_without_a_brick_attaches_nothing(rig: Rig) -> None:
    g = rig.gripper
    g.set_joint_locked(False)
    g.set_magnet(True)
    rig.settle()
    assert g.is_attached() is False
    g.set_magnet(False)
    assert g.is_attached() is False


def test_repeated_commands_are_accepted(rig: Rig) -> None:
    g = rig.gripper
    for _ in range(2):
        g.set_magnet(False)
        g.set_joint_locked(True)
    for _ in range(2):
        g.set_joint_locked(False)
    rig.settle()
    assert g.is_attached() is False


def _holding_a_brick(rig: Rig) -> Gripper:
    """The rig's gripper with its magnet on a brick, the ball joint free."""
    g = rig.gripper
    g.set_joint_locked(False)
    g.set_magnet(True)
    rig.touch()
    rig.settle()
    return g


def test_release_at_lets_go_then_or_at_once(rig: Rig) -> None:
    g = _holding_a_brick(rig)
    assert g.is_attached() is True
    timed = g.release_at(rig.now_s() + 0.12)
    assert isinstance(timed, bool)
    if timed:
        assert g.is_attached() is True  # not yet
        rig.settle()
    assert g.is_attached() is False


def test_release_at_a_time_past_lets_go_at_once(rig: Rig) -> None:
    g = _holding_a_brick(rig)
    g.release_at(rig.now_s() - 1.0)
    assert g.is_attached() is False
