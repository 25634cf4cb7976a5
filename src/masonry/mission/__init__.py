"""Mission control (paper Algorithm 1 at run time), its messages, transports, journal and the whole-mission simulator.

``ZenohTransport`` is loaded on first use so that importing this package does not import zenoh.
"""

from __future__ import annotations

from typing import Any

from masonry.mission.auth import AuthenticatedTransport
from masonry.mission.control import MissionControl
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus, InprocTransport
from masonry.mission.journal import Journal, JournalState, read_journal
from masonry.mission.messages import PROTOCOL_VERSION, decode, encode
from masonry.mission.report import MissionReport
from masonry.mission.sim_options import SimOptions
from masonry.mission.simulate import SimulatedMission, simulate
from masonry.mission.transport import Transport

__all__ = [
    "PROTOCOL_VERSION",
    "AuthenticatedTransport",
    "InprocBus",
    "InprocTransport",
    "Journal",
    "JournalState",
    "MissionControl",
    "MissionReport",
    "SimOptions",
    "SimulatedMission",
    "Transport",
    "UavHandler",
    "ZenohTransport",
    "decode",
    "encode",
    "read_journal",
    "simulate",
]


def __getattr__(name: str) -> Any:
    if name == "ZenohTransport":
        from masonry.mission.zenoh_transport import ZenohTransport

        return ZenohTransport
    raise AttributeError(f"module 'masonry.mission' has no attribute {name!r}")
