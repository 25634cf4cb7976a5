"""masonry: autonomous aerial masonry with heterogeneous UAV teams (planner, state machines, perception, sim).

The pure core (blueprint, planner, motion, estimation math), the state machines, the simulator and mission
control are importable from here. Hardware adapters are loaded on first use, so ``import masonry`` never
imports pymavlink, pyserial or OpenCV.
"""

from __future__ import annotations

from typing import Any

from masonry.airframe import DEFAULT_AIRFRAME, Airframe
from masonry.blueprint import (
    Blueprint,
    Brick,
    MarkerSpec,
    UavSpec,
    format_blueprint,
    load_blueprint,
    parse_blueprint,
)
from masonry.errors import (
    BlueprintError,
    CommandRejected,
    CommandTimeout,
    DeviceNotFound,
    HardwareError,
    InputError,
    InvalidArgument,
    JournalError,
    JournalUnusable,
    LinkLost,
    MasonryError,
    MissionError,
    PerceptionError,
    PlanningError,
    ProtocolError,
)
from masonry.fsm import AdhesionUav, BrickUav, UavConfig, fly_task, run_single_task
from masonry.mission import (
    Journal,
    JournalState,
    MissionControl,
    MissionReport,
    SimOptions,
    SimulatedMission,
    UavHandler,
    simulate,
)
from masonry.motion import PID, AxisGains, MinJerk, PIDGains
from masonry.perception import (
    C_TH,
    BrickEstimate,
    CameraIntrinsics,
    EstimatorConfig,
    PoseWindow,
    TagPose,
    estimate_brick_pose,
    refine_markers,
)
from masonry.planner import (
    AdhesionTask,
    Assignment,
    BrickTask,
    Dispatcher,
    Plan,
    Task,
    estimate_durations_s,
    lower_bound_s,
    min_cycles_s,
    min_durations_s,
    plan,
)
from masonry.ports import (
    PHASES,
    Camera,
    CameraFrame,
    ClearanceLink,
    Clock,
    FlightController,
    Gripper,
    MissionLink,
    PhaseTimes,
    Sprayer,
    TaskResult,
    Telemetry,
    UavPorts,
)
from masonry.sim import Faults, SimClock, SimUav, SimVehicle, VehicleModel, World
from masonry.spares import Spare
from masonry.timing import TaskTiming

__version__ = "0.1.0.dev0"

#: Hardware adapters, imported on first access (they pull in pymavlink, pyserial, OpenCV).
_LAZY = {
    "ArduinoActuators": "masonry.adapters",
    "HardwareConfig": "masonry.adapters",
    "MavlinkFlightController": "masonry.adapters",
    "MavlinkSitl": "masonry.adapters",
    "OpenCvCamera": "masonry.adapters",
    "UdpPoseSource": "masonry.adapters",
}

__all__ = [
    "C_TH",
    "DEFAULT_AIRFRAME",
    "PHASES",
    "PID",
    "AdhesionTask",
    "AdhesionUav",
    "Airframe",
    "ArduinoActuators",
    "Assignment",
    "AxisGains",
    "Blueprint",
    "BlueprintError",
    "Brick",
    "BrickEstimate",
    "BrickTask",
    "BrickUav",
    "Camera",
    "CameraFrame",
    "CameraIntrinsics",
    "ClearanceLink",
    "Clock",
    "CommandRejected",
    "CommandTimeout",
    "DeviceNotFound",
    "Dispatcher",
    "EstimatorConfig",
    "Faults",
    "FlightController",
    "Gripper",
    "HardwareConfig",
    "HardwareError",
    "InputError",
    "InvalidArgument",
    "Journal",
    "JournalError",
    "JournalState",
    "JournalUnusable",
    "LinkLost",
    "MarkerSpec",
    "MasonryError",
    "MavlinkFlightController",
    "MavlinkSitl",
    "MinJerk",
    "MissionControl",
    "MissionError",
    "MissionLink",
    "MissionReport",
    "OpenCvCamera",
    "PIDGains",
    "PerceptionError",
    "PhaseTimes",
    "Plan",
    "PlanningError",
    "PoseWindow",
    "ProtocolError",
    "SimClock",
    "SimOptions",
    "SimUav",
    "SimVehicle",
    "SimulatedMission",
    "Spare",
    "Sprayer",
    "TagPose",
    "Task",
    "TaskResult",
    "TaskTiming",
    "Telemetry",
    "UavConfig",
    "UavHandler",
    "UavPorts",
    "UavSpec",
    "UdpPoseSource",
    "VehicleModel",
    "World",
    "estimate_brick_pose",
    "estimate_durations_s",
    "fly_task",
    "format_blueprint",
    "load_blueprint",
    "lower_bound_s",
    "min_cycles_s",
    "min_durations_s",
    "parse_blueprint",
    "plan",
    "refine_markers",
    "run_single_task",
    "simulate",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'masonry' has no attribute {name!r}")
    import importlib

    return getattr(importlib.import_module(module), name)
