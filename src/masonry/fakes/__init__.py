"""Scripted fakes for every port in :mod:`masonry.ports`: drive a state machine through any scenario without hardware.

Each fake is small, deterministic and honest about failures: a command it cannot carry out raises the same
typed error a real adapter would (:class:`~masonry.errors.CommandRejected`, :class:`~masonry.errors.LinkLost`,
:class:`~masonry.errors.HardwareError`). Faults are scripted in simulated time with ``fake.at(time_s, **changes)``:
at ``time_s`` the named attributes take the given values (for example ``fc.at(30.0, link_ok=False)``).

- :class:`FakeClock`: a clock that advances only when told.
- :class:`FakeFlightController`: an ideal multirotor (first-order velocity lag, takeoff, land, ground, battery)
  integrated lazily up to the clock's time whenever it is asked something.
- :class:`FakeGripper`, :class:`FakeSprayer`: actuators that record what they were told.
- :class:`FakeCamera`: marker observations of static bricks computed from the flight controller's pose.
- :class:`QueueMissionLink`: tasks from a queue in, progress and results collected.
- :class:`ScriptedClearanceLink`: a QueueMissionLink whose airspace answers (and grants) after scripted delays.

Example (a notebook)::

    clock = FakeClock()
    fc = FakeFlightController(clock)
    fc.arm(); fc.takeoff(1.2)
    clock.advance(5.0)
    fc.telemetry().position_m   # (0.0, 0.0, 1.2)
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from masonry.airframe import DEFAULT_AIRFRAME, camera_mount
from masonry.blueprint import MarkerSpec
from masonry.errors import CommandRejected, CommandTimeout, HardwareError, InvalidArgument, LinkLost
from masonry.fakes.link import FakeClearance as FakeClearance
from masonry.fakes.link import QueueMissionLink as QueueMissionLink
from masonry.fakes.link import ScriptedClearanceLink as ScriptedClearanceLink
from masonry.geometry import R_world_body
from masonry.perception.types import DEFAULT_INTRINSICS, CameraIntrinsics, TagPose
from masonry.ports import CameraFrame, Clock, Telemetry

Vec3 = tuple[float, float, float]


class _Scripted:
    """Mixin: ``at(time_s, **changes)`` sets attributes when the fake's time passes ``time_s``."""

    _script: list[tuple[float, int, dict[str, Any]]]

    def _init_script(self) -> None:
        self._script = []
        self._script_seq = 0

    def at(self, time_s: float, **changes: Any) -> None:
        """At simulated time ``time_s`` set each named attribute to its value (unknown names raise)."""
        for key in changes:
            if not hasattr(self, key):
                raise AttributeError(f"{type(self).__name__} has no attribute {key!r} to script")
        self._script.append((float(time_s), self._script_seq, dict(changes)))
        self._script_seq += 1
        self._script.sort(key=lambda item: (item[0], item[1]))

    def _next_event_s(self) -> float:
        return self._script[0][0] if self._script else math.inf

    def _apply_due(self, now_s: float) -> None:
        while self._script and self._script[0][0] <= now_s:
            _, _, changes = self._script.pop(0)
            for key, value in changes.items():
                setattr(self, key, value)
            self._on_scripted(changes)

    def _on_scripted(self, changes: dict[str, Any]) -> None:
        """Hook for a fake to react to a scripted change."""


class FakeClock:
    """A clock that advances only when told: ``sleep`` and ``advance`` move it forward."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._now_s = float(start_s)

    def now_s(self) -> float:
        return self._now_s

    def sleep(self, duration_s: float) -> None:
        self.advance(duration_s)

    def advance(self, duration_s: float) -> None:
        if duration_s < 0.0:
            raise InvalidArgument(f"cannot advance a clock by a negative duration ({duration_s} s)")
        self._now_s += duration_s


class FakeFlightController(_Scripted):
    """An ideal multirotor behind the FlightController port, integrated lazily on the injected clock.

    The autopilot's velocity loop is a first-order lag (``velocity_time_constant_s``) with a speed limit; a
    constant ``wind_mps`` adds to the commanded velocity; ``floor_z_m`` is the lowest the vehicle can go (the
    ground, or something in the way when scripted higher). ``takeoff`` climbs vertically at
    ``climb_rate_mps``; ``land`` descends at ``land_rate_mps`` and disarms on touchdown. A velocity setpoint
    older than ``command_timeout_s`` is dropped (the vehicle hovers), like ArduPilot's guided timeout.

    Scriptable faults (``fc.at(t, ...)``): ``link_ok=False`` (commands raise LinkLost, the autopilot lands by
    itself), ``failure="motor failure"`` (every call raises HardwareError, the vehicle falls),
    ``battery_fraction``, ``battery_drain_per_s``, ``floor_z_m``, ``wind_mps``, ``arm_rejection``,
    ``land_failures=N`` (the next N ``land()`` calls go unanswered: CommandTimeout), ``mode="LOITER"`` (a pilot's
    mode switch: the vehicle holds where it is; ``mode="LAND"`` lands it).

    Why a physics of its own and not a layer over :class:`~masonry.sim.vehicle.SimVehicle`: this fake is the
    scripted one, whose few knobs (a lag, a speed limit, a climb and a land rate, a constant wind, a floor) a
    test sets to make a scenario exact, and whose faults (a failure that makes every call raise, a pilot's
    mode switch, unanswered LANDs, rejected arming) the simulated autopilot does not have; ``SimVehicle`` is
    the simulator's autopilot, with failsafes, gusts, acceleration limits and noise, bit-identical for the
    pinned missions. The two agree where a state machine can tell: both run the one FlightController
    contract suite (``tests/test_flight_contract.py``), with the MAVLink adapter on the SITL, so a
    difference there fails a test (e.g. velocity setpoints are ignored on the ground by all of them).
    """

    def __init__(
        self,
        clock: Clock,
        *,
        position_m: Vec3 = (0.0, 0.0, 0.0),
        yaw_rad: float = 0.0,
        ground_z_m: float = 0.0,
        battery_fraction: float = 1.0,
        battery_drain_per_s: float = 0.0,
        velocity_time_constant_s: float = 0.15,
        max_speed_mps: float = 2.0,
        climb_rate_mps: float = 0.6,
        land_rate_mps: float = 0.5,
        command_timeout_s: float = 3.0,
        arm_rejection: str | None = None,
        position_ok: bool = True,
    ) -> None:
        self._init_script()
        self.clock = clock
        self.ground_z_m = float(ground_z_m)
        self.floor_z_m = float(ground_z_m)
        self.battery_fraction = float(battery_fraction)
        self.battery_drain_per_s = float(battery_drain_per_s)
        self.velocity_time_constant_s = float(velocity_time_constant_s)
        self.max_speed_mps = float(max_speed_mps)
        self.climb_rate_mps = float(climb_rate_mps)
        self.land_rate_mps = float(land_rate_mps)
        self.command_timeout_s = float(command_timeout_s)
        self.arm_rejection = arm_rejection
        self.land_failures = 0
        self.position_ok = position_ok
        self.link_ok = True
        self.failure: str | None = None
        self.wind_mps: Vec3 = (0.0, 0.0, 0.0)
        self.connected = False
        self.armed = False
        self.mode = "STABILIZE"
        self.commands: list[tuple[float, str, tuple[Any, ...]]] = []  # every command but velocity setpoints
        self.velocity_commands = 0
        self._pos = np.array(position_m, dtype=float)
        self._vel = np.zeros(3)
        self._yaw = float(yaw_rad)
        self._cmd_vel = np.zeros(3)
        self._cmd_yaw_rate = 0.0
        self._cmd_time_s = -math.inf
        self._takeoff_z_m: float | None = None
        self._t_s = clock.now_s()

    # -- dynamics ---------------------------------------------------------------------------------------
    @property
    def on_ground(self) -> bool:
        return bool(self._pos[2] <= self.ground_z_m + 1e-3 and self._vel[2] <= 1e-6)

    @property
    def position_m(self) -> Vec3:
        """True position (no link needed): for tests and fakes that observe the vehicle."""
        self._advance()
        return (float(self._pos[0]), float(self._pos[1]), float(self._pos[2]))

    @property
    def yaw_rad(self) -> float:
        self._advance()
        return self._yaw

    def _on_scripted(self, changes: dict[str, Any]) -> None:
        if changes.get("link_ok") is False and self.armed and not self.on_ground:
            self.mode = "LAND"  # the autopilot's own failsafe
        if changes.get("failure"):
            self.mode = "FAILED"

    def _advance(self) -> None:
        now_s = self.clock.now_s()
        while self._t_s < now_s:
            t_next = min(now_s, self._next_event_s(), self._t_s + 0.02)
            if t_next > self._t_s:
                self._integrate(t_next - self._t_s)
                self._t_s = t_next
            self._apply_due(self._t_s)
        self._apply_due(self._t_s)

    def _integrate(self, dt_s: float) -> None:
        cmd_yaw_rate = 0.0
        if self.failure is not None:
            cmd = np.array([0.0, 0.0, -3.0])
        elif not self.armed:
            cmd = np.zeros(3)
        elif self.mode == "LAND":
            cmd = np.array([0.0, 0.0, -self.land_rate_mps])
        elif self._takeoff_z_m is not None:
            error = self._takeoff_z_m - self._pos[2]
            cmd = np.array([0.0, 0.0, min(self.climb_rate_mps, max(-self.climb_rate_mps, 1.5 * error))])
            if abs(error) < 0.02 and abs(self._vel[2]) < 0.05:
                self._takeoff_z_m = None
        elif self.mode != "GUIDED":
            cmd = np.zeros(3)  # a pilot's mode (LOITER...): setpoints are ignored, the vehicle holds
        elif self._t_s - self._cmd_time_s <= self.command_timeout_s:
            cmd = self._cmd_vel + np.asarray(self.wind_mps)
            cmd_yaw_rate = self._cmd_yaw_rate
        else:
            cmd = np.asarray(self.wind_mps, dtype=float).copy()
        speed = float(np.linalg.norm(cmd))
        if speed > self.max_speed_mps:
            cmd = cmd * (self.max_speed_mps / speed)
        tau = self.velocity_time_constant_s
        alpha = 1.0 if tau <= 0.0 else 1.0 - math.exp(-dt_s / tau)
        self._vel += alpha * (cmd - self._vel)
        self._pos += self._vel * dt_s
        floor = max(self.floor_z_m, self.ground_z_m)
        if self._pos[2] <= floor:
            self._pos[2] = floor
            self._vel[2] = max(self._vel[2], 0.0)
            if floor <= self.ground_z_m + 1e-9:
                self._vel[:2] = 0.0  # ground contact: no sliding
        self._yaw = (self._yaw + cmd_yaw_rate * dt_s + math.pi) % (2.0 * math.pi) - math.pi
        if self.armed:
            self.battery_fraction = max(0.0, self.battery_fraction - self.battery_drain_per_s * dt_s)
        if self.armed and self.mode in ("LAND", "FAILED") and self.on_ground:
            self.armed = False
            self.mode = "LAND"

    # -- the port -------------------------------------------------------------------------------------------
    def _check(self, command: str) -> None:
        self._advance()
        if self.failure is not None:
            raise HardwareError(f"flight controller: {self.failure}")
        if not self.link_ok:
            raise LinkLost(f"flight controller link lost ({command} not sent)")

    def _log(self, command: str, *args: Any) -> None:
        self.commands.append((self._t_s, command, args))

    def connect(self) -> None:
        self.connected = True
        self._log("connect")

    def close(self) -> None:
        self.connected = False
        self._log("close")

    def arm(self) -> None:
        self._check("arm")
        if self.arm_rejection:
            raise CommandRejected("arm", self.arm_rejection)
        if not self.position_ok:
            raise CommandRejected("arm", "no position estimate")
        self.armed = True
        self.mode = "GUIDED"
        self._log("arm")

    def disarm(self) -> None:
        self._check("disarm")
        if self.armed and not self.on_ground:
            raise CommandRejected("disarm", "vehicle is airborne")
        self.armed = False
        self._log("disarm")

    def takeoff(self, altitude_m: float, timeout_s: float | None = None) -> None:
        """Climb on its own to ``altitude_m`` above where it stands (``timeout_s``: the caller's, not needed)."""
        self._check("takeoff")
        if not self.armed:
            raise CommandRejected("takeoff", "not armed")
        self.mode = "GUIDED"
        self._takeoff_z_m = float(self._pos[2]) + float(altitude_m)
        self._log("takeoff", altitude_m)

    def land(self) -> None:
        self._check("land")
        if self.land_failures > 0:
            self.land_failures -= 1
            self._log("land", "unanswered")
            raise CommandTimeout("land: no answer from the autopilot")
        self.mode = "LAND"
        self._takeoff_z_m = None
        self._log("land")

    def send_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float) -> None:
        self._check("velocity")
        if not self.armed:
            raise CommandRejected("velocity", "not armed")
        if self.mode == "LAND":
            raise CommandRejected("velocity", "vehicle is landing")
        self.velocity_commands += 1
        if self.on_ground:
            return  # ignored on the ground, as by ArduPilot (only takeoff lifts it): the FlightController contract
        self._takeoff_z_m = None  # a new guided command replaces a takeoff in progress
        self._cmd_vel[0], self._cmd_vel[1], self._cmd_vel[2] = velocity_mps
        self._cmd_yaw_rate = float(yaw_rate_radps)
        self._cmd_time_s = self._t_s

    def telemetry(self) -> Telemetry:
        self._advance()
        if self.failure is not None:
            raise HardwareError(f"flight controller: {self.failure}")
        p, v = self._pos, self._vel
        return Telemetry(
            time_s=self._t_s,
            position_m=(float(p[0]), float(p[1]), float(p[2])),
            velocity_mps=(float(v[0]), float(v[1]), float(v[2])),
            attitude_rad=(0.0, 0.0, self._yaw),
            armed=self.armed,
            mode=self.mode,
            battery_fraction=self.battery_fraction,
            link_ok=self.link_ok,
            position_ok=self.position_ok,
            on_ground=self.on_ground,
            landing=self.mode == "LAND",
        )


class FakeGripper(_Scripted):
    """Electromagnet on a lockable ball joint, with scripted grasp failures.

    The brick attaches while the magnet is on and ``contact()`` is true (always true when no ``contact`` is
    given), except for the first ``failures`` grasp attempts (an attempt = switching the magnet on).
    ``stuck_releases`` makes that many "magnet off" commands fail to let go (remanent magnetism).
    """

    def __init__(
        self,
        *,
        contact: Callable[[], bool] | None = None,
        failures: int = 0,
        stuck_releases: int = 0,
        clock: Clock | None = None,
    ) -> None:
        self._init_script()
        self.contact = contact
        self.failures = int(failures)
        self.stuck_releases = int(stuck_releases)
        self.clock = clock
        self.magnet_on = False
        self.joint_locked = True
        self.attached = False
        self.attempts = 0
        self.commands: list[tuple[str, bool]] = []
        self.release_due_s: float | None = None  # a timed release not yet due (``release_at``)
        self.released_s: list[float] = []  # the clock's time at each timed release done

    def _tick(self) -> None:
        if self.clock is not None:
            now_s = self.clock.now_s()
            self._apply_due(now_s)
            if self.release_due_s is not None and now_s >= self.release_due_s:
                self.released_s.append(now_s)
                self.release_due_s = None
                self._magnet(False)

    def set_magnet(self, on: bool) -> None:
        self._tick()
        self.release_due_s = None
        self._magnet(on)

    def _magnet(self, on: bool) -> None:
        self.commands.append(("magnet", bool(on)))
        if on and not self.magnet_on:
            self.attempts += 1
        if not on:
            if self.attached and self.stuck_releases > 0:
                self.stuck_releases -= 1
            else:
                self.attached = False
        self.magnet_on = bool(on)

    def release_at(self, at_s: float) -> bool:
        """With a clock, the magnet goes off at the first call at or after ``at_s``; without one, now (False)."""
        if self.clock is None:
            self.set_magnet(False)
            return False
        self.release_due_s = float(at_s)
        self._tick()
        return True

    def can_time_release(self) -> bool:
        """With a clock (:meth:`release_at` times it then)."""
        return self.clock is not None

    def set_joint_locked(self, locked: bool) -> None:
        self._tick()
        self.commands.append(("joint_locked", bool(locked)))
        self.joint_locked = bool(locked)

    def is_attached(self) -> bool:
        self._tick()
        if (
            self.magnet_on
            and not self.attached
            and self.attempts > self.failures
            and (self.contact is None or self.contact())
        ):
            self.attached = True
        return self.attached


class FakeSprayer:
    """The adhesive valve; records when it was open (``intervals``) when given a clock."""

    def __init__(self, clock: Clock | None = None, *, open_rejection: str | None = None) -> None:
        self.clock = clock
        self.open_rejection = open_rejection
        self.valve_open = False
        self.commands: list[bool] = []
        self.intervals: list[tuple[float, float]] = []
        self._opened_s: float | None = None

    def set_valve(self, open_: bool) -> None:
        if open_ and self.open_rejection:
            raise CommandRejected("valve open", self.open_rejection)
        self.commands.append(bool(open_))
        now_s = self.clock.now_s() if self.clock is not None else 0.0
        if open_ and not self.valve_open:
            self._opened_s = now_s
        if not open_ and self.valve_open and self._opened_s is not None:
            self.intervals.append((self._opened_s, now_s))
            self._opened_s = None
        self.valve_open = bool(open_)

    def is_valve_open(self) -> bool:
        return self.valve_open


@dataclass(frozen=True)
class FakeBrick:
    """A static brick the fake camera can see: top-face centre (world) and yaw."""

    brick_id: int
    top_center_m: Vec3
    yaw_rad: float = 0.0


class FakeCamera(_Scripted):
    """Downward camera on a fake flight controller: marker poses of static bricks, as the camera would measure.

    Markers 2k (at +spacing/2 along the brick's +x) and 2k+1 lie on brick k's top face, their frame aligned
    with the brick (x along the brick's +x, z up). A marker is seen when its centre is in front of the camera
    and projects at least half a marker inside the image. Knobs (scriptable with ``at``): ``noise_sigma_m``
    (Gaussian, per axis in the camera frame), ``yaw_noise_sigma_rad``, ``dropout`` (probability a frame is
    empty), ``hidden`` (marker ids never seen), ``blind`` (no frames at all). One frame per ``1/rate_hz``.
    """

    def __init__(
        self,
        fc: FakeFlightController,
        bricks: Iterable[FakeBrick] = (),
        *,
        markers: MarkerSpec | None = None,
        intrinsics: CameraIntrinsics = DEFAULT_INTRINSICS,
        T_body_cam: np.ndarray | None = None,
        noise_sigma_m: float = 0.0,
        yaw_noise_sigma_rad: float = 0.0,
        dropout: float = 0.0,
        hidden: frozenset[int] = frozenset(),
        blind: bool = False,
        rate_hz: float = 30.0,
        seed: int = 0,
    ) -> None:
        self._init_script()
        self.fc = fc
        self.bricks = list(bricks)
        self.markers = markers if markers is not None else MarkerSpec()
        self._intrinsics = intrinsics
        self._T_body_cam = (
            camera_mount(DEFAULT_AIRFRAME.camera_offset_m) if T_body_cam is None else T_body_cam
        )
        self.noise_sigma_m = float(noise_sigma_m)
        self.yaw_noise_sigma_rad = float(yaw_noise_sigma_rad)
        self.dropout = float(dropout)
        self.hidden = frozenset(hidden)
        self.blind = bool(blind)
        self.rate_hz = float(rate_hz)
        self.frames_read = 0
        self._rng = np.random.default_rng(seed)
        self._last_frame_s = -math.inf

    @property
    def intrinsics(self) -> CameraIntrinsics:
        return self._intrinsics

    @property
    def T_body_cam(self) -> np.ndarray:
        return self._T_body_cam

    def T_world_cam(self) -> np.ndarray:
        """The camera's true pose in the world (from the fake flight controller's true pose)."""
        T_world_body = np.eye(4)
        T_world_body[:3, :3] = R_world_body(0.0, 0.0, self.fc.yaw_rad)
        T_world_body[:3, 3] = self.fc.position_m
        T_world_cam: np.ndarray = T_world_body @ self._T_body_cam
        return T_world_cam

    def read(self) -> CameraFrame | None:
        now_s = self.fc.clock.now_s()
        self._apply_due(now_s)
        if self.blind or now_s - self._last_frame_s < 1.0 / self.rate_hz - 1e-9:
            return None
        self._last_frame_s = now_s
        self.frames_read += 1
        if self.dropout > 0.0 and self._rng.random() < self.dropout:
            return CameraFrame(time_s=now_s, tags=())
        return CameraFrame(time_s=now_s, tags=tuple(self._observe()))

    def _observe(self) -> list[TagPose]:
        T_wc = self.T_world_cam()
        R_cw = T_wc[:3, :3].T
        t_wc = T_wc[:3, 3]
        k = self._intrinsics
        half_px = 0.5 * self.markers.size_m * k.fx
        tags: list[TagPose] = []
        for brick in self.bricks:
            c, s = math.cos(brick.yaw_rad), math.sin(brick.yaw_rad)
            R_wm = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            top = np.asarray(brick.top_center_m, dtype=float)
            for marker_id, sign in ((2 * brick.brick_id, 1.0), (2 * brick.brick_id + 1, -1.0)):
                if marker_id in self.hidden:
                    continue
                p_world = top + R_wm[:, 0] * (sign * self.markers.spacing_m / 2.0)
                p_cam = R_cw @ (p_world - t_wc)
                if p_cam[2] < 0.05:
                    continue
                u = k.fx * p_cam[0] / p_cam[2] + k.cx
                v = k.fy * p_cam[1] / p_cam[2] + k.cy
                margin = half_px / p_cam[2]
                if not (margin <= u <= k.width_px - margin and margin <= v <= k.height_px - margin):
                    continue
                R_cm = R_cw @ R_wm
                if self.noise_sigma_m > 0.0:
                    p_cam = p_cam + self._rng.normal(0.0, self.noise_sigma_m, 3)
                if self.yaw_noise_sigma_rad > 0.0:
                    a = self._rng.normal(0.0, self.yaw_noise_sigma_rad)
                    ca, sa = math.cos(a), math.sin(a)
                    R_cm = R_cm @ np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
                tags.append(TagPose(marker_id=marker_id, position_m=p_cam, R_cam_marker=R_cm))
        return tags
