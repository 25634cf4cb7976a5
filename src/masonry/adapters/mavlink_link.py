"""The MAVLink 2 link under :class:`~masonry.adapters.mavlink.MavlinkFlightController`: connection, threads, acks.

:class:`MavlinkLink` opens the pymavlink connection (optionally signed), waits for the autopilot's heartbeat,
requests message rates, and runs two threads: the receiver records what the autopilot says (:class:`_State`,
raw MAVLink fields: the NED frame conversion lives in :mod:`masonry.adapters.mavlink` only) and the sender
beats our heartbeat and streams whatever the flight controller above wants streamed. ``command`` sends a
COMMAND_LONG and checks its COMMAND_ACK (a refusal marked ``temporary`` when the autopilot says so). Nothing the
threads meet is silent: a message the receiver cannot handle, a failed receive and a failed send are each
counted and logged (:meth:`MavlinkLink.status`), and the threads keep going.
"""

from __future__ import annotations

import logging
import math
import os
import queue
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any

from typing_extensions import Self

from masonry.adapters.link_silence import RECEIVER_HUNG_S, beatless_s, watchdog_text
from masonry.adapters.link_values import LinkClock, LinkStatus, StatusText, add_status_text, load_signing_key
from masonry.adapters.mavlink_protocol import (
    HEARTBEAT_MISSING_S,
    MAV_AUTOPILOT_INVALID,
    MAV_AUTOPILOT_PX4,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_LOCAL_NED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_IN_PROGRESS,
    MAV_RESULT_NAMES,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_SEVERITY_WARNING,
    MAV_TYPE_GCS,
    MSG_ATTITUDE,
    MSG_EKF_STATUS_REPORT,
    MSG_ESTIMATOR_STATUS,
    MSG_EXTENDED_SYS_STATE,
    MSG_LOCAL_POSITION_NED,
    MSG_SYS_STATUS,
    MSG_WIND,
    TYPE_MASK_ACCELERATION_YAW_RATE,
    TYPE_MASK_VELOCITY_YAW_RATE,
    VELOCITY_LOOP_STALE_S,
    Autopilot,
)
from masonry.adapters.pose_source import PoseSource
from masonry.adapters.sitl_standstill import Standstill
from masonry.errors import CommandRejected, CommandTimeout, DeviceNotFound, InputError, LinkLost
from masonry.motion.velocity_loop import VelocityLoop, tilt_acceleration_mps2
from masonry.ports import Vec3

# Re-exported: callers import these from here (the clock, the counters and the key reader live in link_values).
__all__ = ["RECEIVER_HUNG_S", "LinkClock", "LinkStatus", "MavlinkLink", "load_signing_key", "mavutil_module"]

_log = logging.getLogger(__name__)


def mavutil_module() -> Any:
    """``pymavlink.mavutil`` with the MAVLink 2 dialect loaded (sets MAVLINK20=1 before the first import)."""
    os.environ["MAVLINK20"] = "1"
    from pymavlink import mavutil

    if mavutil.mavlink.WIRE_PROTOCOL_VERSION != "2.0":  # imported earlier without MAVLINK20
        mavutil.set_dialect("ardupilotmega")
    return mavutil


@dataclass
class _State:
    """What the receiver thread has learned (guarded by the controller's lock)."""

    last_message_s: float = -math.inf
    last_heartbeat_s: float = -math.inf
    heartbeat_boot_s: float | None = None  # the autopilot's clock at the last HEARTBEAT (link_silence)
    listened_s: float = -math.inf  # when the receiver last began a read that found nothing (the link quiet)
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
    wind_speed_mps: float | None = None  # the latest WIND message's speed (ArduPilot), and when it came
    wind_time_s: float = -math.inf
    status_texts: list[StatusText] | None = None
    # the latest local heights (up, m) reported while disarmed: the ground as the EKF sees it (issue 20)
    ground_heights: deque[float] = field(default_factory=lambda: deque(maxlen=15))


def _sensed(st: _State, kind: str, msg: Any, now: float) -> None:
    """A SYS_STATUS (the battery) or a WIND (ArduPilot's wind estimate) into the receiver's state."""
    if kind == "SYS_STATUS":
        st.battery_fraction = math.nan if msg.battery_remaining < 0 else msg.battery_remaining / 100.0
        st.battery_voltage_v = msg.voltage_battery / 1000.0 if msg.voltage_battery != 65535 else math.nan
        return
    speed = float(msg.speed)
    if math.isfinite(speed) and speed >= 0.0:
        st.wind_speed_mps, st.wind_time_s = speed, now


#: Log the first few errors of a kind, then every this-many-th (a 30 Hz stream of bad messages must not flood).
_LOG_EVERY = 100


class MavlinkLink:
    """A MAVLink 2 connection to one autopilot: heartbeat both ways, message rates, receiver and sender threads.

    Args: as :class:`~masonry.adapters.mavlink.MavlinkFlightController` (which adds the commands and the frame).
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
        setpoint_rate_hz: float = 20.0,
        signing_key: bytes | None = None,
        pose_source: PoseSource | None = None,
        vision_rate_hz: float = 30.0,
        source_system: int = 255,
        source_component: int = 190,  # MAV_COMP_ID_MISSIONPLANNER
        telemetry_rate_hz: float = 30.0,
        monotonic: Callable[[], float] = time.monotonic,
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
        self.setpoint_rate_hz = setpoint_rate_hz
        self.signing_key = signing_key
        self.pose_source = pose_source
        self.vision_rate_hz = vision_rate_hz
        self.source_system = source_system
        self.source_component = source_component
        self.telemetry_rate_hz = telemetry_rate_hz
        self.target_system = 0
        self.target_component = 0
        self._monotonic = monotonic
        self.clock = LinkClock(monotonic, hold_s=heartbeat_timeout_s)  # held while the link watchdog waits
        self.standstill = Standstill(url)  # a SITL on this computer left unrun: not its silence (issue 29)
        self._down_at: tuple[float, float | None] | None = None  # the watchdog fired: (when, clocks)
        # lock-step (masonry.adapters.lockstep): the stream's clock, until when (monotonic) grants stream it, and
        # the age (s) of the position the velocity loop closes on (on the wall here; on the autopilot's time there)
        self.stream_clock: Callable[[], float] = monotonic
        self.stream_paced_until_s = -math.inf
        self.position_age_s: Callable[[], float] = lambda: self._monotonic() - self._state.position_time_s
        self.warnings: list[str] = []
        self.setpoints_sent = 0
        self.vision_sent = 0
        self.pose_errors = 0
        self.last_pose_error: str | None = None
        self.handler_errors = 0
        self.receive_errors = 0
        self.send_errors = 0
        self.last_error: str | None = None
        self._conn: Any = None
        self._mavlink: Any = None
        self._lock = threading.Lock()
        self._send_lock = threading.Lock()
        self._acks = threading.Condition(self._lock)
        self._ack_log: list[tuple[float, int, int]] = []  # (monotonic_s, command, result)
        self._state = _State(status_texts=[])
        #: close the velocity loop here, on the reported position, sending acceleration setpoints while
        #: :attr:`velocity_loop_engaged` (issue 29: PX4's loop closes on EKF2's velocity); None: on PX4 only
        self.own_velocity_loop: bool | None = None
        self.velocity_observer_input = "command"  # its observer's input: the "command" sent, or the "tilt"
        self.velocity_loop: VelocityLoop | None = None
        self.velocity_loop_engaged = False
        self._stop = threading.Event()
        self._threads: list[threading.Thread] = []
        self._listeners: list[tuple[frozenset[str], queue.Queue[Any]]] = []

    def listen(self, kinds: Iterable[str]) -> queue.Queue[Any]:
        """A queue that gets every message of these types from the autopilot from now on (a protocol run outside
        the receiver's state, e.g. the fence upload: :mod:`masonry.adapters.mavlink_fence`); :meth:`unlisten`."""
        q: queue.Queue[Any] = queue.Queue()
        with self._lock:
            self._listeners = [*self._listeners, (frozenset(kinds), q)]
        return q

    def unlisten(self, q: queue.Queue[Any]) -> None:
        """Stop feeding a :meth:`listen` queue."""
        with self._lock:
            self._listeners = [(k, other) for k, other in self._listeners if other is not q]

    def send_message(self, build: Callable[[Any], None]) -> None:
        """Send what ``build(mav)`` sends on the connection's ``mav`` (under the send lock)."""
        if self._conn is None:
            raise LinkLost(f"not connected to {self.url} (call connect() first)")
        with self._send_lock:
            build(self._conn.mav)

    def status(self) -> LinkStatus:
        """The link's counters now: what was sent, and every error the threads met (none are dropped)."""
        return LinkStatus(
            connected=self._conn is not None,
            autopilot=self.autopilot,
            setpoints_sent=self.setpoints_sent,
            vision_sent=self.vision_sent,
            handler_errors=self.handler_errors,
            receive_errors=self.receive_errors,
            send_errors=self.send_errors,
            pose_errors=self.pose_errors,
            last_error=self.last_error,
        )

    def _count_error(self, kind: str, count: int, exc: BaseException) -> None:
        """Record one error of ``kind`` (its new ``count``) and log it (the first three, then every 100th)."""
        self.last_error = f"{kind}: {type(exc).__name__}: {exc}"
        if count <= 3 or count % _LOG_EVERY == 0:
            _log.warning(
                "MAVLink %s on %s (%d so far): %s: %s", kind, self.url, count, type(exc).__name__, exc
            )

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
        deadline = self._monotonic() + self.connect_timeout_s
        while not self.clock.anchored and self._monotonic() < deadline:  # the machines run on this clock
            self._stop.wait(0.01)
        if not self.clock.anchored:
            self.warnings.append("no time-stamped telemetry (ATTITUDE / LOCAL_POSITION_NED) after connecting")

    def close(self) -> None:
        """Stop the threads and close the connection."""
        self._stop.set()
        for thread in self._threads:
            thread.join(timeout=2.0)
        self._threads = []
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def _await_first_heartbeat(self) -> None:
        deadline = self._monotonic() + self.connect_timeout_s
        next_beat, texts = 0.0, list[tuple[object, float]]()  # texts: heard before the heartbeat (issue 29)
        while self._monotonic() < deadline:
            now = self._monotonic()
            if now >= next_beat:  # a udpout/udpin peer learns our address from our first packet
                self._send_heartbeat()
                next_beat = now + 0.25
            msg = self._conn.recv_match(blocking=True, timeout=0.05)
            if msg is None or msg.get_type() != "HEARTBEAT":  # a lock-step SITL's announcement may come first
                texts += [(msg, now)] if msg is not None and msg.get_type() == "STATUSTEXT" else []
                continue
            if msg.type == MAV_TYPE_GCS or msg.autopilot == MAV_AUTOPILOT_INVALID:
                continue  # another ground station, not an autopilot
            self.target_system = msg.get_srcSystem()
            self.target_component = msg.get_srcComponent()
            if self.autopilot_setting == "auto":
                self.autopilot = "px4" if msg.autopilot == MAV_AUTOPILOT_PX4 else "ardupilot"
            else:
                self.autopilot = self.autopilot_setting
            own = self.own_velocity_loop
            self.velocity_loop = VelocityLoop() if (self.autopilot == "px4" if own is None else own) else None
            self._handle(msg, self._monotonic())
            for text, heard_s in texts:  # the autopilot's own (others are dropped as ever)
                self._handle(text, heard_s)
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
        if self.autopilot == "ardupilot":
            rates[MSG_WIND] = 1.0  # the wind limit's reading (masonry.mission.wind_limit); PX4 has no WIND
        sent_at = self._monotonic()
        for msg_id, rate_hz in rates.items():
            self._send_command(MAV_CMD_SET_MESSAGE_INTERVAL, (msg_id, 1e6 / rate_hz, 0, 0, 0, 0, 0), 0)
        deadline = sent_at + self.command_timeout_s
        asked = MAV_CMD_SET_MESSAGE_INTERVAL
        with self._acks:
            while True:
                answered = [a for a in self._ack_log if a[0] >= sent_at and a[1] == asked]
                if len(answered) >= len(rates) or self._monotonic() >= deadline:
                    break
                self._acks.wait(timeout=max(0.0, deadline - self._monotonic()))
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
                started = self._monotonic()
                msg = self._conn.recv_match(blocking=True, timeout=0.05)
                if msg is None:
                    self._state.listened_s = started
            except (OSError, ValueError, AttributeError) as exc:
                if self._stop.is_set():
                    return
                self.receive_errors += 1
                self._count_error("receive error", self.receive_errors, exc)
                self._stop.wait(0.05)
                continue
            if msg is not None:
                self._receive(msg, self._monotonic())

    def _receive(self, msg: Any, now: float) -> None:
        """Handle one received message; one the handler cannot read (another dialect, a bad field) is counted."""
        try:
            self._handle(msg, now)
        except (AttributeError, TypeError, ValueError) as exc:
            self.handler_errors += 1
            self._count_error("unhandled message", self.handler_errors, exc)

    def _handle(self, msg: Any, now: float) -> None:
        kind = msg.get_type()
        if kind == "BAD_DATA" or msg.get_srcSystem() != self.target_system:
            return
        for kinds, q in self._listeners:
            if kind in kinds:
                q.put(msg)
        with self._lock:
            st = self._state
            st.last_message_s = now
            if kind == "HEARTBEAT":
                if msg.get_srcComponent() != self.target_component:
                    return
                st.last_heartbeat_s = now
                st.heartbeat_boot_s = self.clock.last_boot_s
                st.armed = bool(msg.base_mode & MAV_MODE_FLAG_SAFETY_ARMED)
                st.base_mode = msg.base_mode
                st.custom_mode = msg.custom_mode
            elif kind == "LOCAL_POSITION_NED":
                st.position_ned = (msg.x, msg.y, msg.z)
                st.velocity_ned = (msg.vx, msg.vy, msg.vz)
                st.position_time_s = now
                if self.velocity_loop is not None:
                    tilt = self.velocity_observer_input == "tilt"  # the attitude's acceleration (29/30)
                    a = tilt_acceleration_mps2(*st.attitude) if tilt else None
                    self.velocity_loop.observe(msg.time_boot_ms / 1000.0, st.position_ned, a)
                if not st.armed:
                    st.ground_heights.append(-float(msg.z))
                self.clock.observe(msg.time_boot_ms / 1000.0, now)
            elif kind == "ATTITUDE":
                st.attitude = (msg.roll, msg.pitch, msg.yaw)
                self.clock.observe(msg.time_boot_ms / 1000.0, now)
            elif kind in ("SYS_STATUS", "WIND"):
                _sensed(st, kind, msg, now)
            elif kind in ("EKF_STATUS_REPORT", "ESTIMATOR_STATUS"):
                st.estimate_flags = int(msg.flags)
            elif kind == "EXTENDED_SYS_STATE":
                st.landed_state = int(msg.landed_state)
            elif kind == "STATUSTEXT":
                add_status_text(st.status_texts, msg, now)
            elif kind == "COMMAND_ACK":
                self._ack_log.append((now, int(msg.command), int(msg.result)))
                del self._ack_log[:-64]
                self._acks.notify_all()

    def _send_loop(self) -> None:
        period = 1.0 / self.setpoint_rate_hz
        vision_period = 1.0 / self.vision_rate_hz
        next_setpoint = next_beat = next_vision = self._monotonic()
        while not self._stop.is_set():
            now = self._monotonic()
            try:
                if now >= next_beat:
                    next_beat = now + 1.0
                    self._send_heartbeat()
                if now >= next_setpoint:
                    next_setpoint += period
                    if next_setpoint < now:  # fell behind (suspended?): don't burst
                        next_setpoint = now + period
                    if now >= self.stream_paced_until_s:
                        self._stream_setpoint(self.stream_clock())
                if self.pose_source is not None and now >= next_vision:
                    next_vision = now + vision_period
                    try:
                        self._forward_pose()
                    except Exception as exc:  # a bad pose must not stop the setpoint stream
                        self.pose_errors += 1
                        self.last_pose_error = f"{type(exc).__name__}: {exc}"
                        self._count_error("pose forward error", self.pose_errors, exc)
            except (OSError, ValueError, AttributeError) as exc:
                if self._stop.is_set():
                    return
                self.send_errors += 1
                self._count_error("send error", self.send_errors, exc)
            wake = min(next_setpoint, next_beat, next_vision if self.pose_source is not None else next_beat)
            self._stop.wait(max(0.0, wake - self._monotonic()))

    def _stream_setpoint(self, now: float) -> None:
        """The sender's hook, once per setpoint period: a bare link streams nothing but its heartbeat."""

    def _forward_pose(self) -> None:
        """The sender's hook for ``pose_source`` (the flight controller forwards it in the autopilot's frame)."""

    def _send_position_target(self, v_ned: Vec3, yaw_rate_ned: float) -> None:
        mask, v, a = TYPE_MASK_VELOCITY_YAW_RATE, v_ned, (0.0, 0.0, 0.0)
        with self._lock:  # engaged: our loop, while the position it closes on is fresh (else the autopilot's)
            loop = self.velocity_loop if self.velocity_loop_engaged else None
            if self.velocity_loop is not None and loop is None:
                self.velocity_loop.release()
            if loop is not None and self.position_age_s() <= VELOCITY_LOOP_STALE_S:
                mask, v, a = TYPE_MASK_ACCELERATION_YAW_RATE, (0.0, 0.0, 0.0), loop.acceleration(v_ned)
        with self._send_lock:
            self._conn.mav.set_position_target_local_ned_send(
                int(self._monotonic() * 1000) & 0xFFFFFFFF, self.target_system, self.target_component,
                MAV_FRAME_LOCAL_NED, mask, 0.0, 0.0, 0.0,
                float(v[0]), float(v[1]), float(v[2]),
                float(a[0]), float(a[1]), float(a[2]),
                0.0, float(yaw_rate_ned),
            )  # fmt: skip
        self.setpoints_sent += 1

    def _send_heartbeat(self) -> None:
        with self._send_lock:
            self._conn.mav.heartbeat_send(MAV_TYPE_GCS, MAV_AUTOPILOT_INVALID, 0, 0, 4)  # MAV_STATE_ACTIVE

    def _send_command(self, command: int, params: tuple[float, ...], confirmation: int) -> None:
        with self._send_lock:
            self._conn.mav.command_long_send(
                self.target_system, self.target_component, command, confirmation, *map(float, params)
            )

    def _heard_until(self, now: float) -> float:
        """Up to when the receiver read all that arrived and the autopilot could speak (sitl_standstill)."""
        return self.standstill.heard_until(now, self._state.last_message_s, self._state.listened_s)

    def _silences(self, now: float) -> tuple[float, float]:
        """Seconds without a message (local) and without a HEARTBEAT (the slower clock), up to what was read."""
        st, heard = self._state, self._heard_until(now)
        return heard - st.last_message_s, beatless_s(
            heard, st.last_heartbeat_s, self.clock.last_boot_s, st.heartbeat_boot_s
        )

    def _link_ok(self, now: float) -> bool:
        """The watchdog: a message within ``heartbeat_timeout_s``, a HEARTBEAT within 2.5 s (link_silence)."""
        silent_s, beatless = self._silences(now)
        ok = self._conn is not None and silent_s <= self.heartbeat_timeout_s
        ok = ok and beatless <= self._heartbeat_missing_s
        # its transitions, what it read, logged
        if ok == (self._down_at is not None) and self._conn is not None:
            st, boot = self._state, self.clock.last_boot_s
            _log.warning(
                "MAVLink watchdog on %s: %s", self.url, watchdog_text(now, st, beatless, boot, self._down_at)
            )
            self._down_at = None if ok else (st.last_message_s, boot)
        return ok

    def _check_link(self, what: str) -> None:
        if self._conn is None:
            raise LinkLost(f"{what}: not connected to {self.url} (call connect() first)")
        silent_s, beatless = self._silences(self._monotonic())
        if silent_s > self.heartbeat_timeout_s:
            raise LinkLost(f"{what}: no message from the autopilot on {self.url} for {silent_s:.1f} s")
        if beatless > self._heartbeat_missing_s:
            raise LinkLost(f"{what}: no HEARTBEAT from the autopilot on {self.url} for {beatless:.1f} s")

    def _latest_warning(self, since: float) -> str | None:
        with self._lock:
            texts = [
                t for t in (self._state.status_texts or []) if t[0] >= since and t[1] <= MAV_SEVERITY_WARNING
            ]
        return texts[-1][2].rstrip() if texts else None

    def command(self, name: str, command: int, params: tuple[float, ...] = ()) -> None:
        """Send COMMAND_LONG ``command`` and wait for its COMMAND_ACK.

        Raises:
            CommandRejected: the autopilot answered with anything but ACCEPTED (reason: result and warning).
            CommandTimeout: no answer after ``command_retries`` resends.
            LinkLost: the link watchdog has fired.
        """
        self._check_link(name)
        params = tuple(params) + (0.0,) * (7 - len(params))
        started = self._monotonic()
        for attempt in range(self.command_retries + 1):
            sent_at = self._monotonic()
            self._send_command(command, params, attempt)
            result = self._wait_ack(command, sent_at, sent_at + self.command_timeout_s)
            if result is None:
                continue
            if result == MAV_RESULT_ACCEPTED:
                return
            reason = MAV_RESULT_NAMES.get(result, f"result {result}")
            warning = self._latest_warning(started - 0.5)
            text = f"{reason}: {warning}" if warning else reason
            raise CommandRejected(name, text, temporary=result == MAV_RESULT_TEMPORARILY_REJECTED)
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
                remaining = deadline - self._monotonic()
                if remaining <= 0.0:
                    return None
                in_progress = any(t >= since and c == command for t, c, _ in self._ack_log)
                if in_progress:  # IN_PROGRESS extends the wait (ArduPilot: long calibrations; harmless here)
                    deadline = max(deadline, self._monotonic() + self.command_timeout_s)
                self._acks.wait(timeout=min(remaining, 0.1))

    @property
    def battery_voltage_v(self) -> float:
        return self._state.battery_voltage_v

    def status_texts(self) -> list[str]:
        """The autopilot's recent STATUSTEXT messages, oldest first."""
        with self._lock:
            return [t[2] for t in self._state.status_texts or []]
