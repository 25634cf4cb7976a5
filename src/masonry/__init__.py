"""masonry: autonomous aerial masonry with heterogeneous UAV teams (planner, state machines, perception, sim)."""

from __future__ import annotations

from masonry.blueprint import Blueprint, Brick, MarkerSpec, UavSpec
from masonry.errors import (
    BlueprintError,
    CommandRejected,
    CommandTimeout,
    DeviceNotFound,
    HardwareError,
    InputError,
    JournalError,
    LinkLost,
    MasonryError,
    MissionError,
    PerceptionError,
    PlanningError,
    ProtocolError,
)

__version__ = "0.1.0.dev0"

__all__ = sorted(
    [
        "Blueprint",
        "BlueprintError",
        "Brick",
        "CommandRejected",
        "CommandTimeout",
        "DeviceNotFound",
        "HardwareError",
        "InputError",
        "JournalError",
        "LinkLost",
        "MarkerSpec",
        "MasonryError",
        "MissionError",
        "PerceptionError",
        "PlanningError",
        "ProtocolError",
        "UavSpec",
    ]
)
