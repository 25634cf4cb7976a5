"""One record of a UAV's ports (``masonry.ports.UavPorts``): every producer returns it, every consumer takes it."""

from __future__ import annotations

import dataclasses

import pytest

from masonry.blueprint_gen import running_bond
from masonry.ports import Camera, Clock, FlightController, Gripper, Sprayer, UavPorts
from masonry.sim import World


def test_a_simulated_uav_holds_its_ports_on_the_world_clock_and_step() -> None:
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=0)
    world = World(bp, seed=0)
    uav = world.add_fleet()[0]
    ports = uav.ports
    assert isinstance(ports, UavPorts)
    assert (ports.fc, ports.gripper, ports.sprayer, ports.camera) == (
        uav.fc,
        uav.gripper,
        uav.sprayer,
        uav.camera,
    )
    assert ports.clock is world.clock and ports.world is world
    assert isinstance(ports.fc, FlightController) and isinstance(ports.gripper, Gripper)
    assert isinstance(ports.sprayer, Sprayer) and isinstance(ports.camera, Camera)
    assert isinstance(ports.clock, Clock)
    ports.advance(0.5)
    assert world.clock.now_s() == pytest.approx(0.5)
    ports.close()  # nothing to close in a simulation: no error


def test_the_record_is_frozen() -> None:
    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=0)
    ports = World(bp, seed=0).add_fleet()[0].ports
    with pytest.raises(dataclasses.FrozenInstanceError):
        ports.fc = None  # type: ignore[misc]


def test_open_adapters_returns_the_record_and_closes_newest_first() -> None:
    from masonry.adapters.wiring import HardwareConfig, open_adapters

    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=0)
    opened = open_adapters(HardwareConfig(), blueprint=bp, spec=bp.fleet[0])
    assert isinstance(opened, UavPorts)
    assert opened.world is not None and opened.clock is opened.world.clock  # type: ignore[attr-defined]
    assert set(opened.descriptions) == {"flight controller", "actuators", "camera"}
    # a simulated flight controller: the simulated camera sees from the simulated UAV, not from an autopilot
    assert opened.descriptions["camera"] == "simulated (geometric), seen from the simulated UAV"
    opened.close()


def test_the_cli_and_the_remote_uav_take_the_same_record() -> None:
    from masonry.cli.fly import select_adapters
    from masonry.sim import Faults

    bp = running_bond(1, 2, brick_uavs=1, adhesion_uavs=0)
    ports = select_adapters(
        sim=True, blueprint=bp, spec=bp.fleet[0], seed=0, camera="geometric", faults=Faults()
    )
    assert isinstance(ports, UavPorts) and ports.world is not None
