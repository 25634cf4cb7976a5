"""MAVLink numbers, autopilot modes and estimate flags (from common.xml / ardupilotmega.xml): pure values.

Spelled out here so the adapter imports pymavlink only when a connection is opened.
"""

from __future__ import annotations

from typing import Literal

Autopilot = Literal["auto", "ardupilot", "px4"]

# MAVLink numbers used below (from common.xml / ardupilotmega.xml), spelled out so this module imports
# pymavlink only when a connection is opened.
MAV_AUTOPILOT_ARDUPILOTMEGA = 3
MAV_AUTOPILOT_PX4 = 12
MAV_AUTOPILOT_INVALID = 8
MAV_TYPE_GCS = 6
MAV_MODE_FLAG_SAFETY_ARMED = 128
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1
MAV_FRAME_LOCAL_NED = 1
MAV_CMD_NAV_LAND = 21
MAV_CMD_NAV_TAKEOFF = 22
MAV_CMD_DO_SET_MODE = 176
MAV_CMD_COMPONENT_ARM_DISARM = 400
MAV_CMD_SET_MESSAGE_INTERVAL = 511
MAV_RESULT_ACCEPTED = 0
MAV_RESULT_IN_PROGRESS = 5
MAV_RESULT_NAMES = {
    0: "accepted",
    1: "temporarily rejected",
    2: "denied",
    3: "unsupported",
    4: "failed",
    5: "in progress",
    6: "cancelled",
    7: "command only accepted as COMMAND_LONG",
    8: "command only accepted as COMMAND_INT",
    9: "unsupported frame",
}
MAV_LANDED_STATE_ON_GROUND = 1
HEARTBEAT_MISSING_S = 2.5  # telemetry without a HEARTBEAT for this long also counts as a lost link
MAV_LANDED_STATE_LANDING = 4
MAV_SEVERITY_WARNING = 4

# SET_POSITION_TARGET_LOCAL_NED type mask: a set bit means "ignore this field". Velocity + yaw rate only:
# ignore x, y, z (1|2|4), ax, ay, az (64|128|256) and yaw (1024); keep vx, vy, vz (8|16|32) and yaw rate (2048).
TYPE_MASK_VELOCITY_YAW_RATE = 1 | 2 | 4 | 64 | 128 | 256 | 1024

# EKF_STATUS_REPORT (ArduPilot) / ESTIMATOR_STATUS (PX4) flags (same bits up to 512) that make a local position
# usable for flight: attitude (1), horizontal and vertical velocity (2, 4), relative horizontal position (8) and
# vertical position (32). Absolute horizontal position (16) is not required: indoors, with motion capture and no
# GPS, there is none. Disqualifying: constant-position mode (128, the EKF does not know where it is),
# EKF_UNINITIALIZED (1024, ArduPilot) / GPS glitch (1024, PX4), accelerometer error (2048, PX4).
ESTIMATE_FLAGS_REQUIRED = 1 | 2 | 4 | 8 | 32
ESTIMATE_FLAGS_BAD = 128 | 1024 | 2048


def estimate_usable(flags: int) -> bool:
    """Whether EKF_STATUS_REPORT / ESTIMATOR_STATUS ``flags`` describe a position estimate fit to fly on."""
    return flags & ESTIMATE_FLAGS_REQUIRED == ESTIMATE_FLAGS_REQUIRED and not flags & ESTIMATE_FLAGS_BAD


_FLAG_NAMES = {
    1: "attitude",
    2: "horizontal velocity",
    4: "vertical velocity",
    8: "relative horizontal position",
    32: "vertical position",
    128: "constant-position mode",
    1024: "not initialised / GPS glitch",
    2048: "accelerometer error",
}


def describe_estimate_flags(flags: int) -> str:
    """What EKF ``flags`` lack for flight, in words: ``EKF flags 0x0081: missing horizontal velocity, ...``."""
    missing = [name for bit, name in _FLAG_NAMES.items() if bit & ESTIMATE_FLAGS_REQUIRED and not flags & bit]
    bad = [name for bit, name in _FLAG_NAMES.items() if bit & ESTIMATE_FLAGS_BAD and flags & bit]
    parts = []
    if missing:
        parts.append("missing " + ", ".join(missing))
    if bad:
        parts.append(", ".join(bad))
    return f"EKF flags 0x{flags:04x}" + (": " + "; ".join(parts) if parts else ": usable")


# ArduCopter custom modes and PX4 custom modes (main mode << 16 | sub mode << 24).
ARDUPILOT_MODES = {
    "STABILIZE": 0,
    "ALT_HOLD": 2,
    "AUTO": 3,
    "GUIDED": 4,
    "LOITER": 5,
    "RTL": 6,
    "LAND": 9,
    "POSHOLD": 16,
    "BRAKE": 17,
}
PX4_MODES = {
    "MANUAL": 1 << 16,
    "ALTCTL": 2 << 16,
    "POSCTL": 3 << 16,
    "AUTO.LOITER": (4 << 16) | (3 << 24),
    "AUTO.RTL": (4 << 16) | (5 << 24),
    "AUTO.LAND": (4 << 16) | (6 << 24),
    "AUTO.TAKEOFF": (4 << 16) | (2 << 24),
    "OFFBOARD": 6 << 16,
}

#: The modes in which the autopilot lands on its own (``Telemetry.landing``): ArduPilot LAND, PX4 AUTO.LAND.
LANDING_MODES = frozenset({"LAND", "AUTO.LAND"})

# Messages and the rates (Hz) requested with MAV_CMD_SET_MESSAGE_INTERVAL on connect.
MSG_HEARTBEAT = 0
MSG_SYS_STATUS = 1
MSG_ATTITUDE = 30
MSG_LOCAL_POSITION_NED = 32
MSG_EKF_STATUS_REPORT = 193
MSG_ESTIMATOR_STATUS = 230
MSG_EXTENDED_SYS_STATE = 245


def mode_name(autopilot: str, custom_mode: int) -> str:
    """Human name of a custom mode (``"GUIDED"``, ``"OFFBOARD"``), or ``"MODE(<n>)"`` if unknown."""
    table = ARDUPILOT_MODES if autopilot == "ardupilot" else PX4_MODES
    for name, number in table.items():
        if number == custom_mode:
            return name
    if autopilot == "px4":  # PX4 sub mode 0 with an AUTO main mode: compare the main mode only
        for name, number in table.items():
            if (
                number >> 16 & 0xFF == custom_mode >> 16 & 0xFF
                and number >> 24 == 0
                and custom_mode >> 24 == 0
            ):
                return name
    return f"MODE({custom_mode})"
