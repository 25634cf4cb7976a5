"""A simulated multirotor behind a real MAVLink 2 endpoint that behaves like ArduCopter (``masonry sitl``).

It pushes its stream to ``udpout:HOST:PORT`` as ArduPilot's SITL/MAVProxy do (``--out 127.0.0.1:14550``), so a
ground station or :class:`~masonry.adapters.mavlink.MavlinkFlightController` listens with ``udpin:0.0.0.0:PORT``
(pymavlink's ``udp:`` is the same) and is answered on the address it replies from.

What it models (ArduCopter semantics; names from ArduPilot):
- HEARTBEAT at 1 Hz (wall time), custom modes STABILIZE/GUIDED/LAND/..., armed flag in ``base_mode``.
- An EKF that needs ``ekf_converge_s`` (simulated) after boot before LOCAL_POSITION_NED flows and
  EKF_STATUS_REPORT reports a usable position (or, with ``position_source="vision"``, VISION_POSITION_ESTIMATE
  messages); arming with pre-arm checks (position estimate, battery, an injectable failure) answered with
  STATUSTEXT "PreArm: ..." and COMMAND_ACK FAILED.
- MAV_CMD_NAV_TAKEOFF in GUIDED, velocity + yaw-rate SET_POSITION_TARGET_LOCAL_NED with the guided timeout
  (GUID_TIMEOUT, 3 s: no setpoint -> stop), LAND mode with auto-disarm on touchdown, GCS failsafe
  (FS_GCS_TIMEOUT, 5 s without a GCS heartbeat while flying -> LAND), battery drain in SYS_STATUS,
  MAV_CMD_SET_MESSAGE_INTERVAL, MAVLink 2 signing.
- ``time_scale``: simulated seconds per wall second, so tests fly a whole takeoff in a fraction of a second.
  The guided timeout runs on simulated time (it bounds how far the UAV flies on a stale setpoint; a ground
  station streaming at 10-20 Hz of wall time stays well within it), the GCS failsafe on wall time (ground
  stations send their heartbeat at 1 Hz of wall time, which scaled would trip it).

The vehicle dynamics are the simulator's multirotor, :class:`masonry.sim.vehicle.SimVehicle` (velocity lag with
limits, takeoff, landing, ground contact, battery, motion-capture noise); this module adds the autopilot around it.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any, ClassVar

import numpy as np
from typing_extensions import Self

from masonry.adapters.mavlink import (
    ARDUPILOT_MODES,
    MAV_AUTOPILOT_ARDUPILOTMEGA,
    MAV_AUTOPILOT_PX4,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MAV_CMD_DO_SET_MODE,
    MAV_CMD_NAV_LAND,
    MAV_CMD_NAV_TAKEOFF,
    MAV_CMD_SET_MESSAGE_INTERVAL,
    MAV_FRAME_LOCAL_NED,
    MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
    MAV_MODE_FLAG_SAFETY_ARMED,
    MAV_TYPE_GCS,
    MSG_ATTITUDE,
    MSG_EKF_STATUS_REPORT,
    MSG_ESTIMATOR_STATUS,
    MSG_HEARTBEAT,
    MSG_WIND,
    PX4_MODES,
    FrameTransform,
    mavutil_module,
)
from masonry.adapters.sitl_config import (
    DEFAULT_RATES_HZ,
    DISARM_MAGIC,
    MAV_RESULT_ACCEPTED,
    MAV_RESULT_DENIED,
    MAV_RESULT_FAILED,
    MAV_RESULT_TEMPORARILY_REJECTED,
    MAV_RESULT_UNSUPPORTED,
    MAV_SEVERITY_CRITICAL,
    MAV_SEVERITY_INFO,
    MAV_SEVERITY_WARNING,
    MAV_STATE_ACTIVE,
    MAV_STATE_STANDBY,
    MAV_TYPE_QUADROTOR,
    VELOCITY_IGNORED,
    VELOCITY_ONLY_IGNORED,
    SitlConfig,
    free_udp_port,
)
from masonry.adapters.sitl_lockstep import SitlLockstep
from masonry.adapters.sitl_offboard import SetpointStream
from masonry.adapters.sitl_streams import send_stream
from masonry.errors import CommandRejected
from masonry.ports import Vec3

# Re-exported: callers import these from here (they live in sitl_config).
__all__ = ["SITL_PRESETS", "MavlinkSitl", "SitlConfig", "free_udp_port"]

#: ``masonry sitl --vehicle NAME``: the autopilot knobs that come with a vehicle preset. ``px4``: PX4 v1.16 on
#: GNSS as issue 20 met it (OFFBOARD rules, EKF2's at-rest flags, the ground 0.5 m up in its frame, and the
#: vehicle's thrust ramp and GNSS-grade noise).
SITL_PRESETS: dict[str, dict[str, Any]] = {
    "ideal": {},
    "arducopter": {"vehicle": "arducopter"},
    "px4": {"vehicle": "px4", "autopilot": "px4", "ekf2_flags": True, "ekf_ground_z_m": -0.5},
}


class MavlinkSitl:
    """ArduCopter-like SITL: a vehicle model served over MAVLink 2 on UDP (construct, then ``start``).

    Args:
        port: UDP port the stream is sent to (where the ground station listens).
        host: address of the ground station.
        vehicle: the dynamics; default a :class:`~masonry.sim.vehicle.SimVehicle` standing at ``home_m`` whose
            setpoint timeout is the guided timeout (simulated seconds: how far a UAV flies on a stale command).
        home_m: start position (world ENU). With ``position_source="internal"`` (the default, like GPS) the local frame's origin is
            there, as a real autopilot's on GPS (LOCAL_POSITION_NED is 0, 0, 0 at home); with ``"vision"`` the
            local frame is the world's (motion capture poses are fed to it in the world frame).
        time_scale: simulated seconds per wall second.
        signing_key: 32-byte MAVLink 2 key: sign everything, accept only messages signed with it.
        config: autopilot knobs.
        log: called with one line per event (mode change, STATUSTEXT), e.g. ``print``.
        lockstep_wait_s: lock-step (``masonry sitl --lockstep``, :mod:`masonry.adapters.sitl_lockstep`): simulated
            time waits for the client's grants, at most this long (wall s) each; None: it runs free.
    """

    def __init__(
        self,
        port: int = 14550,
        host: str = "127.0.0.1",
        *,
        vehicle: Any = None,
        home_m: Vec3 = (0.0, 0.0, 0.0),
        time_scale: float = 1.0,
        signing_key: bytes | None = None,
        config: SitlConfig | None = None,
        physics_dt_s: float = 0.01,
        seed: int = 0,
        log: Callable[[str], None] | None = None,
        lockstep_wait_s: float | None = None,
    ) -> None:
        self.port = port
        self.lockstep = SitlLockstep(self, lockstep_wait_s) if lockstep_wait_s is not None else None
        self.host = host
        self.time_scale = time_scale
        self.signing_key = signing_key
        self.config = config or SitlConfig()
        if vehicle is None:
            from dataclasses import replace

            from masonry.sim.vehicle import SimVehicle
            from masonry.sim.vehicle_config import sitl_vehicle_preset

            vehicle = SimVehicle(
                replace(
                    sitl_vehicle_preset(self.config.vehicle),
                    setpoint_timeout_s=self.config.guided_timeout_s,
                    link_failsafe_s=math.inf,  # the GCS failsafe below decides
                    battery_arm_min_fraction=self.config.arm_min_battery,
                ),
                position_m=home_m,
                rng=np.random.default_rng(seed),
            )
        self.vehicle = vehicle
        self.seed = seed  # (lock-step draws the noise afresh from it at the first grant: sitl_lockstep)
        self.physics_dt_s = physics_dt_s
        origin = (
            tuple(float(c) for c in home_m) if self.config.position_source == "internal" else (0.0, 0.0, 0.0)
        )
        self.frame = FrameTransform(origin)  # type: ignore[arg-type]
        self.sim_time_s = 0.0
        if self.config.autopilot not in ("ardupilot", "px4"):
            raise ValueError(f"autopilot must be ardupilot or px4, not {self.config.autopilot!r}")
        self.px4 = self.config.autopilot == "px4"
        self._modes = PX4_MODES if self.px4 else ARDUPILOT_MODES
        self._offboard_mode = "OFFBOARD" if self.px4 else "GUIDED"
        self._land_mode = "AUTO.LAND" if self.px4 else "LAND"
        self.mode = "POSCTL" if self.px4 else "STABILIZE"
        # PX4's OFFBOARD rules (issue 29); in lock-step timed on the simulated clock, as the SITL's time (sitl_offboard)
        self._setpoints = SetpointStream(
            self.config.starved_answers, None if self.lockstep is None else (lambda: self.sim_time_s)
        )
        self.link_down = False  # test hook: a radio outage (nothing sent, everything received is dropped)
        self.log = log  # a line per event (mode change, STATUSTEXT), e.g. print
        self.vision_received = 0
        self.last_vision_m: Vec3 | None = None  # world ENU position of the last VISION_POSITION_ESTIMATE
        self.setpoints_received = 0
        self.acceleration_targets = 0  # acceleration-only targets (masonry's velocity loop on PX4, issue 29)
        self.last_setpoint_mps: Vec3 | None = None  # world ENU velocity of the last accepted setpoint
        self.status_log: list[str] = []
        self.land_requests = 0  # LAND asked by the ground station (MAV_CMD_NAV_LAND or a mode change)
        self._defaults_hz = dict(DEFAULT_RATES_HZ)
        if self.px4:
            self._defaults_hz[MSG_ESTIMATOR_STATUS] = self._defaults_hz.pop(MSG_EKF_STATUS_REPORT)
            del self._defaults_hz[MSG_WIND]
        self._rates_hz = dict(self._defaults_hz)
        self._next_due: dict[int, float] = {}
        self._conn: Any = None
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._lock = threading.Lock()
        self._last_gcs_wall_s: float | None = None
        self._last_vision_sim_s = -math.inf
        from masonry.adapters.sitl_fence import SitlFence

        #: the fence a ground station uploaded, its parameters and its enforcement (masonry.adapters.sitl_fence)
        self.fence = SitlFence(mode=self.config.fence)

    # ------------------------------------------------------------------------------------------- lifecycle

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> None:
        """Open the endpoint and run the simulation in a background thread."""
        mavutil = mavutil_module()
        self._conn = mavutil.mavlink_connection(
            f"udpout:{self.host}:{self.port}",
            source_system=self.config.system_id,
            source_component=self.config.component_id,
        )
        if self.signing_key is not None:
            self._conn.setup_signing(self.signing_key, sign_outgoing=True, allow_unsigned_callback=None)
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="masonry-sitl", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
            self._thread = None
        if self._conn is not None:
            self._conn.close()
            self._conn = None

    def serve_forever(self) -> None:
        """Run in the calling thread until KeyboardInterrupt (the ``masonry sitl`` command)."""
        self.start()
        try:
            while self._thread is not None and self._thread.is_alive():
                self._thread.join(timeout=0.5)
        finally:
            self.stop()

    # ----------------------------------------------------------------------------------------------- loop

    def _run(self) -> None:
        last = time.monotonic()
        next_beat = last
        while not self._stop.is_set():
            now = time.monotonic()
            with self._lock:
                self._drain_input()
                step_s = (now - last) * self.time_scale
                if self.lockstep is None:
                    self._advance(step_s)
                else:  # whole physics steps, to the grant (masonry.adapters.sitl_lockstep)
                    self.lockstep.run(step_s, now)
                last = now
                if not self.link_down:
                    if now >= next_beat:
                        self._send_heartbeat()
                        # until a ground station has answered, beat at 5 Hz so it finds us quickly
                        searching = self._last_gcs_wall_s is None
                        next_beat = now + (0.2 if searching else 1.0 / self.config.heartbeat_hz)
                    if self.lockstep is None or self.lockstep.at_grant():
                        self._send_streams(now)
                    if self.lockstep is not None:
                        self.lockstep.reply()
            (self._stop if self.lockstep is None else self.lockstep).wait(0.004)  # lock-step: or a grant

    def _advance(self, dt_s: float) -> None:
        v = self.vehicle
        while dt_s > 1e-9:
            h = min(self.physics_dt_s, dt_s)
            dt_s -= h
            self.sim_time_s += h
            self._gcs_failsafe()
            was_armed = v.armed
            v.step(h)
            self.fence.enforce(self)
            if v.mode == "LAND" and self.mode != self._land_mode:  # the vehicle's battery failsafe
                self._text(MAV_SEVERITY_CRITICAL, "Battery failsafe: landing")
                self.mode = self._land_mode
            if was_armed and not v.armed:
                self._text(MAV_SEVERITY_INFO, "Land complete, disarming" if v.on_ground else "Motors stopped")
            if self.lockstep is not None:  # the telemetry noise: one sample per step, not per message sent
                self.lockstep.sample()

    def _gcs_failsafe(self) -> None:
        v = self.vehicle
        if (
            v.armed
            and not v.on_ground
            and self._last_gcs_wall_s is not None
            and time.monotonic() - self._last_gcs_wall_s > self.config.gcs_failsafe_s
            and self.mode != self._land_mode
        ):
            self._text(MAV_SEVERITY_CRITICAL, "GCS Failsafe")
            self._set_mode(self._land_mode)
        if (
            self.px4
            and self.mode == "OFFBOARD"
            and v.armed
            and not v.on_ground
            and self._setpoints.silent_for(self.config.offboard_loss_s)
        ):
            self._text(MAV_SEVERITY_CRITICAL, "Offboard setpoints lost: holding position")
            self._set_mode("AUTO.LOITER")

    def _ekf_ok(self) -> bool:
        if self.sim_time_s < self.config.ekf_converge_s:
            return False
        if self.config.position_source == "vision":
            return self.sim_time_s - self._last_vision_sim_s < 0.5
        return True

    # ------------------------------------------------------------------------------------------- receiving

    def _drain_input(self) -> None:
        while True:
            try:
                msg = self._conn.recv_msg()
            except (OSError, ValueError):
                return
            if msg is None:
                return
            if self.link_down:
                continue
            self._handle(msg)

    def _handle(self, msg: Any) -> None:
        if self.lockstep is not None:
            self.lockstep.heard(time.monotonic())
        if self.fence.handle(self, msg):
            return
        kind = msg.get_type()
        if kind == "HEARTBEAT":
            if msg.type == MAV_TYPE_GCS:
                if self._last_gcs_wall_s is None:
                    self._log(f"ground station connected (system {msg.get_srcSystem()})")
                if self.lockstep is not None:  # it takes grants: says so to a client new or back
                    self.lockstep.greet(self._last_gcs_wall_s, time.monotonic())
                self._last_gcs_wall_s = time.monotonic()
        elif kind == "COMMAND_LONG":
            if msg.target_system in (0, self.config.system_id):
                self._command(msg)
        elif kind == "SET_MODE":
            if msg.target_system == self.config.system_id:
                self._set_mode_by_number(int(msg.custom_mode))
        elif kind == "SET_POSITION_TARGET_LOCAL_NED":
            if msg.target_system == self.config.system_id:
                self._position_target(msg)
        elif kind == "SYSTEM_TIME" and self.lockstep is not None:
            self.lockstep.grant(int(msg.time_boot_ms))
        elif kind == "VISION_POSITION_ESTIMATE":
            self.vision_received += 1
            self.last_vision_m = self.frame.position_to_world((msg.x, msg.y, msg.z))
            self._last_vision_sim_s = self.sim_time_s

    def _ack(self, command: int, result: int) -> None:
        if self.lockstep is not None:  # the time it is answered at, heard before the answer (sitl_lockstep)
            self._send_stream(MSG_ATTITUDE)
        self._conn.mav.command_ack_send(command, result)

    def _log(self, text: str) -> None:
        if self.log is not None:
            self.log(f"{self.sim_time_s:9.2f} s  {text}")

    def _text(self, severity: int, text: str) -> None:
        self.status_log.append(text)
        self._log(text)
        if not self.link_down and self._conn is not None:
            self._conn.mav.statustext_send(severity, text.encode("ascii", errors="replace")[:50])

    def _command(self, msg: Any) -> None:
        cmd = int(msg.command)
        answer = self._COMMANDS.get(cmd)
        if answer is None:
            self._ack(cmd, MAV_RESULT_UNSUPPORTED)
            return
        answer(self, msg, cmd)

    def _arm_disarm(self, msg: Any, cmd: int) -> None:
        v = self.vehicle
        if msg.param1 >= 0.5:
            lost = self.px4 and self.mode == "OFFBOARD" and self._setpoints.stale(self.config.offboard_loss_s)
            if self.sim_time_s < self.config.arm_ready_s or lost:
                if lost:  # (PX4 v1.16 SITL, on an OFFBOARD whose setpoints stopped)
                    self._text(MAV_SEVERITY_WARNING, "Arming denied: Resolve system health failures first")
                self._ack(cmd, MAV_RESULT_TEMPORARILY_REJECTED)
                return
            problem = self._prearm_problem()
            if problem is not None:
                self._text(MAV_SEVERITY_CRITICAL, f"PreArm: {problem}")
                self._ack(cmd, MAV_RESULT_FAILED)
                return
            try:
                v.arm()
            except CommandRejected as exc:
                self._text(MAV_SEVERITY_CRITICAL, f"PreArm: {exc.reason}")
                self._ack(cmd, MAV_RESULT_FAILED)
                return
            # the vehicle model arms into its GUIDED; keep the autopilot's mode
            v.mode = "GUIDED" if self.mode == self._offboard_mode else self.mode
            self._ack(cmd, MAV_RESULT_ACCEPTED)
            self._text(MAV_SEVERITY_INFO, "Arming motors")
        else:
            if not v.on_ground and int(msg.param2) != DISARM_MAGIC:
                self._text(MAV_SEVERITY_CRITICAL, "Disarm: vehicle is flying")
                self._ack(cmd, MAV_RESULT_FAILED)
                return
            v.disarm(force=int(msg.param2) == DISARM_MAGIC)
            self._ack(cmd, MAV_RESULT_ACCEPTED)

    def _takeoff(self, msg: Any, cmd: int) -> None:
        v = self.vehicle
        mode_ok = self.px4 or self.mode == "GUIDED"  # PX4 switches to AUTO.TAKEOFF by itself
        if not mode_ok or not v.armed or not v.on_ground:
            why = "not in GUIDED" if not mode_ok else "not armed" if not v.armed else "already flying"
            self._text(MAV_SEVERITY_WARNING, f"Takeoff: {why}")
            self._ack(cmd, MAV_RESULT_FAILED)
            return
        try:
            v.takeoff(float(msg.param7))  # NAV_TAKEOFF altitude: above home (the ground it stands on)
        except CommandRejected as exc:
            self._text(MAV_SEVERITY_WARNING, f"Takeoff: {exc.reason}")
            self._ack(cmd, MAV_RESULT_FAILED)
            return
        if self.px4:
            self.mode = "AUTO.TAKEOFF"
        self._log(f"takeoff to {float(msg.param7):.2f} m")
        self._ack(cmd, MAV_RESULT_ACCEPTED)

    def _land(self, msg: Any, cmd: int) -> None:
        self.land_requests += 1
        self._set_mode(self._land_mode)
        self._ack(cmd, MAV_RESULT_ACCEPTED)

    def _do_set_mode(self, msg: Any, cmd: int) -> None:
        if self.px4:  # param2 main mode, param3 sub mode
            result = self._set_mode_by_number((int(msg.param2) << 16) | (int(msg.param3) << 24))
        else:
            result = self._set_mode_by_number(int(msg.param2))
        self._ack(cmd, result)

    def _set_message_interval(self, msg: Any, cmd: int) -> None:
        msg_id, interval_us = int(msg.param1), float(msg.param2)
        if msg_id not in self._defaults_hz and msg_id != MSG_HEARTBEAT:
            self._ack(cmd, MAV_RESULT_DENIED)
            return
        if msg_id == MSG_HEARTBEAT:
            self._ack(cmd, MAV_RESULT_ACCEPTED)  # heartbeat stays at 1 Hz, as on ArduPilot
            return
        if interval_us < 0:
            self._rates_hz[msg_id] = 0.0
        elif interval_us == 0:
            self._rates_hz[msg_id] = self._defaults_hz[msg_id]
        else:
            self._rates_hz[msg_id] = min(100.0, 1e6 / interval_us)
        self._next_due.pop(msg_id, None)  # the new rate starts now
        self._ack(cmd, MAV_RESULT_ACCEPTED)

    #: The COMMAND_LONG commands the SITL answers, one method each; any other gets MAV_RESULT_UNSUPPORTED.
    _COMMANDS: ClassVar[dict[int, Callable[[MavlinkSitl, Any, int], None]]] = {
        MAV_CMD_COMPONENT_ARM_DISARM: _arm_disarm,
        MAV_CMD_NAV_TAKEOFF: _takeoff,
        MAV_CMD_NAV_LAND: _land,
        MAV_CMD_DO_SET_MODE: _do_set_mode,
        MAV_CMD_SET_MESSAGE_INTERVAL: _set_message_interval,
    }

    def _prearm_problem(self) -> str | None:
        if self.config.prearm_failure:
            return self.config.prearm_failure
        if not self._ekf_ok():
            return "Need Position Estimate"
        return None  # battery and the vehicle's own checks: SimVehicle.arm()

    def _set_mode_by_number(self, custom_mode: int) -> int:  # the MAV_RESULT to acknowledge it with
        for name, number in self._modes.items():
            if number == custom_mode:
                if name == self._offboard_mode and not self._ekf_ok():
                    self._text(MAV_SEVERITY_WARNING, f"Mode change to {name} failed: requires position")
                    return MAV_RESULT_FAILED
                if (
                    name == "OFFBOARD"
                    and self.vehicle.armed
                    and self._setpoints.stale(self.config.offboard_loss_s)
                ):
                    # PX4 v1.16 armed (disarmed: accepted, the arming refused instead): masonry.adapters.sitl_offboard
                    self._text(MAV_SEVERITY_WARNING, "Switching to Offboard is not possible: no setpoints")
                    return MAV_RESULT_TEMPORARILY_REJECTED
                if name == self._land_mode:
                    self.land_requests += 1
                self._set_mode(name)
                return MAV_RESULT_ACCEPTED
        self._text(MAV_SEVERITY_WARNING, f"Mode change to {custom_mode} failed: unknown mode")
        return MAV_RESULT_FAILED

    def pilot_mode(self, name: str) -> None:
        """The safety pilot flips the RC mode switch: the autopilot enters ``name`` (no ground station involved)."""
        if name not in self._modes:
            raise ValueError(
                f"unknown {self.config.autopilot} mode {name!r}; known: {', '.join(self._modes)}"
            )
        with self._lock:
            self._log(f"pilot selects {name}")
            self._set_mode(name)

    def _set_mode(self, name: str) -> None:
        if name != self.mode:
            self._log(f"mode {name}")
        self.mode = name
        v = self.vehicle
        if name == self._land_mode:
            v.land()
        elif v.mode != "FAILED":
            # the vehicle model follows setpoints in its GUIDED; the other modes hold where it is (no pilot here)
            v.mode = "GUIDED" if name == self._offboard_mode else name

    def _position_target(self, msg: Any) -> None:
        if (
            msg.coordinate_frame != MAV_FRAME_LOCAL_NED
            or msg.type_mask & VELOCITY_ONLY_IGNORED != VELOCITY_ONLY_IGNORED
        ):
            return  # position targets and other frames are not modelled
        self._setpoints.heard()
        vehicle = self.vehicle
        if (
            self.lockstep is not None
            and self.lockstep.same_setpoint(msg)
            and self.last_setpoint_mps is not None
        ):
            v_world = self.last_setpoint_mps  # the client's stream repeating it: refreshed, not re-applied
        elif (
            msg.type_mask & VELOCITY_IGNORED == VELOCITY_IGNORED
        ):  # acceleration (PX4, issue 29): the velocity
            a = self.frame.velocity_to_world((msg.afx, msg.afy, msg.afz))  # that reaches it through the lag
            tau_s, v_now = vehicle.config.velocity_tau_s, vehicle.velocity_mps
            v_world = (v_now[0] + a[0] * tau_s, v_now[1] + a[1] * tau_s, v_now[2] + a[2] * tau_s)
            self.acceleration_targets += 1
        else:
            v_world = self.frame.velocity_to_world((msg.vx, msg.vy, msg.vz))
        if self.px4 and self.mode == "OFFBOARD" and vehicle.armed and vehicle.on_ground and v_world[2] > 0.05:
            vehicle.takeoff(0.2)  # PX4 lifts off on an upward offboard velocity; setpoints rule once airborne
        if self.mode != self._offboard_mode or not vehicle.armed or vehicle.on_ground:
            return
        self.setpoints_received += 1
        yaw_rate = 0.0 if msg.type_mask & 2048 else FrameTransform.yaw_rate_to_world(msg.yaw_rate)
        self.vehicle.command_velocity(v_world, yaw_rate, self.vehicle.time_s)
        self.last_setpoint_mps = v_world

    # --------------------------------------------------------------------------------------------- sending

    def _send_heartbeat(self) -> None:
        v = self.vehicle
        base = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | (MAV_MODE_FLAG_SAFETY_ARMED if v.armed else 0)
        self._conn.mav.heartbeat_send(
            MAV_TYPE_QUADROTOR,
            MAV_AUTOPILOT_PX4 if self.px4 else MAV_AUTOPILOT_ARDUPILOTMEGA,
            base,
            self._modes[self.mode],
            MAV_STATE_ACTIVE if v.armed else MAV_STATE_STANDBY,
        )

    def _send_streams(self, now: float) -> None:
        for msg_id, rate_hz in self._rates_hz.items():
            if rate_hz <= 0.0:
                continue
            due = self._next_due.get(msg_id, now)
            if now < due:
                continue
            self._next_due[msg_id] = max(due + 1.0 / rate_hz, now)
            self._send_stream(msg_id)

    _send_stream = send_stream  # one message of a stream, now (masonry.adapters.sitl_streams)
