"""FlightController over MAVLink 2 (pymavlink): ArduPilot GUIDED or PX4 OFFBOARD velocity control.

This module is the only place in masonry where NED appears. masonry's world is ENU (x east, y north, z up) with
its origin at the autopilot's local origin, shifted by a configurable offset and rotated by a configurable yaw
(:class:`FrameTransform`); MAVLink's local frame is NED and its body frame FRD.

Lifecycle (construct, then connect)::

    fc = MavlinkFlightController("udpin:0.0.0.0:14550")
    fc.connect()            # heartbeat, target ids, message rates, background threads
    fc.arm()                # waits for a usable position estimate, GUIDED/OFFBOARD, arm (COMMAND_ACK checked)
    fc.takeoff(1.2)
    fc.send_velocity((0.0, 0.0, -0.2), 0.0)   # streamed at >= 10 Hz by a background sender
    fc.land()
    fc.close()

Every command is checked through COMMAND_ACK: a refusal raises :class:`~masonry.errors.CommandRejected` with the
MAV_RESULT and the autopilot's latest warning text (ArduPilot's "PreArm: ..."), silence raises
:class:`~masonry.errors.CommandTimeout` after the retries, and a silent link raises
:class:`~masonry.errors.LinkLost`.
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from typing_extensions import Self

from masonry.adapters.pose_source import PoseSource
from masonry.errors import CommandRejected, CommandTimeout, DeviceNotFound, InputError, LinkLost
from masonry.ports import Telemetry, Vec3

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


_FLAG_NAMES = {1: "attitude", 2: "horizontal velocity", 4: "vertical velocity", 8: "relative horizontal position",
               32: "vertical position", 128: "constant-position mode", 1024: "not initialised / GPS glitch",
               2048: "accelerometer error"}


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


@dataclass(frozen=True)
class FrameTransform:
    """masonry world ENU <-> autopilot local NED: ``p_world = R_z(yaw_rad) @ enu(p_local) + offset_m``.

    ``offset_m`` is the autopilot's local origin expressed in the world frame, ``yaw_rad`` the rotation of the
    autopilot's local ENU axes (east, north, up from its NED) about world z. The identity (the default) fits a
    motion-capture setup whose poses are fed to the autopilot in the world frame.
    """

    offset_m: Vec3 = (0.0, 0.0, 0.0)
    yaw_rad: float = 0.0

    def _rotate(self, x: float, y: float, angle: float) -> tuple[float, float]:
        c, s = math.cos(angle), math.sin(angle)
        return (c * x - s * y, s * x + c * y)

    def position_to_world(self, p_ned: Vec3) -> Vec3:
        """A local NED position (m) as a world ENU position (m)."""
        east, north, up = p_ned[1], p_ned[0], -p_ned[2]
        x, y = self._rotate(east, north, self.yaw_rad)
        return (x + self.offset_m[0], y + self.offset_m[1], up + self.offset_m[2])

    def position_to_ned(self, p_world: Vec3) -> Vec3:
        """A world ENU position (m) as a local NED position (m)."""
        x, y = self._rotate(p_world[0] - self.offset_m[0], p_world[1] - self.offset_m[1], -self.yaw_rad)
        return (y, x, -(p_world[2] - self.offset_m[2]))

    def velocity_to_world(self, v_ned: Vec3) -> Vec3:
        """A local NED velocity (m/s) as a world ENU velocity (m/s)."""
        x, y = self._rotate(v_ned[1], v_ned[0], self.yaw_rad)
        return (x, y, -v_ned[2])

    def velocity_to_ned(self, v_world: Vec3) -> Vec3:
        """A world ENU velocity (m/s) as a local NED velocity (m/s)."""
        x, y = self._rotate(v_world[0], v_world[1], -self.yaw_rad)
        return (y, x, -v_world[2])

    def attitude_to_world(self, roll_rad: float, pitch_rad: float, yaw_ned_rad: float) -> Vec3:
        """FRD roll/pitch/yaw in NED as FLU roll/pitch and yaw about world +z from world +x."""
        return (roll_rad, -pitch_rad, _wrap(math.pi / 2.0 - yaw_ned_rad + self.yaw_rad))

    def attitude_to_ned(self, roll_rad: float, pitch_rad: float, yaw_world_rad: float) -> Vec3:
        """World FLU roll/pitch/yaw as FRD roll/pitch and yaw in the autopilot's NED frame."""
        return (roll_rad, -pitch_rad, _wrap(math.pi / 2.0 - yaw_world_rad + self.yaw_rad))

    @staticmethod
    def yaw_rate_to_ned(yaw_rate_radps: float) -> float:
        """Yaw rate about +z up (ENU) as yaw rate about +z down (NED)."""
        return -yaw_rate_radps

    @staticmethod
    def yaw_rate_to_world(yaw_rate_ned_radps: float) -> float:
        return -yaw_rate_ned_radps


def _wrap(angle_rad: float) -> float:
    return (angle_rad + math.pi) % (2.0 * math.pi) - math.pi


def load_signing_key(path: str | os.PathLike[str]) -> bytes:
    """Read a MAVLink 2 signing key: 32 raw bytes, 64 hex digits, or a passphrase (SHA-256, as MAVProxy does).

    Raises:
        InputError: the file is missing or empty.
    """
    import hashlib

    p = Path(path)
    try:
        raw = p.read_bytes()
    except OSError as exc:
        raise InputError(f"{p}: cannot read signing key: {exc.strerror or exc}") from exc
    if len(raw) == 32:
        return raw
    text = raw.decode("utf-8", errors="replace").strip()
    if not text:
        raise InputError(f"{p}: signing key file is empty")
    if len(text) == 64 and all(ch in "0123456789abcdefABCDEF" for ch in text):
        return bytes.fromhex(text)
    return hashlib.sha256(text.encode("utf-8")).digest()


def mavutil_module() -> Any:
    """``pymavlink.mavutil`` with the MAVLink 2 dialect loaded (sets MAVLINK20=1 before the first import)."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # imported earlier without MAVLINK20
        mavutil.set_dialect("ardupilotmega")
    return mavutil


class LinkClock:
    """The autopilot's clock (``time_boot_ms``) seen from this computer: a Clock for the state machines.

    ``now_s`` extrapolates the last boot time received at the rate measured between the autopilot's and the
    local monotonic clock (1.0 for real hardware, the time-scale factor for a faster-than-real-time SITL);
    ``sleep`` sleeps the wall time that corresponds to ``duration_s`` of autopilot time.
    """

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._first: tuple[float, float] | None = None  # (boot_s, monotonic_s)
        self._last: tuple[float, float] | None = None
        self._returned = -math.inf
        self._created = time.monotonic()

    def observe(self, boot_s: float, monotonic_s: float) -> None:
        with self._lock:
            if self._last is not None and boot_s < self._last[0] - 1.0:  # autopilot rebooted
                self._first = None
                self._returned = -math.inf
            if self._first is None:
                self._first = (boot_s, monotonic_s)
            self._last = (boot_s, monotonic_s)

    @property
    def rate(self) -> float:
        """Autopilot seconds per local second (1.0 until 0.2 s of samples exist)."""
        with self._lock:
            if self._first is None or self._last is None:
                return 1.0
            dt_local = self._last[1] - self._first[1]
            if dt_local < 0.2:
                return 1.0
            return max(1e-3, (self._last[0] - self._first[0]) / dt_local)

    def now_s(self) -> float:
        rate = self.rate
        with self._lock:
            if self._last is None:  # nothing heard yet: seconds since this clock was made
                return time.monotonic() - self._created
            # extrapolated over one telemetry period at most; never runs backwards
            now = self._last[0] + (time.monotonic() - self._last[1]) * rate
            self._returned = max(self._returned, now)
            return self._returned

    @property
    def anchored(self) -> bool:
        """Whether a time-stamped message from the autopilot has been seen."""
        return self._last is not None

    def sleep(self, duration_s: float) -> None:
        if duration_s > 0.0:
            time.sleep(duration_s / self.rate)


@dataclass
class _State:
    """What the receiver thread has learned (guarded by the controller's lock)."""

    last_message_s: float = -math.inf
    last_heartbeat_s: float = -math.inf
    armed: bool = False
    custom_mode: int = -1
    base_mode: int = 0
    position_ned: Vec3 | None = None
    velocity_ned: Vec3 = (0.0, 0.0, 0.0)
    position_time_s: float = -math.inf
    attitude: Vec3 = (0.0, 0.0, 0.0)  # roll, pitch, yaw (FRD / NED)
    battery_fraction: float = math.nan
    battery_voltage_v: float = math.nan
    estimate_flags: int | None = None
    landed_state: int | None = None
    status_texts: list[tuple[float, int, str]] | None = None


class MavlinkFlightController:
    """The FlightController port over MAVLink 2 for ArduPilot (GUIDED) or PX4 (OFFBOARD).

    Args:
        url: a pymavlink connection string: ``udpin:0.0.0.0:14550``, ``udp:127.0.0.1:14550``,
            ``udpout:192.168.1.10:14550``, ``tcp:127.0.0.1:5760``, ``/dev/ttyACM0`` (with ``baud``).
        baud: serial baud rate (serial URLs only).
        autopilot: ``"auto"`` (from the HEARTBEAT's autopilot field), ``"ardupilot"`` or ``"px4"``.
        heartbeat_timeout_s: the link watchdog; no message from the autopilot for this long (or no HEARTBEAT
            for 2.5 s, autopilots beating at 1 Hz) -> link lost.
        connect_timeout_s: how long :meth:`connect` waits for the first heartbeat.
        command_timeout_s: how long to wait for each COMMAND_ACK (one try).
        command_retries: resends of an unanswered command (MAVLink's ``confirmation`` field counts them).
        estimate_timeout_s: how long :meth:`arm` waits for a usable position estimate.
        setpoint_rate_hz: rate of the background setpoint stream (PX4 leaves OFFBOARD below 2 Hz).
        setpoint_hold_s: a velocity setpoint older than this is replaced by zero (hover) in the stream, so a
            stalled caller cannot leave the UAV flying on its last command.
        frame: world ENU <-> autopilot NED transform (origin offset and yaw).
        signing_key: 32-byte MAVLink 2 signing key (:func:`load_signing_key`), or None for no signing.
        pose_source: motion-capture poses (world frame) forwarded as VISION_POSITION_ESTIMATE.
        vision_rate_hz: forwarding rate for ``pose_source``.
        source_system: our MAVLink system id (255 = ground station convention).
        telemetry_rate_hz: rate requested for LOCAL_POSITION_NED and ATTITUDE.
        land_on_close: :meth:`close` while flying in GUIDED/OFFBOARD commands LAND first (a pilot's mode is left
            alone).
    """

    def __init__(
        self,
        url: str,
        *,
        baud: int = 115200,
        autopilot: Autopilot = "auto",
        heartbeat_timeout_s: float = 1.0,
        connect_timeout_s: float = 10.0,
        command_timeout_s: float = 1.0,
        command_retries: int = 2,
        estimate_timeout_s: float = 15.0,
        takeoff_timeout_s: float = 20.0,
        setpoint_rate_hz: float = 20.0,
        setpoint_hold_s: float = 0.5,
        frame: FrameTransform | None = None,
        signing_key: bytes | None = None,
        pose_source: PoseSource | None = None,
        vision_rate_hz: float = 30.0,
        source_system: int = 255,
        source_component: int = 190,  # MAV_COMP_ID_MISSIONPLANNER
        telemetry_rate_hz: float = 30.0,
        land_on_close: bool = True,
    ) -> None:
        if autopilot not in ("auto", "ardupilot", "px4"):
            raise InputError(f"autopilot must be auto, ardupilot or px4, not {autopilot!r}")
        if setpoint_rate_hz < 10.0:
            raise InputError(f"setpoint rate must be at least 10 Hz, not {setpoint_rate_hz}")
        if signing_key is not None and len(signing_key) != 32:
            raise InputError(f"a MAVLink signing key has 32 bytes, not {len(signing_key)}")
        self.url = url
        self.baud = baud
        self.autopilot_setting: Autopilot = autopilot
        self.autopilot: str | None = None
        self.heartbeat_timeout_s = heartbeat_timeout_s
        self.connect_timeout_s = connect_timeout_s
        self.command_timeout_s = command_timeout_s
        self.command_retries = command_retries
        self.estimate_timeout_s = estimate_timeout_s
        self.takeoff_timeout_s = takeoff_timeout_s
        self.setpoint_rate_hz = setpoint_rate_hz
        self.setpoint_hold_s = setpoint_hold_s
        self.frame = frame or FrameTransform()
        self.signing_key = signing_key
        self.pose_source = pose_source
        self.vision_rate_hz = vision_rate_hz
        self.source_system = source_system
        self.source_component = source_component
        self.telemetry_rate_hz = telemetry_rate_hz
        self.land_on_close = land_on_close
        self.target_system = 0
        self.target_component = 0
        self.clock = LinkClock()
        self.warnings: list[str] = []
        self.setpoints_sent = 0
        self.vision_sent = 0
        self.pose_errors = 0
        self.last_pose_error: str | None = None
        self._conn: Any = None
        self._mavlink: Any = None
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._acks = threading.Condition(self._lock)
        self._ack_log: list[tuple[float, int, int]] = []  # (monotonic_s, command, result)
        self._state = _State(status_texts=[])
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._setpoint: tuple[Vec3, float] | None = None  # NED velocity, NED yaw rate
        self._setpoint_time_s = -math.inf
        self._streaming = False
        self._takeoff_target_m: float | None = None  # world altitude being climbed to
        self._takeoff_started_s = -math.inf
        self._last_vision_stamp: Any = None

    # ----------------------------------------------------------------------------------------------- lifecycle

    def __enter__(self) -> Self:
        self.connect()
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def connected(self) -> bool:
        return self._conn is not None

    @property
    def _heartbeat_missing_s(self) -> float:
        # Autopilots beat at 1 Hz: the watchdog proper counts every message (telemetry streams at 30 Hz); a
        # stream without heartbeats (a confused autopilot, or another component) counts as lost after 2.5 beats.
        return max(self.heartbeat_timeout_s, HEARTBEAT_MISSING_S)

    def connect(self) -> None:
        """Open the link, wait for the autopilot's heartbeat, request message rates, start the threads.

        Raises:
            DeviceNotFound: the endpoint cannot be opened or no autopilot heartbeat arrives in time.
        """
        if self._conn is not None:
            return
        mavutil = mavutil_module()
        self._mavlink = mavutil.mavlink
        try:
            conn = mavutil.mavlink_connection(
                self.url,
                baud=self.baud,
                source_system=self.source_system,
                source_component=self.source_component,
                autoreconnect=False,
            )
        except (OSError, ValueError) as exc:
            raise DeviceNotFound(f"cannot open MAVLink endpoint {self.url}: {exc}") from exc
        if self.signing_key is not None:
            conn.setup_signing(self.signing_key, sign_outgoing=True, allow_unsigned_callback=None)
        self._conn = conn
        self._stop.clear()
        try:
            self._await_first_heartbeat()
        except BaseException:
            self._conn = None
            conn.close()
            raise
        receiver = threading.Thread(target=self._receive_loop, name="mavlink-rx", daemon=True)
        sender = threading.Thread(target=self._send_loop, name="mavlink-tx", daemon=True)
        self._threads = [receiver, sender]
        for thread in self._threads:
            thread.start()
        self._request_rates()
        deadline = time.monotonic() + self.connect_timeout_s
        while not self.clock.anchored and time.monotonic() < deadline:  # the machines run on this clock
            self._stop.wait(0.01)
        if not self.clock.anchored:
            self.warnings.append("no time-stamped telemetry (ATTITUDE / LOCAL_POSITION_NED) after connecting")

    def close(self) -> None:
        """Stop the threads and close the link; still flying in GUIDED/OFFBOARD, command LAND first (``land_on_close``).

        A program interrupted in flight (Ctrl-C, an exception) so lands the UAV where it is instead of leaving it
        to the guided timeout and the link-loss failsafe.
        """
        if self.land_on_close and self._conn is not None and self._threads:
            tel = self.telemetry()
            # only while masonry flies it (GUIDED/OFFBOARD): a pilot's mode is the pilot's
            flying_ours = tel.mode == self.offboard_mode or self._takeoff_target_m is not None
            if tel.link_ok and tel.armed and not tel.on_ground and not tel.landing and flying_ours:
                try:
                    self.land()
                except (CommandRejected, CommandTimeout, LinkLost):
                    pass  # the autopilot's failsafes remain
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._threads = []
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def _await_first_heartbeat(self) -> None:
        deadline = time.monotonic() + self.connect_timeout_s
        next_beat = 0.0
        while time.monotonic() < deadline:
            now = time.monotonic()
            if now >= next_beat:  # a udpout/udpin peer learns our address from our first packet
                self._send_heartbeat()
                next_beat = now + 0.25
            msg = self._conn.recv_match(blocking=True, timeout=0.05)
            if msg is None or msg.get_type() != "HEARTBEAT":
                continue
            if msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
                continue  # another ground station, not an autopilot
            self.target_system = msg.get_srcSystem()
            self.target_component = msg.get_srcComponent()
            if self.autopilot_setting == "auto":
                self.autopilot = "px4" if msg.autopilot == MAV_AUTOPILOT_PX4 else "ardupilot"
            else:
                self.autopilot = self.autopilot_setting
            self._handle(msg, time.monotonic())
            return
        hint = " (is the signing key the same on both ends?)" if self.signing_key is not None else ""
        raise DeviceNotFound(
            f"no autopilot heartbeat on {self.url} within {self.connect_timeout_s:.1f} s{hint}"
        )

    def _request_rates(self) -> None:
        rates = {
            MSG_LOCAL_POSITION_NED: self.telemetry_rate_hz,
            MSG_ATTITUDE: self.telemetry_rate_hz,
            MSG_SYS_STATUS: 2.0,
            MSG_EXTENDED_SYS_STATE: 10.0,
            MSG_EKF_STATUS_REPORT if self.autopilot == "ardupilot" else MSG_ESTIMATOR_STATUS: 5.0,
        }
        sent_at = time.monotonic()
        for msg_id, rate_hz in rates.items():
            self._send_command(MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 1e6 / rate_hz, 0, 0, 0, 0, 0), 0)
        deadline = sent_at + self.command_timeout_s
        with self._acks:
            while time.monotonic() < deadline:
                answered = [
                    a for a in self._ack_log if a[0] >= sent_at and a[1] == MAV_CMD_SET_MESSAGE_INTERVAL
                ]
                if len(answered) >= len(rates):
                    break
                self._acks.wait(timeout=max(0.0, deadline - time.monotonic()))
            answered = [a for a in self._ack_log if a[0] >= sent_at and a[1] == MAV_CMD_SET_MESSAGE_INTERVAL]
        refused = [a for a in answered if a[2] != MAV_RESULT_ACCEPTED]
        if len(answered) < len(rates) or refused:
            self.warnings.append(
                f"message rates: {len(answered) - len(refused)} of {len(rates)} SET_MESSAGE_INTERVAL accepted; "
                "telemetry may come at the autopilot's default stream rates"
            )

    # ---------------------------------------------------------------------------------------------- threads

    def _receive_loop(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self._conn.recv_match(blocking=True, timeout=0.05)
            except (OSError, ValueError, AttributeError):
                if self._stop.is_set():
                    return
                time.sleep(0.05)
                continue
            if msg is not None:
                try:
                    self._handle(msg, time.monotonic())
                except (AttributeError, TypeError, ValueError):
                    pass  # a message without the fields we expect (another dialect): ignore it, keep listening

    def _handle(self, msg: Any, now: float) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA" or msg.get_srcSystem() != self.target_system:
            return
        with self._lock:
            st = self._state
            st.last_message_s = now
            if kind == "HEARTBEAT":
                if msg.get_srcComponent() != self.target_component:
                    return
                st.last_heartbeat_s = now
                st.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
                st.base_mode = msg.base_mode
                st.custom_mode = msg.custom_mode
            elif kind == "LOCAL_POSITION_NED":
                st.position_ned = (msg.x, msg.y, msg.z)
                st.velocity_ned = (msg.vx, msg.vy, msg.vz)
                st.position_time_s = now
                self.clock.observe(msg.time_boot_ms / 1000.0, now)
            elif kind == "ATTITUDE":
                st.attitude = (msg.roll, msg.pitch, msg.yaw)
                self.clock.observe(msg.time_boot_ms / 1000.0, now)
            elif kind == "SYS_STATUS":
                st.battery_fraction = math.nan if msg.battery_remaining < 0 else msg.battery_remaining / 100.0
                st.battery_voltage_v = (
                    msg.voltage_battery / 1000.0 if msg.voltage_battery != 65535 else math.nan
                )
            elif kind in ("EKF_STATUS_REPORT", "ESTIMATOR_STATUS"):
                st.estimate_flags = int(msg.flags)
            elif kind == "EXTENDED_SYS_STATE":
                st.landed_state = int(msg.landed_state)
            elif kind == "STATUSTEXT":
                assert st.status_texts is not None
                st.status_texts.append((now, int(msg.severity), str(msg.text)))
                del st.status_texts[:-20]
            elif kind == "COMMAND_ACK":
                self._ack_log.append((now, int(msg.command), int(msg.result)))
                del self._ack_log[:-64]
                self._acks.notify_all()

    def _send_loop(self) -> None:
        period = 1.0 / self.setpoint_rate_hz
        vision_period = 1.0 / self.vision_rate_hz
        next_setpoint = next_beat = next_vision = time.monotonic()
        while not self._stop.is_set():
            now = time.monotonic()
            try:
                if now >= next_beat:
                    self._send_heartbeat()
                    next_beat = now + 1.0
                if now >= next_setpoint:
                    self._stream_setpoint(now)
                    next_setpoint += period
                    if next_setpoint < now:  # fell behind (suspended?): don't burst
                        next_setpoint = now + period
                if self.pose_source is not None and now >= next_vision:
                    next_vision = now + vision_period
                    try:
                        self._forward_pose()
                    except Exception as exc:  # noqa: BLE001 - a bad pose must not stop the setpoint stream
                        self.pose_errors += 1
                        self.last_pose_error = f"{type(exc).__name__}: {exc}"
            except (OSError, ValueError, AttributeError):
                if self._stop.is_set():
                    return
            wake = min(next_setpoint, next_beat, next_vision if self.pose_source is not None else next_beat)
            self._stop.wait(max(0.0, wake - time.monotonic()))

    def _stream_setpoint(self, now: float) -> None:
        with self._lock:
            streaming = self._streaming and self._state.armed
            setpoint = self._setpoint
            fresh = now - self._setpoint_time_s <= self.setpoint_hold_s
            takeoff_target = self._takeoff_target_m
            position = self._state.position_ned
        if not streaming:
            return
        if takeoff_target is not None:
            world_alt = self.frame.position_to_world(position)[2] if position is not None else 0.0
            with self._lock:
                climb_rate = -self._state.velocity_ned[2]
            reached = world_alt >= takeoff_target - 0.1 and abs(climb_rate) < 0.1
            if reached or time.monotonic() - self._takeoff_started_s > self.takeoff_timeout_s:
                with self._lock:
                    self._takeoff_target_m = None
            elif self.autopilot == "px4":
                # PX4 has no GUIDED-style takeoff inside OFFBOARD: climb with a P law (0.5 m/s max).
                climb = min(0.5, max(0.0, 1.0 * (takeoff_target - world_alt)))
                self._send_position_target((0.0, 0.0, -climb), 0.0)
                return
            else:
                return  # ArduPilot climbs on its own; a velocity target would abort its takeoff
        if setpoint is None or not fresh:
            self._send_position_target((0.0, 0.0, 0.0), 0.0)
        else:
            self._send_position_target(setpoint[0], setpoint[1])

    def _send_position_target(self, v_ned: Vec3, yaw_rate_ned: float) -> None:
        with self._send_lock:
            self._conn.mav.set_position_target_local_ned_send(
                int(time.monotonic() * 1000) & 0xFFFFFFFF,
                self.target_system,
                self.target_component,
                MAV_FRAME_LOCAL_NED,
                TYPE_MASK_VELOCITY_YAW_RATE,
                0.0, 0.0, 0.0,
                float(v_ned[0]), float(v_ned[1]), float(v_ned[2]),
                0.0, 0.0, 0.0,
                0.0, float(yaw_rate_ned),
            )  # fmt: skip
        self.setpoints_sent += 1

    def _send_heartbeat(self) -> None:
        with self._send_lock:
            self._conn.mav.heartbeat_send(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 4)  # MAV_STATE_ACTIVE

    def _forward_pose(self) -> None:
        assert self.pose_source is not None
        pose = self.pose_source.latest()
        if pose is None or pose is self._last_vision_stamp:
            return
        self._last_vision_stamp = pose
        x, y, z = self.frame.position_to_ned(tuple(pose.position_m))  # type: ignore[arg-type]
        roll, pitch, yaw = self.frame.attitude_to_ned(*pose.attitude_rad)
        with self._send_lock:
            self._conn.mav.vision_position_estimate_send(
                int(pose.time_s * 1e6) & 0xFFFFFFFFFFFFFFFF, x, y, z, roll, pitch, yaw
            )
        self.vision_sent += 1

    # ---------------------------------------------------------------------------------------------- commands

    def _send_command(self, command: int, params: tuple[float, ...], confirmation: int) -> None:
        with self._send_lock:
            self._conn.mav.command_long_send(
                self.target_system, self.target_component, command, confirmation, *map(float, params)
            )

    def _check_link(self, what: str) -> None:
        if self._conn is None:
            raise LinkLost(f"{what}: not connected to {self.url} (call connect() first)")
        now = time.monotonic()
        silent_s = now - self._state.last_message_s
        if silent_s > self.heartbeat_timeout_s:
            raise LinkLost(f"{what}: no message from the autopilot on {self.url} for {silent_s:.1f} s")
        beatless_s = now - self._state.last_heartbeat_s
        if beatless_s > self._heartbeat_missing_s:
            raise LinkLost(f"{what}: no HEARTBEAT from the autopilot on {self.url} for {beatless_s:.1f} s")

    def _latest_warning(self, since: float) -> str | None:
        with self._lock:
            texts = [
                t for t in (self._state.status_texts or []) if t[0] >= since and t[1] <= MAV_SEVERITY_WARNING
            ]
        return texts[-1][2] if texts else None

    def command(self, name: str, command: int, params: tuple[float, ...] = ()) -> None:
        """Send COMMAND_LONG ``command`` and wait for its COMMAND_ACK.

        Raises:
            CommandRejected: the autopilot answered with anything but ACCEPTED (reason: result and warning).
            CommandTimeout: no answer after ``command_retries`` resends.
            LinkLost: the link watchdog has fired.
        """
        self._check_link(name)
        params = tuple(params) + (0.0,) * (7 - len(params))
        started = time.monotonic()
        for attempt in range(self.command_retries + 1):
            sent_at = time.monotonic()
            self._send_command(command, params, attempt)
            result = self._wait_ack(command, sent_at, sent_at + self.command_timeout_s)
            if result is None:
                continue
            if result == MAV_RESULT_ACCEPTED:
                return
            reason = MAV_RESULT_NAMES.get(result, f"result {result}")
            warning = self._latest_warning(started - 0.5)
            raise CommandRejected(name, f"{reason}: {warning}" if warning else reason)
        self._check_link(name)
        raise CommandTimeout(
            f"{name}: no COMMAND_ACK from the autopilot on {self.url} after {self.command_retries + 1} tries "
            f"of {self.command_timeout_s:.1f} s"
        )

    def _wait_ack(self, command: int, since: float, deadline: float) -> int | None:
        with self._acks:
            while True:
                for t, cmd, result in reversed(self._ack_log):
                    if t >= since and cmd == command and result != MAV_RESULT_IN_PROGRESS:
                        return result
                remaining = deadline - time.monotonic()
                if remaining <= 0.0:
                    return None
                in_progress = any(t >= since and c == command for t, c, _ in self._ack_log)
                if in_progress:  # IN_PROGRESS extends the wait (ArduPilot: long calibrations; harmless here)
                    deadline = max(deadline, time.monotonic() + self.command_timeout_s)
                self._acks.wait(timeout=min(remaining, 0.1))

    def set_mode(self, mode: str) -> None:
        """Switch the autopilot to ``mode`` (a name of :data:`ARDUPILOT_MODES` or :data:`PX4_MODES`)."""
        table = ARDUPILOT_MODES if self.autopilot == "ardupilot" else PX4_MODES
        if mode not in table:
            raise InputError(f"unknown {self.autopilot} mode {mode!r}; known: {', '.join(table)}")
        custom = table[mode]
        if self.autopilot == "px4":
            main, sub = custom >> 16 & 0xFF, custom >> 24 & 0xFF
            params: tuple[float, ...] = (MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, main, sub)
        else:
            params = (MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom)
        self.command(f"set mode {mode}", MAV_CMD_DO_SET_MODE, params)
        with self._lock:
            self._state.custom_mode = custom  # the ACK said so; the next HEARTBEAT confirms

    @property
    def offboard_mode(self) -> str:
        """The mode velocity setpoints are flown in: GUIDED (ArduPilot) or OFFBOARD (PX4)."""
        return "OFFBOARD" if self.autopilot == "px4" else "GUIDED"

    def estimate_status(self) -> str:
        """What the estimate lacks now, in words: no local position yet, or what the EKF flags miss."""
        now = time.monotonic()
        with self._lock:
            st = self._state
            flags = st.estimate_flags
            streaming = st.position_ned is not None and now - st.position_time_s <= max(0.5, self.heartbeat_timeout_s)
        if flags is not None and not estimate_usable(flags):
            return ("no local position yet, " if not streaming else "local position streaming, ") + \
                describe_estimate_flags(flags)
        if not streaming:
            return "no local position yet (LOCAL_POSITION_NED not streaming)" + \
                ("" if flags is None else f", {describe_estimate_flags(flags)}")
        return "usable" if flags is None else describe_estimate_flags(flags)

    def wait_for_estimate(self, timeout_s: float | None = None, *, progress: Callable[[str], None] | None = None,
                          report_every_s: float = 5.0) -> None:
        """Block until the autopilot reports a usable local position estimate.

        ArduCopter SITL streams LOCAL_POSITION_NED about 19 s after its first client connects and its EKF is
        usable at about 40 s (docs/hardware.md), so a pre-flight check waits that long with a countdown.

        Args:
            progress: called with one line (what is missing, the seconds left) when that changes and every
                ``report_every_s``; e.g. the pre-flight check's echo to stderr.

        Raises:
            CommandRejected: no usable estimate within ``timeout_s`` (default ``estimate_timeout_s``), naming
                what was missing at the end.
            LinkLost: the link went silent meanwhile.
        """
        timeout_s = self.estimate_timeout_s if timeout_s is None else timeout_s
        start = time.monotonic()
        deadline = start + timeout_s
        last_status, last_report = "", start
        while True:
            self._check_link("wait for position estimate")
            now = time.monotonic()
            if self._position_ok(now):
                return
            status = self.estimate_status()
            if now >= deadline:
                hint = ("is motion capture feeding the EKF?" if self.pose_source is not None else
                        "an ArduPilot SITL needs about 40 s after its first connection, a cold Pixhawk about as "
                        "long: give more with --estimate-wait; indoors, is the position source feeding the EKF?")
                raise CommandRejected(
                    "arm", f"no usable position estimate from the autopilot after {timeout_s:.1f} s: {status} ({hint})"
                )
            if progress is not None and (status != last_status or now - last_report >= report_every_s):
                progress(f"waiting for the position estimate: {status} ({max(0.0, deadline - now):.0f} s left)")
                last_status, last_report = status, now
            self._stop.wait(0.02)

    def arm(self) -> None:
        """Wait for a usable position estimate, enter GUIDED/OFFBOARD, arm; each step checked by COMMAND_ACK."""
        self._check_link("arm")
        self.wait_for_estimate()
        with self._lock:
            self._setpoint = None
            self._streaming = True  # PX4 needs a setpoint stream before it accepts OFFBOARD
        if self.autopilot == "px4":
            self._stream_zero_before_offboard()
        self.set_mode(self.offboard_mode)
        self.command("arm", MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        with self._lock:
            self._state.armed = True  # the ACK said so; the next HEARTBEAT confirms

    def _stream_zero_before_offboard(self) -> None:
        for _ in range(5):
            self._send_position_target((0.0, 0.0, 0.0), 0.0)
            self._stop.wait(0.05)

    def disarm(self) -> None:
        """Disarm (the autopilot refuses while flying: CommandRejected)."""
        self.command("disarm", MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
        with self._lock:
            self._state.armed = False
            self._streaming = False
            self._setpoint = None

    def takeoff(self, altitude_m: float) -> None:
        """Climb ``altitude_m`` above where the UAV stands (the port's convention); setpoints wait until then.

        ArduPilot: MAV_CMD_NAV_TAKEOFF in GUIDED. PX4: a climb inside OFFBOARD by the setpoint stream.
        """
        self._check_link("takeoff")
        if not (math.isfinite(altitude_m) and altitude_m > 0.0):
            raise CommandRejected("takeoff", f"altitude must be > 0 m, got {altitude_m!r}")
        with self._lock:
            position = self._state.position_ned
            armed = self._state.armed
        if not armed:  # the autopilot would refuse too, with a less direct reason (ArduPilot: mode first)
            raise CommandRejected("takeoff", "not armed (arm first)")
        ground_world = self.frame.position_to_world(position) if position is not None else self.frame.offset_m
        if self.autopilot == "ardupilot":
            self.command("takeoff", MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, altitude_m))
        with self._lock:
            self._setpoint = None
            self._streaming = True
            self._takeoff_target_m = ground_world[2] + altitude_m
            self._takeoff_started_s = time.monotonic()

    def land(self) -> None:
        """Land where the UAV is (ArduPilot LAND mode; PX4 MAV_CMD_NAV_LAND); the setpoint stream stops."""
        self._check_link("land")
        with self._lock:
            self._streaming = False
            self._setpoint = None
            self._takeoff_target_m = None
        if self.autopilot == "ardupilot":
            self.set_mode("LAND")
        else:
            self.command("land", MAV_CMD_NAV_LAND, (0, 0, 0, math.nan, math.nan, math.nan, math.nan))

    def send_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float) -> None:
        """Set the velocity (world ENU, m/s) and yaw rate (rad/s, about +z up) the stream flies.

        Raises:
            LinkLost: the link watchdog has fired (the autopilot's own timeout stops the UAV).
        """
        self._check_link("velocity setpoint")
        v = self.frame.velocity_to_ned(tuple(float(c) for c in velocity_mps))  # type: ignore[arg-type]
        if not all(math.isfinite(c) for c in v) or not math.isfinite(yaw_rate_radps):
            raise InputError(f"velocity setpoint must be finite, not {velocity_mps}, {yaw_rate_radps}")
        with self._lock:
            self._setpoint = (v, FrameTransform.yaw_rate_to_ned(float(yaw_rate_radps)))
            self._setpoint_time_s = time.monotonic()
            if not self._state.armed:
                return
            self._streaming = True
            send_now = self._takeoff_target_m is None
        if send_now:  # the stream repeats it; sending now removes up to one period of latency
            self._send_position_target(v, FrameTransform.yaw_rate_to_ned(float(yaw_rate_radps)))

    # --------------------------------------------------------------------------------------------- telemetry

    def _position_ok(self, now: float) -> bool:
        st = self._state
        if st.position_ned is None or now - st.position_time_s > max(0.5, self.heartbeat_timeout_s):
            return False
        if (
            st.estimate_flags is None
        ):  # no estimator report (yet): a streaming LOCAL_POSITION_NED is the signal
            return True
        return estimate_usable(st.estimate_flags)

    def telemetry(self) -> Telemetry:
        """The latest state in the world frame (never blocks; ``link_ok`` False once the watchdog fired)."""
        now = time.monotonic()
        with self._lock:
            st = self._state
            link_ok = (
                self._conn is not None
                and now - st.last_message_s <= self.heartbeat_timeout_s
                and now - st.last_heartbeat_s <= self._heartbeat_missing_s
            )
            position_ok = link_ok and self._position_ok(now)
            p_ned = st.position_ned or (0.0, 0.0, 0.0)
            position = (
                self.frame.position_to_world(p_ned) if st.position_ned is not None else self.frame.offset_m
            )
            velocity = self.frame.velocity_to_world(st.velocity_ned)
            attitude = self.frame.attitude_to_world(*st.attitude)
            if st.landed_state is not None and st.landed_state != 0:
                # disarmed after LANDING is down even if the next EXTENDED_SYS_STATE has not come yet; disarmed
                # IN_AIR / TAKEOFF is a motor stop in flight: falling, not landed
                on_ground = st.landed_state == MAV_LANDED_STATE_ON_GROUND or (
                    not st.armed and st.landed_state == MAV_LANDED_STATE_LANDING
                )
            else:
                on_ground = not st.armed or -p_ned[2] < 0.05
            mode = (
                mode_name(self.autopilot or "ardupilot", st.custom_mode) if st.custom_mode >= 0 else "UNKNOWN"
            )
            return Telemetry(
                time_s=self.clock.now_s(),
                position_m=position,
                velocity_mps=velocity,
                attitude_rad=attitude,
                armed=st.armed,
                mode=mode,
                battery_fraction=st.battery_fraction,
                link_ok=link_ok,
                position_ok=position_ok,
                on_ground=on_ground,
                landing=mode in LANDING_MODES or st.landed_state == MAV_LANDED_STATE_LANDING,
            )

    @property
    def battery_voltage_v(self) -> float:
        return self._state.battery_voltage_v

    def status_texts(self) -> list[str]:
        """The autopilot's recent STATUSTEXT messages, oldest first."""
        with self._lock:
            return [t[2] for t in self._state.status_texts or []]
