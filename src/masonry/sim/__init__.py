"""The simulated world behind the ports: vehicles, bricks, adhesive, camera and faults on a simulated clock."""

from __future__ import annotations

from masonry.sim.adhesive import AdhesiveDeposit
from masonry.sim.bricks import BrickField, SimBrick
from masonry.sim.camera import DEFAULT_INTRINSICS, CameraConfig
from masonry.sim.clock import SimClock
from masonry.sim.faults import FAULT_KEYS, Faults
from masonry.sim.ports import SimCamera, SimFlightController, SimGripper, SimSprayer
from masonry.sim.vehicle import SimVehicle, VehicleConfig
from masonry.sim.vehicle_model import VehicleModel, sim_vehicle
from masonry.sim.world import CameraMode, SimUav, World, WorldConfig

__all__ = [
    "DEFAULT_INTRINSICS",
    "FAULT_KEYS",
    "AdhesiveDeposit",
    "BrickField",
    "CameraConfig",
    "CameraMode",
    "Faults",
    "SimBrick",
    "SimCamera",
    "SimClock",
    "SimFlightController",
    "SimGripper",
    "SimSprayer",
    "SimUav",
    "SimVehicle",
    "VehicleConfig",
    "VehicleModel",
    "World",
    "WorldConfig",
    "sim_vehicle",
]
