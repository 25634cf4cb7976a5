"""The UAV's navigator: route legs and their references, turned into a velocity setpoint each tick (no ports).

A :class:`Navigator` holds the motion in hand: a hover point, a minimum-jerk leg (``masonry.motion.MinJerk``)
with the legs still to fly after it, or a constant-speed line (a bead of adhesive). ``step(now_s, telemetry)``
evaluates the reference and the position PID (paper, Section IV "UAV Control": the reference velocity, plus its
acceleration times the autopilot's velocity lag, as feed-forward) and returns the setpoint; the model sends it.
Everything here is pure: the model asks, the navigator answers, only the model talks to the flight controller.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any, NamedTuple

import numpy as np

from masonry.fsm.config import UavConfig
from masonry.fsm.fence import clamp_reference
from masonry.geometry import wrap_angle_rad
from masonry.motion import PID, MinJerk
from masonry.ports import Telemetry
from masonry.timing import MIN_JERK_PEAK_TO_MEAN_SPEED, MIN_LEG_S

Vec3 = tuple[float, float, float]
Leg = tuple[np.ndarray, "float | None"]  # end point, duration (None: from the distance and the speeds)

_ZERO3 = np.zeros(3)
_ZERO3.flags.writeable = False
_ZERO_FF = (0.0, 0.0, 0.0)  # no velocity feed-forward, as plain floats for the PID
#: A UAV this close to the end of its leg (or takeoff) when it stops (to ask for a transit) hovers at that end.
END_NEAR_M = 0.15
#: Legs and layer moves shorter than this are not flown (a corner this close is where the UAV is).
_SAME_M = 0.05


#: A rest-to-rest minimum-jerk leg of d metres over T seconds: its jerk peaks at 60 d / T^3 (at both ends), its
#: acceleration at 10 / sqrt(3) d / T^2.
MIN_JERK_PEAK_JERK = 60.0
MIN_JERK_PEAK_ACCEL = 10.0 / math.sqrt(3.0)


#: ``tuple.__new__``: builds a :class:`Setpoint` from its two fields (the navigator's, every control tick)
_new_tuple = tuple.__new__


class Setpoint(NamedTuple):
    """What the navigator asks of the flight controller for one tick (world ENU)."""

    velocity_mps: Vec3
    yaw_rate_radps: float


class Navigator:
    """Route legs and trajectory evaluation for one UAV (world ENU, SI units).

    Attributes:
        active: a motion (hover, leg or line) is in hand: ``step`` has a setpoint.
        target_m: where the current motion ends (or the hover point).
        target_yaw_rad: the heading held (None: none).
        traj: the current minimum-jerk leg, or None (a hover or a line).
        end_s: when the current leg (or line) ends by plan; a hover's start.
        legs: the legs still to fly after the current one.
        legs_from_rest: those legs start from rest (a layer route turns its corners where the UAV is).
        settling_since_s: when the hover at the end of the current leg began waiting to settle (None: not yet).
    """

    def __init__(self, config: UavConfig) -> None:
        self.config = config
        self.pid = PID(config.pid_gains)
        self.velocity_lag_s = float(config.velocity_lag_s)
        self.leg_lag_s = self.velocity_lag_s  # the leg in hand's (fly_to's lag_s)
        self.active = False
        self.target_m = np.zeros(3)
        self.target_yaw_rad: float | None = None
        self.traj: MinJerk | None = None
        self._traj_end: tuple[MinJerk, Vec3] | None = (
            None  # the leg's end sample, and of which leg (reference)
        )
        self.line: tuple[np.ndarray, np.ndarray, float] | None = None  # start, unit direction, length
        self.line_speed_mps = 0.0
        #: a reference the model sets every tick (position, velocity feed-forward): :meth:`steer`
        self.steered: tuple[Vec3, Vec3] | None = None
        self.t0_s = 0.0
        self.end_s = 0.0
        self.legs: list[Leg] = []
        self.legs_from_rest = False
        self.settling_since_s: float | None = None
        #: the site's fence (None: none): targets and references are kept inside it (``masonry.fsm.fence``)
        self.fence = config.fence
        self._shift_m: tuple[float, float, float] | None = (
            None  # added to the leg's reference (:meth:`shift`)
        )

    def _inside(self, p_m: Any) -> np.ndarray:
        """``p_m`` (a target) kept inside the fence."""
        p, clamped = clamp_reference(self.fence, p_m)
        return np.array(p, dtype=float) if clamped or not isinstance(p, np.ndarray) else p

    # -- what to fly -------------------------------------------------------------------------------------
    def shift(self, delta_m: Sequence[float] | np.ndarray) -> None:
        """Move the motion in hand, its reference and its end, by ``delta_m``: the point it flies to moved (the
        brick as the camera sees it now, :mod:`masonry.fsm.camera_align`); its timing stays."""
        d = (float(delta_m[0]), float(delta_m[1]), float(delta_m[2]))
        self.target_m = np.asarray(self.target_m, dtype=float) + np.array(d)
        if self.traj is not None:
            s = self._shift_m or (0.0, 0.0, 0.0)
            self._shift_m = (s[0] + d[0], s[1] + d[1], s[2] + d[2])

    def stop(self) -> None:
        """No motion: ``step`` has nothing to say."""
        self.active = False
        self.traj = None
        self.line = None
        self.steered = None
        self.legs = []

    def hold(self, now_s: float, tel: Telemetry, target_m: Any = None, yaw_rad: float | None = None) -> None:
        """Hover at ``target_m`` (default: where the UAV is) with the given yaw (default: keep it)."""
        if not self.active:
            self.pid.reset()
        self.traj = None
        self.line = None
        self.steered = None
        self.legs = []
        self.end_s = now_s
        self.target_m = self._inside(np.array(tel.position_m if target_m is None else target_m, dtype=float))
        self.target_yaw_rad = tel.attitude_rad[2] if yaw_rad is None else yaw_rad
        self.active = True

    def fly_to(
        self,
        now_s: float,
        tel: Telemetry,
        target_m: Any,
        duration_s: float | None = None,
        yaw_rad: float | None = None,
        from_rest: bool = False,
        lag_s: float | None = None,
        level: bool = False,
    ) -> None:
        """One minimum-jerk leg from the current state (``from_rest``: from rest where the UAV is) to rest at
        ``target_m``; ``lag_s``: its acceleration feed-forward's lag (default: ``velocity_lag_s``); ``level``:
        a lateral leg at a layer, which carries the UAV's horizontal velocity only (:meth:`_start_leg`)."""
        if not self.active:
            self.pid.reset()
        self.legs = []
        self.line = None
        self.steered = None
        self._start_leg(now_s, tel, np.asarray(target_m, dtype=float), duration_s, from_rest, lag_s, level)
        if yaw_rad is not None:
            self.target_yaw_rad = yaw_rad
        elif not self.active:
            self.target_yaw_rad = tel.attitude_rad[2]
        self.active = True

    def fly_line(self, now_s: float, start_m: np.ndarray, end_m: np.ndarray, speed_mps: float) -> None:
        """Track ``start -> end`` at constant ``speed_mps`` (reference starts at ``start`` now)."""
        d = end_m - start_m
        length = float(np.linalg.norm(d))
        self.legs = []
        self.traj = None
        self.steered = None
        self.line = (np.array(start_m, dtype=float), d / max(length, 1e-9), length)
        self.line_speed_mps = speed_mps
        self.t0_s = now_s
        self.end_s = now_s + length / speed_mps
        self.target_m = np.array(end_m, dtype=float)
        self.active = True

    def steer(
        self,
        now_s: float,
        reference_m: Sequence[float] | np.ndarray,
        velocity_mps: Sequence[float],
        end_s: float,
    ) -> None:
        """Fly the reference the caller sets every tick (a spray pass steered by the nozzle,
        :mod:`masonry.fsm.bead`): ``reference_m`` now, moving at ``velocity_mps`` (feed-forward); ``end_s``: when
        the caller expects it to end (its timeouts count from then)."""
        if not self.active:
            self.pid.reset()
        self.legs = []
        self.traj = None
        self.line = None
        ref = (float(reference_m[0]), float(reference_m[1]), float(reference_m[2]))
        self.steered = (ref, (float(velocity_mps[0]), float(velocity_mps[1]), float(velocity_mps[2])))
        self.target_m = self._inside(np.array(ref))
        self.end_s = end_s
        self.active = True

    def route(self, now_s: float, tel: Telemetry, target_m: Any, yaw_rad: float | None = None) -> None:
        """Go to ``target_m`` without an airspace: climbing first if it is higher, descending last if it is
        lower (never diagonal); with a fixed ``config.lateral_altitude_m`` a lateral leg longer than
        ``layer_min_leg_m`` flies at that layer."""
        p = np.asarray(tel.position_m, dtype=float)
        target = np.asarray(target_m, dtype=float)
        self.legs_from_rest = False
        layer = self.config.lateral_altitude_m
        if layer is not None and math.hypot(target[0] - p[0], target[1] - p[1]) > self.config.layer_min_leg_m:
            self.layer_route(now_s, tel, p, target, layer, yaw_rad)
            return
        self.low_route(now_s, tel, p, target, yaw_rad)

    def low_route(
        self,
        now_s: float,
        tel: Telemetry,
        p: np.ndarray,
        target: np.ndarray,
        yaw_rad: float | None,
        from_rest: bool = False,
    ) -> None:
        """Fly :meth:`low_legs` from ``p`` to ``target`` (the first leg ``from_rest``: see :meth:`fly_to`)."""
        legs = self.low_legs(p, target)
        self.fly_to(now_s, tel, legs[0], yaw_rad=yaw_rad, from_rest=from_rest)
        self.legs = [(leg, None) for leg in legs[1:]]

    def layer_route_legs(self, target: np.ndarray, layer: float) -> list[Leg]:
        """The legs of a layer route from the layer on: over ``target`` at ``layer``, then down to it."""
        legs: list[Leg] = [(np.array([target[0], target[1], layer]), None)]
        if abs(target[2] - layer) > _SAME_M:
            v_z = self.config.layer_vertical_speed_mps
            legs.append((target, max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(layer - target[2]) / v_z)))
        return legs

    def layer_route(
        self,
        now_s: float,
        tel: Telemetry,
        p: np.ndarray,
        target: np.ndarray,
        layer: float,
        yaw_rad: float | None,
        lateral_accel_mps2: float | None = None,
    ) -> None:
        """Climb (or descend) to ``layer`` where the UAV is, fly there above ``target`` (within
        ``lateral_accel_mps2``, if given), descend to it."""
        v_z = self.config.layer_vertical_speed_mps
        legs: list[Leg] = []
        if math.hypot(target[0] - p[0], target[1] - p[1]) > _SAME_M:
            over = np.array([target[0], target[1], layer])
            lateral_s = (
                None
                if lateral_accel_mps2 is None
                else self.leg_duration_s(np.array([p[0], p[1], layer]), over, lateral_accel_mps2)
            )
            legs.append((over, lateral_s))
        if abs(target[2] - layer) > _SAME_M:
            legs.append((target, max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(layer - target[2]) / v_z)))
        self.legs_from_rest = True  # legs start from rest: a corner is turned where the UAV is, never cut
        if abs(p[2] - layer) > _SAME_M or not legs:
            self.fly_to(
                now_s,
                tel,
                np.array([p[0], p[1], layer]),
                max(0.5, MIN_JERK_PEAK_TO_MEAN_SPEED * abs(layer - p[2]) / v_z),
                yaw_rad=yaw_rad,
                from_rest=True,
            )
            self.legs = legs
        else:
            self.fly_to(now_s, tel, legs[0][0], legs[0][1], yaw_rad=yaw_rad, from_rest=True)
            self.legs = legs[1:]

    @staticmethod
    def low_legs(p: np.ndarray, target: np.ndarray) -> list[np.ndarray]:
        """Legs from ``p`` to ``target``: climb first if it is higher, descend last if it is lower."""
        if target[2] > p[2] + _SAME_M:
            legs = [np.array([p[0], p[1], target[2]]), target]
        elif target[2] < p[2] - _SAME_M:
            legs = [np.array([target[0], target[1], p[2]]), target]
        else:
            legs = [target]
        return [leg for i, leg in enumerate(legs) if i == len(legs) - 1 or np.linalg.norm(leg - p) > _SAME_M]

    def expect(self, target_m: Sequence[float]) -> None:
        """Where the autopilot takes the UAV by itself (a take-off): the point the machine holds next."""
        self.target_m = np.array([float(target_m[0]), float(target_m[1]), float(target_m[2])])

    def legs_moving(self) -> None:
        """The legs that follow need not start from rest (a route's corners may be cut)."""
        self.legs_from_rest = False

    def begin_settling(self, now_s: float) -> None:
        """The hover at the end of the leg starts waiting to settle now, unless it already does."""
        if self.settling_since_s is None:
            self.settling_since_s = now_s

    def next_leg(self, now_s: float, tel: Telemetry) -> None:
        """Start the next leg of the route (there is one: ``legs``)."""
        target, duration = self.legs.pop(0)
        self._start_leg(now_s, tel, target, duration, from_rest=self.legs_from_rest)

    def wait(self, now_s: float) -> None:
        """Hover on at the end of the leg: its timeout counts from now."""
        self.end_s = now_s

    def leg_duration_s(
        self, start: np.ndarray | Vec3, target: np.ndarray | Vec3, accel_mps2: float | None = None
    ) -> float:
        """A rest-to-rest leg's duration: its peak speed within the cruise and vertical speeds, its jerk and
        acceleration within ``leg_jerk_mps3`` and ``leg_accel_mps2`` (and ``accel_mps2``), at least 1 s."""
        cfg = self.config
        accel = cfg.leg_accel_mps2 if accel_mps2 is None else min(cfg.leg_accel_mps2, accel_mps2)
        d_xy = math.hypot(target[0] - start[0], target[1] - start[1])
        d_z = abs(target[2] - start[2])
        d = math.hypot(d_xy, d_z)
        return max(
            MIN_LEG_S,
            MIN_JERK_PEAK_TO_MEAN_SPEED * max(d_xy / cfg.cruise_speed_mps, d_z / cfg.vertical_speed_mps),
            (MIN_JERK_PEAK_JERK * d / cfg.leg_jerk_mps3) ** (1.0 / 3.0),
            math.sqrt(MIN_JERK_PEAK_ACCEL * d / accel),
        )

    def _start_leg(
        self,
        now_s: float,
        tel: Telemetry,
        target: np.ndarray,
        duration_s: float | None,
        from_rest: bool = False,
        lag_s: float | None = None,
        level: bool = False,
    ) -> None:
        self.leg_lag_s = self.velocity_lag_s if lag_s is None else float(lag_s)
        p = np.asarray(tel.position_m, dtype=float)
        if self.fence is not None:
            target = self._inside(target)
        # from rest: the reference turns the corner where the UAV is (a layer route never cuts diagonally)
        v = _ZERO3 if from_rest else np.asarray(tel.velocity_mps, dtype=float)
        if level and not from_rest:
            # a level leg keeps its altitude: a minimum-jerk leg started with a vertical velocity v_z sags up to
            # ~0.2 v_z T past its end altitude, 0.11 m below a 2.45 m layer for a climb's -0.07 m/s rebound
            # carried into an 8 s leg (bench_layouts --large seed 3256: 0.993 m over the UAV a layer below)
            v = np.array([v[0], v[1], 0.0])
        T = self.leg_duration_s(p, target) if duration_s is None else float(duration_s)
        self.traj = MinJerk(p, v, _ZERO3, target, _ZERO3, _ZERO3, T)
        self._shift_m = None
        self.t0_s = now_s
        self.end_s = now_s + T
        self.target_m = target
        self.settling_since_s = None

    # -- questions (no side effects) -----------------------------------------------------------------------
    def at_end(self, now_s: float, tel: Telemetry, tolerance_m: float | None = None) -> bool:
        """The current leg is over by plan and the UAV is within ``tolerance_m`` of its end, slower than
        ``arrive_speed_mps``; in turbulence both twice that ``align_patience_s`` after the planned end (a gust
        that never lets it come within 8 cm fails the leg only at ``leg_timeout_s``, with the state's reason).
        A ``tolerance_m`` given is the caller's own gate and is not doubled (the spray descent doubles its own)."""
        if now_s < self.end_s:
            return False
        cfg = self.config
        scale = 1.0 if now_s - self.end_s < cfg.align_patience_s else 2.0
        vx, vy, vz = tel.velocity_mps
        speed = cfg.arrive_speed_mps * scale
        if vx * vx + vy * vy + vz * vz > speed * speed:
            return False
        tol = (
            scale * cfg.arrive_tolerance_m if tolerance_m is None else tolerance_m
        )  # a caller's: its own rule
        p = tel.position_m
        t = self.target_m
        if type(t) is np.ndarray:
            t = t.tolist()  # plain floats: the same squares, without a numpy scalar per element
        return (p[0] - t[0]) ** 2 + (p[1] - t[1]) ** 2 + (p[2] - t[2]) ** 2 <= tol * tol

    def yaw_error_rad(self, tel: Telemetry) -> float:
        """How far the heading is from the one held (0 without one)."""
        if self.target_yaw_rad is None:
            return 0.0
        return abs(wrap_angle_rad(self.target_yaw_rad - tel.attitude_rad[2]))

    def stop_point_m(self, tel: Telemetry) -> np.ndarray:
        """Where the UAV comes to rest when it stops (to ask for a transit): its current leg's end or on the way.

        Near the end of its leg or takeoff (within ``END_NEAR_M``; a takeoff is over 0.1 m short, climbing), at
        that end. Stopped mid-flight (it was flying home and got a task), on along its velocity as far as a
        one-second smooth stop takes it (half a second's flight, a deceleration of at most 1.5 x speed per
        second), never past the leg's end: stopping dead from cruise speed swung it 0.1-0.2 m past the point and
        back, slowly, vertically. Mission control keeps the leg ahead of a UAV for it until it asks (and the
        next metre after: ``STOP_M``).
        """
        p = np.asarray(tel.position_m, dtype=float)
        end = np.asarray(self.target_m, dtype=float)
        to_end = float(np.linalg.norm(end - p))
        if to_end <= END_NEAR_M:
            return end
        v = np.asarray(tel.velocity_mps, dtype=float)
        coast = 0.5 * v  # a 1 s quintic from (p, v) to rest at p + v / 2 decelerates monotonically
        length = float(np.linalg.norm(coast))
        if length > to_end:
            coast *= to_end / length
        return p + coast

    def rests_at(self, tel: Telemetry, point_m: Sequence[float] | np.ndarray, scale: float = 1.0) -> bool:
        """Within ``scale`` x ``ask_settle_tolerance_m`` of ``point_m`` and slower than ``scale`` x
        ``settle_speed_mps``."""
        vx, vy, vz = tel.velocity_mps
        speed = scale * self.config.settle_speed_mps
        if vx * vx + vy * vy + vz * vz > speed * speed:
            return False
        p, t = tel.position_m, point_m
        tol = scale * self.config.ask_settle_tolerance_m
        return (p[0] - t[0]) ** 2 + (p[1] - t[1]) ** 2 + (p[2] - t[2]) ** 2 <= tol * tol

    def settled(self, now_s: float, tel: Telemetry) -> bool:
        """The UAV has come to rest at the end of its leg, waiting since ``settling_since_s`` (started).

        Within ``ask_settle_tolerance_m`` of it and slower than ``settle_speed_mps``; twice both after
        ``align_patience_s``; after twice that time anywhere slower than ``swing_speed_mps`` (gusts may never let
        it settle), and anyhow after ``leg_timeout_s``. A UAV swinging through the point at 1.7 m/s on an
        autopilot it is tuned too fast for no longer asks for its transit then (issue 19).
        """
        assert self.settling_since_s is not None
        waited = now_s - self.settling_since_s
        cfg = self.config
        if waited >= 2.0 * cfg.align_patience_s:
            vx, vy, vz = tel.velocity_mps
            return vx * vx + vy * vy + vz * vz <= cfg.swing_speed_mps**2 or waited >= cfg.leg_timeout_s
        return self.rests_at(tel, self.target_m, 1.0 if waited < cfg.align_patience_s else 2.0)

    # -- the tick ------------------------------------------------------------------------------------------
    def reference(self, now_s: float) -> tuple[Any, Any]:
        """The reference position and velocity feed-forward at ``now_s`` (float tuples or the target array)."""
        traj = self.traj
        if traj is not None:
            t = now_s - self.t0_s
            shift = self._shift_m
            if t < traj.duration_s:
                ref, vel, acc = traj.sample_floats(t)
                if shift is not None:
                    ref = (ref[0] + shift[0], ref[1] + shift[1], ref[2] + shift[2])
                # velocity, plus the acceleration times the autopilot's velocity lag: a first-order velocity
                # loop then follows the reference's velocity instead of trailing it by lag x acceleration,
                # which the integral would otherwise make up for as an overshoot at the end of the leg
                lag = self.leg_lag_s
                return ref, (vel[0] + lag * acc[0], vel[1] + lag * acc[1], vel[2] + lag * acc[2])
            end = self._traj_end  # past its end the sample is the end's (held while the leg's hover lasts)
            if end is None or end[0] is not traj:
                end = self._traj_end = (traj, traj.sample_floats(t)[0])
            ref = end[1]
            if shift is not None:
                ref = (ref[0] + shift[0], ref[1] + shift[1], ref[2] + shift[2])
            return ref, _ZERO_FF
        if self.steered is not None:
            return self.steered
        if self.line is not None:
            start, direction, length = self.line
            s = (now_s - self.t0_s) * self.line_speed_mps
            if s < length:
                return (start + direction * s).tolist(), (direction * self.line_speed_mps).tolist()
        return self.target_m, _ZERO_FF

    def step(self, now_s: float, tel: Telemetry) -> Setpoint:
        """The velocity setpoint at ``now_s``: the PID on the reference, with its feed-forward (``active``)."""
        ref, ff = self.reference(now_s)
        if self.fence is not None:
            ref, clamped = clamp_reference(self.fence, ref)
            if clamped:
                ff = _ZERO_FF  # held at the fence: no feed-forward out through it
        if type(ref) is np.ndarray:
            ref = ref.tolist()  # the PID takes floats: hand it floats, not numpy scalars to convert
        vx, vy, vz, yaw_rate = self.pid.step_floats(
            now_s,
            tel.position_m,
            ref,
            velocity_ff_mps=ff,
            yaw_rad=tel.attitude_rad[2],
            target_yaw_rad=self.target_yaw_rad,
        )
        return _new_tuple(Setpoint, ((vx, vy, vz), yaw_rate))  # Setpoint(...) without its Python __new__
