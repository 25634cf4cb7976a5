"""FlightController over MAVLink 2 (pymavlink): ArduPilot GUIDED or PX4 OFFBOARD velocity control.

This module and :mod:`~masonry.adapters.mavlink_frame` are the only places in masonry where NED appears. masonry's
world is ENU (x east, y north, z up) with its origin at the autopilot's local origin, shifted by a configurable
offset and rotated by a configurable yaw (:class:`FrameTransform`); MAVLink's local frame is NED and its body
frame FRD.

Lifecycle (construct, then connect)::

    fc = MavlinkFlightController("udpin:0.0.0.0:14550")
    fc.connect()            # heartbeat, target ids, message rates, background threads
    fc.arm()                # waits for a usable position estimate, GUIDED/OFFBOARD, arm (COMMAND_ACK checked)
    fc.takeoff(1.2)
    fc.send_velocity((0.0, 0.0, -0.2), 0.0)   # streamed at >= 10 Hz by a background sender
    fc.land()
    fc.close()

The connection, its threads and COMMAND_ACK handling are :class:`~masonry.adapters.mavlink_link.MavlinkLink`
(its :meth:`~masonry.adapters.mavlink_link.MavlinkLink.status` counts every error the threads meet); this
module adds the commands, the setpoint stream and the frames. Every command is checked through COMMAND_ACK: a refusal raises :class:`~masonry.errors.CommandRejected` with the
MAV_RESULT and the autopilot's latest warning text (ArduPilot's "PreArm: ..."), silence raises
:class:`~masonry.errors.CommandTimeout` after the retries, and a silent link raises
:class:`~masonry.errors.LinkLost`.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from masonry.adapters.arming import ARM_RETRY_S, arm_retrying
from masonry.adapters.mavlink_estimate import EstimateLink
from masonry.adapters.mavlink_frame import FrameTransform
from masonry.adapters.mavlink_link import LinkClock, LinkStatus, MavlinkLink, load_signing_key, mavutil_module
from masonry.adapters.mavlink_protocol import (
    ARDUPILOT_MODES,
    ESTIMATE_FLAGS_BAD,
    ESTIMATE_FLAGS_REQUIRED,
    HEARTBEAT_MISSING_S,
    LANDING_MODES,
    MAV_AUTOPILOT_ARDUPILOTMEGA,
    MAV_AUTOPILOT_INVALID,
    MAV_AUTOPILOT_PX4,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_LOCAL_NED,
    MAV_LANDED_STATE_LANDING,
    MAV_LANDED_STATE_ON_GROUND,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_IN_PROGRESS,
    MAV_RESULT_NAMES,
    MAV_SEVERITY_WARNING,
    MAV_TYPE_GCS,
    MSG_ATTITUDE,
    MSG_EKF_STATUS_REPORT,
    MSG_ESTIMATOR_STATUS,
    MSG_EXTENDED_SYS_STATE,
    MSG_HEARTBEAT,
    MSG_LOCAL_POSITION_NED,
    MSG_SYS_STATUS,
    MSG_WIND,
    PX4_MODES,
    TYPE_MASK_VELOCITY_YAW_RATE,
    Autopilot,
    describe_estimate_flags,
    estimate_usable,
    mode_name,
)
from masonry.adapters.pose_source import PoseSource
from masonry.adapters.takeoff import ClimbConfig, ClimbMonitor, climb_limit_s
from masonry.errors import CommandRejected, CommandTimeout, InputError, LinkLost
from masonry.ports import Telemetry, Vec3

if TYPE_CHECKING:
    from masonry.adapters.mavlink_fence import FenceUpload
    from masonry.geofence import Site

__all__ = [
    "ARDUPILOT_MODES",
    "ESTIMATE_FLAGS_BAD",
    "ESTIMATE_FLAGS_REQUIRED",
    "HEARTBEAT_MISSING_S",
    "LANDING_MODES",
    "MAV_AUTOPILOT_ARDUPILOTMEGA",
    "MAV_AUTOPILOT_INVALID",
    "MAV_AUTOPILOT_PX4",
    "MAV_CMD_COMPONENT_ARM_DISARM",
    "MAV_CMD_DO_SET_MODE",
    "MAV_CMD_NAV_LAND",
    "MAV_CMD_NAV_TAKEOFF",
    "MAV_CMD_SET_MESSAGE_INTERVAL",
    "MAV_FRAME_LOCAL_NED",
    "MAV_LANDED_STATE_LANDING",
    "MAV_LANDED_STATE_ON_GROUND",
    "MAV_MODE_FLAG_CUSTOM_MODE_ENABLED",
    "MAV_MODE_FLAG_SAFETY_ARMED",
    "MAV_RESULT_ACCEPTED",
    "MAV_RESULT_IN_PROGRESS",
    "MAV_RESULT_NAMES",
    "MAV_SEVERITY_WARNING",
    "MAV_TYPE_GCS",
    "MSG_ATTITUDE",
    "MSG_EKF_STATUS_REPORT",
    "MSG_ESTIMATOR_STATUS",
    "MSG_EXTENDED_SYS_STATE",
    "MSG_HEARTBEAT",
    "MSG_LOCAL_POSITION_NED",
    "MSG_SYS_STATUS",
    "MSG_WIND",
    "PX4_MODES",
    "TYPE_MASK_VELOCITY_YAW_RATE",
    "Autopilot",
    "FrameTransform",
    "LinkClock",
    "LinkStatus",
    "MavlinkFlightController",
    "MavlinkLink",
    "describe_estimate_flags",
    "estimate_usable",
    "load_signing_key",
    "mavutil_module",
    "mode_name",
]


class MavlinkFlightController(EstimateLink):
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
        arm_retry_s: how long :meth:`arm` keeps asking while the autopilot refuses it as temporary (PX4's first
            seconds; :mod:`masonry.adapters.arming`).
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
        ground_m: where the UAV stands in the world when it arms (its blueprint home): :meth:`arm` then measures
            the height the EKF reports on the ground and shifts ``frame`` so that the ground reads ``ground_m``'s
            z (PX4 on GNSS and baro reported -0.34 to -0.71 m, issue 20). Only within 1 m of it horizontally
            (a UAV that landed elsewhere keeps the last measurement). None: ``frame`` as given.
        monotonic: the local monotonic clock (s) that stamps what arrives and that the link watchdog, the
            connect, command and estimate timeouts and the setpoint hold are measured on (a test injects one it
            can hold still; the waits themselves stay bounded polls of wall time). The take-off's timeout is on
            the autopilot's clock (``clock``), as the machine's.
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
        arm_retry_s: float = ARM_RETRY_S,
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
        ground_m: Vec3 | None = None,
        monotonic: Callable[[], float] = time.monotonic,
    ) -> None:
        super().__init__(
            url,
            baud=baud,
            autopilot=autopilot,
            heartbeat_timeout_s=heartbeat_timeout_s,
            connect_timeout_s=connect_timeout_s,
            command_timeout_s=command_timeout_s,
            command_retries=command_retries,
            setpoint_rate_hz=setpoint_rate_hz,
            signing_key=signing_key,
            pose_source=pose_source,
            vision_rate_hz=vision_rate_hz,
            source_system=source_system,
            source_component=source_component,
            telemetry_rate_hz=telemetry_rate_hz,
            monotonic=monotonic,
        )
        self.estimate_timeout_s = estimate_timeout_s
        self.arm_retry_s = arm_retry_s
        self.setpoint_hold_s = setpoint_hold_s
        self.frame = frame or FrameTransform()
        self.land_on_close = land_on_close
        self._setpoint: tuple[Vec3, float] | None = None  # NED velocity, NED yaw rate
        self._setpoint_time_s = -math.inf
        self._streaming = False
        self._takeoff_target_m: float | None = None  # world altitude being climbed to
        self._takeoff_mode = ""  # the autopilot's mode when the take-off was commanded
        self._takeoff_started_s, self._takeoff_limit_s = -math.inf, climb_limit_s(None)  # (takeoff())
        self._climb: ClimbMonitor | None = None  # PX4's take-off climb inside OFFBOARD
        #: why the last take-off ended short of its altitude (None: it reached it, or none was asked)
        self.takeoff_problem: str | None = None
        self.ground_m = ground_m
        #: the EKF's ground height measured at the last arming (local up, m; None: not measured)
        self.ground_offset_m: float | None = None
        self._last_vision_stamp: Any = None
        #: held across one stream decision and its send, and by takeoff() while it starts a climb (issue 29)
        self._stream_lock = threading.Lock()

    # ----------------------------------------------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Stop the threads and close the link; still flying in GUIDED/OFFBOARD, command LAND first (``land_on_close``).

        A program interrupted in flight (Ctrl-C, an exception) so lands the UAV where it is instead of leaving it
        to the guided timeout and the link-loss failsafe.
        """
        if self.land_on_close and self._conn is not None and self._threads:
            tel = self.telemetry()
            # only while masonry flies it (GUIDED/OFFBOARD): a pilot's mode is the pilot's
            # (or climbing in the mode the take-off began in: a pilot's switch mid-climb is the pilot's too)
            climbing = self._takeoff_target_m is not None and tel.mode == self._takeoff_mode
            flying_ours = tel.mode == self.offboard_mode or climbing
            if tel.link_ok and tel.armed and not tel.on_ground and not tel.landing and flying_ours:
                try:
                    self.land()
                except (CommandRejected, CommandTimeout, LinkLost):
                    pass  # the autopilot's failsafes remain
        super().close()

    # ---------------------------------------------------------------------------------- the setpoint stream

    def _stream_setpoint(self, now: float) -> None:
        with (
            self._stream_lock
        ):  # a decision is sent before takeoff() starts a climb, or made after (issue 29)
            self._stream_setpoint_locked(now)

    def _stream_setpoint_locked(self, now: float) -> None:
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
            with self._lock:  # where the own loop flies the climb, the position's velocity (EKF2's is off)
                loop = self.velocity_loop if self.velocity_loop_engaged else None
                climb_rate = -(loop.velocity_mps if loop is not None else self._state.velocity_ned)[2]
            climb_monitor = self._climb
            if climb_monitor is not None:
                # PX4 has no GUIDED-style takeoff inside OFFBOARD: the stream climbs, monitored (takeoff.py)
                # a fresh velocity setpoint takes over once the climb is near its altitude (as ArduPilot's
                # guided take-off ends on one): the monitor's "steady" would hold it back another second.
                # No telemetry past the clock's horizon (stale): hold the altitude, judge no progress on none
                climb, stale, asked = 0.0, self.clock.stale, setpoint is not None and fresh
                if not (stale or (asked and climb_monitor.hand_over(world_alt, climb_rate))):
                    climb = climb_monitor.step(self.clock.now_s(), world_alt, climb_rate)
                if climb_monitor.own_loop:  # a stall once airborne: the rest on the own loop (takeoff.py)
                    self.velocity_loop_engaged = True
                if not climb_monitor.done:
                    self._send_position_target((0.0, 0.0, -climb), 0.0)
                    return
                with self._lock:
                    self._takeoff_target_m = None
                    self.takeoff_problem = climb_monitor.reason
                    self._climb = None
                    self.velocity_loop_engaged = True  # airborne: acceleration setpoints, if ours (issue 29)
            else:
                reached = world_alt >= takeoff_target - 0.1 and abs(climb_rate) < 0.1
                if reached or self.clock.now_s() - self._takeoff_started_s > self._takeoff_limit_s:
                    with self._lock:
                        self._takeoff_target_m = None
                        self.velocity_loop_engaged = True
                        if not reached:
                            alt = f"{world_alt:.2f} m of {takeoff_target:.2f} m"
                            self.takeoff_problem = f"take-off at {alt} after {self._takeoff_limit_s:.0f} s"
                else:
                    return  # ArduPilot climbs on its own; a velocity target would abort its takeoff
        if setpoint is None or not fresh:
            self._send_position_target((0.0, 0.0, 0.0), 0.0)
        else:
            self._send_position_target(setpoint[0], setpoint[1])

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

    #: A WIND message older than this is no reading (ArduPilot streams it at 1 Hz once asked).
    WIND_FRESH_S = 5.0

    @property
    def wind_speed_mps(self) -> float | None:
        """The autopilot's horizontal wind estimate (m/s, its WIND message), None when it reports none."""
        with self._lock:
            st = self._state
            if st.wind_speed_mps is None or self._monotonic() - st.wind_time_s > self.WIND_FRESH_S:
                return None
            return st.wind_speed_mps

    @property
    def offboard_mode(self) -> str:
        """The mode velocity setpoints are flown in: GUIDED (ArduPilot) or OFFBOARD (PX4)."""
        return "OFFBOARD" if self.autopilot == "px4" else "GUIDED"

    def arm(self) -> None:
        """Wait for a usable position estimate, enter GUIDED/OFFBOARD, arm; each step checked by COMMAND_ACK."""
        self._check_link("arm")
        self.wait_for_estimate()
        if self.ground_m is not None:
            self.measure_ground(self.ground_m)
        with self._lock:
            self._setpoint = None
            self._streaming = True  # PX4 needs a setpoint stream before it accepts OFFBOARD
        arm_retrying(self._enter_mode_and_arm, self._monotonic, self._pause, self.arm_retry_s)
        with self._lock:
            self._state.armed = True  # the ACK said so; the next HEARTBEAT confirms

    def measure_ground(self, ground_m: Vec3, samples: int = 10, timeout_s: float = 2.0) -> float | None:
        """Measure the EKF's height on the ground and shift ``frame`` so that the ground reads ``ground_m[2]``.

        Averages the last ``samples`` LOCAL_POSITION_NED reports received disarmed (waiting at most ``timeout_s``
        of local time for them), on the ground and within 1 m of ``ground_m`` horizontally; otherwise the frame stays as it is.

        Returns:
            The EKF's ground height (local up, m) now in use, or None if it could not be measured.
        """
        tel = self.telemetry()
        if tel.armed or not tel.on_ground or math.dist(tel.position_m[:2], ground_m[:2]) > 1.0:
            return self.ground_offset_m
        # the receiver keeps the heights reported while disarmed: usually there are enough already (no wait)
        deadline = self._monotonic() + timeout_s
        while True:
            with self._lock:
                heights = list(self._state.ground_heights)[-samples:]
            if len(heights) >= samples or self._monotonic() >= deadline:
                break
            self._stop.wait(0.01)
        if len(heights) < 3:
            self.warnings.append(
                f"ground height not measured: {len(heights)} position reports in {timeout_s} s"
            )
            return self.ground_offset_m
        up = sum(heights) / len(heights)
        ox, oy, _ = self.frame.offset_m
        self.frame = FrameTransform((ox, oy, float(ground_m[2]) - up), self.frame.yaw_rad)
        self.ground_offset_m = up
        return up

    def _enter_mode_and_arm(self) -> None:
        # each asking enters OFFBOARD anew: the stream runs armed only, and PX4 refuses arming ("Resolve system
        # health failures first") in an OFFBOARD left without setpoints for COM_OF_LOSS_T
        if self.autopilot == "px4":
            self._stream_zero_before_offboard()
        self.set_mode(self.offboard_mode)
        self.command("arm", MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))

    def _stream_zero_before_offboard(self) -> None:
        for _ in range(5):
            self._send_position_target((0.0, 0.0, 0.0), 0.0)
            self._pause(0.05)

    def disarm(self) -> None:
        """Disarm (the autopilot refuses while flying: CommandRejected)."""
        self.command("disarm", MAV_CMD_COMPONENT_ARM_DISARM, (0.0,))
        with self._lock:
            self._state.armed = False
            self._streaming = False
            self._setpoint = None
            self.velocity_loop_engaged = False

    def takeoff(self, altitude_m: float, timeout_s: float | None = None) -> None:
        """Climb ``altitude_m`` above where the UAV stands (the port's convention); setpoints wait until then, for
        at most :func:`~masonry.adapters.takeoff.climb_limit_s` of the caller's ``timeout_s`` (its clock).

        ArduPilot: MAV_CMD_NAV_TAKEOFF in GUIDED. PX4: a climb inside OFFBOARD by the setpoint stream, monitored
        against its progress (:class:`~masonry.adapters.takeoff.ClimbMonitor`): it ends reached and steady, or
        with :attr:`takeoff_problem` saying why not. Where it stands: the position at this call (once armed).
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
        self._takeoff_mode = self.telemetry().mode
        # The climb is started before NAV_TAKEOFF goes out, with no stream decision under way (issue 29): from the
        # arming the stream sends zero velocities (ignored on the ground), and one that reached ArduPilot after it
        # had accepted the take-off and lifted off (this caller left unrun 0.15 s after the ACK) ended its climb.
        with self._stream_lock, self._lock:
            before = (self._setpoint, self._streaming, self.velocity_loop_engaged)
            self._setpoint = None
            self._streaming = True
            self._takeoff_target_m = ground_world[2] + altitude_m
            self.velocity_loop_engaged = False
            self._takeoff_started_s = self.clock.now_s()  # (the autopilot's clock, as the machine's take-off)
            self._takeoff_limit_s, self.takeoff_problem = climb_limit_s(timeout_s), None
            own_loop = self.velocity_loop is not None  # a stall once airborne: the rest on it (takeoff.py)
            climb = ClimbMonitor(
                self.clock.now_s(),
                self._takeoff_target_m,
                ClimbConfig(timeout_s=self._takeoff_limit_s, own_loop=own_loop),
            )
            self._climb = climb if self.autopilot == "px4" else None
        if self.autopilot == "ardupilot":
            try:
                self.command("takeoff", MAV_CMD_NAV_TAKEOFF, (0, 0, 0, math.nan, 0, 0, altitude_m))
            except (CommandRejected, CommandTimeout, LinkLost):
                with self._lock:  # no take-off: the stream as before it
                    self._takeoff_target_m = None
                    self._setpoint, self._streaming, self.velocity_loop_engaged = before
                raise

    def land(self) -> None:
        """Land where the UAV is (ArduPilot LAND mode; PX4 MAV_CMD_NAV_LAND); the setpoint stream stops."""
        self._check_link("land")
        with self._lock:
            self._streaming = False
            self._setpoint = None
            self._takeoff_target_m = None
            self._climb = None
            self.velocity_loop_engaged = False
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
            self._setpoint_time_s = self.stream_clock()  # (the clock the stream judges freshness on)
            if not self._state.armed:
                return
            self._streaming = True
            send_now = self._takeoff_target_m is None
        if send_now:  # the stream repeats it; sending now removes up to one period of latency
            self._send_position_target(v, FrameTransform.yaw_rate_to_ned(float(yaw_rate_radps)))

    # --------------------------------------------------------------------------------------------- telemetry

    def upload_fence(self, site: Site) -> FenceUpload:
        """Upload the blueprint's site as the autopilot's fence and check it (:mod:`masonry.adapters.mavlink_fence`).

        Raises:
            CommandRejected: the autopilot refused it or kept something else; CommandTimeout: it did not answer.
        """
        from masonry.adapters.mavlink_fence import upload_fence

        self._check_link("fence")
        return upload_fence(self, site, monotonic=self._monotonic)  # (the commands' clock)

    def telemetry(self) -> Telemetry:
        """The latest state in the world frame (never blocks; ``link_ok`` False once the watchdog fired)."""
        now = self._monotonic()
        with self._lock:
            st = self._state
            link_ok = self._link_ok(now)
            position_ok = link_ok and self._position_ok(self._heard_until(now))
            p_ned = st.position_ned or (0.0, 0.0, 0.0)
            position = (
                self.frame.position_to_world(p_ned) if st.position_ned is not None else self.frame.offset_m
            )
            loop = (
                self.velocity_loop if self.velocity_loop_engaged else None
            )  # ours: the velocity it closes on
            velocity = self.frame.velocity_to_world(
                loop.velocity_mps if loop is not None else st.velocity_ned
            )
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
