"""MAVLink numbers, autopilot modes and estimate flags (from common.xml / ardupilotmega.xml): pure values.

Spelled out here so the adapter imports pymavlink only when a connection is opened.
"""

from __future__ import annotations

from typing import Literal

from masonry.adapters.estimator_status import ARDUPILOT_EKF, PX4_EKF2, describe_flags, flags_usable

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
MAV_RESULT_TEMPORARILY_REJECTED = 1  # PX4: every failed arming check (its first seconds among them)
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
# Acceleration + yaw rate (issue 29: masonry's own velocity loop, masonry.motion.velocity_loop): ignore x, y, z,
# vx, vy, vz (8|16|32) and yaw; PX4 then leaves its position and velocity loops out and tilts for the acceleration.
TYPE_MASK_ACCELERATION_YAW_RATE = 1 | 2 | 4 | 8 | 16 | 32 | 1024
# Our velocity loop falls back to the autopilot's when the position it closes on is older than this (s).
VELOCITY_LOOP_STALE_S = 0.5

# EKF_STATUS_REPORT (ArduPilot) / ESTIMATOR_STATUS (PX4) flags: what each autopilot's bits mean, and which make
# a local position usable for flight, is :mod:`masonry.adapters.estimator_status` (issue 20: PX4's EKF2 sets
# constant-position mode whenever the vehicle is at rest). These two are the flags every autopilot needs, and
# every bit that disqualifies for one of them (ArduPilot or PX4) in flight.
ESTIMATE_FLAGS_REQUIRED = ARDUPILOT_EKF.required
ESTIMATE_FLAGS_BAD = ARDUPILOT_EKF.bad | PX4_EKF2.bad | PX4_EKF2.bad_in_flight


def estimate_usable(flags: int, autopilot: str | None = "ardupilot", *, on_ground: bool = True) -> bool:
    """Whether ``autopilot``'s EKF_STATUS_REPORT / ESTIMATOR_STATUS ``flags`` describe a position fit to fly on."""
    return flags_usable(flags, autopilot, on_ground=on_ground)


def describe_estimate_flags(
    flags: int, autopilot: str | None = "ardupilot", *, on_ground: bool = True
) -> str:
    """What ``flags`` lack for flight, in words: ``EKF flags 0x0081: missing horizontal velocity, ...``."""
    return describe_flags(flags, autopilot, on_ground=on_ground)


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
MSG_WIND = 168  # ardupilotmega's WIND: the EKF's wind estimate (direction it blows from, speed)


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
