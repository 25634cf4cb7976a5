"""The autopilot inside :class:`~masonry.sim.vehicle.SimVehicle`: its velocity loop, wind, failsafes and contacts.

The model is described in :mod:`masonry.sim.vehicle`; this base class holds the private steps of one
``SimVehicle.step`` (the loop toward a target velocity, the hold and the take-off climb, the wind's push and the
tilt limit, ground contact and the fall of a failed vehicle), so the vehicle's module keeps its state, commands
and telemetry. Plain floats on the hot path, as there.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from masonry.sim.shaping import Shaper
    from masonry.sim.vehicle_config import VehicleConfig
    from masonry.sim.wind import WindField

GRAVITY_MPS2 = 9.81

_PI = math.pi
_TWO_PI = 2.0 * math.pi


class _Autopilot:
    """The private steps of :class:`~masonry.sim.vehicle.SimVehicle` (its state is set by its ``__init__``)."""

    config: VehicleConfig
    wind: WindField | None
    ground_z_m: float
    armed: bool
    mode: str
    on_ground: bool
    battery_fraction: float
    distance_m: float
    _x: float
    _y: float
    _z: float
    _vx: float
    _vy: float
    _vz: float
    _ax: float
    _ay: float
    _yaw: float
    _yaw_rate: float
    _t: float
    _wx: float
    _wy: float
    _wz: float
    _dhat: list[float]
    _west: list[float]
    _wind_k: tuple[float, float, float, float]
    _push: tuple[float, float]
    _takeoff_z: float | None
    _anchor_xy: tuple[float, float] | None
    _hold: tuple[float, float, float] | None
    _link_lost_at: float | None
    _contact_s: float
    _held: bool
    _lag_dt: float
    _lag_k: float
    _yaw_k: float
    _shaper: Shaper | None
    _liftoff_s: float

    def _hold_velocity(self) -> tuple[float, float, float]:
        """The velocity that holds the position where the vehicle stopped (after the setpoint timeout)."""
        hold = self._hold
        if hold is None:
            if self._vx * self._vx + self._vy * self._vy + self._vz * self._vz < 0.01:
                self._hold = (self._x, self._y, self._z)
            return 0.0, 0.0, 0.0
        cfg = self.config
        g = cfg.hold_gain_per_s
        tx, ty, tz = g * (hold[0] - self._x), g * (hold[1] - self._y), g * (hold[2] - self._z)
        n = math.sqrt(tx * tx + ty * ty + tz * tz)
        if n > cfg.hold_max_speed_mps:
            f = cfg.hold_max_speed_mps / n
            tx, ty, tz = tx * f, ty * f, tz * f
        return tx, ty, tz

    def _anchored(self) -> tuple[float, float]:
        """The horizontal velocity that holds the vehicle over where LAND or the take-off climb began."""
        anchor = self._anchor_xy
        if anchor is None:
            anchor = self._anchor_xy = (self._x, self._y)
        g = self.config.hold_gain_per_s
        tx, ty = g * (anchor[0] - self._x), g * (anchor[1] - self._y)
        n = math.sqrt(tx * tx + ty * ty)
        if n > self.config.hold_max_speed_mps:
            f = self.config.hold_max_speed_mps / n
            tx, ty = tx * f, ty * f
        return tx, ty

    def _failsafes(self, t: float, mode: str) -> str:
        """The battery and link failsafes of a step in the air (the battery is low or the link lost): the mode."""
        cfg = self.config
        if self.battery_fraction <= cfg.battery_land_fraction and mode != "LAND":
            mode = self.mode = "LAND"
            self._takeoff_z = None
            self._anchor_xy = (self._x, self._y)
        if (
            self._link_lost_at is not None
            and mode != "LAND"
            and t - self._link_lost_at >= cfg.link_failsafe_s
        ):
            mode = self.mode = "LAND"
            self._takeoff_z = None
            self._anchor_xy = (self._x, self._y)
        return mode

    def _climb(self, takeoff_z: float) -> float:
        """The vertical speed of the automatic climb of ``takeoff`` to ``takeoff_z``; there it ends in a hold."""
        cfg = self.config
        err = takeoff_z - self._z
        shaping = cfg.shaping
        if shaping is not None and math.isfinite(shaping.jerk_z_mps3) and math.isfinite(shaping.accel_z_mps2):
            # an autopilot that shapes its own climb (ArduCopter's takeoff) brakes ahead of the delay and the
            # jerk-limited ramp of its deceleration; a plain P law through them rose 0.14 m past its altitude
            err -= self._vz * (shaping.delay_s + 0.5 * shaping.accel_z_mps2 / shaping.jerk_z_mps3)
        tz = 1.5 * err
        if not tz > -cfg.max_descent_mps:  # min(takeoff_speed, max(-max_descent, 1.5 * err))
            tz = -cfg.max_descent_mps
        if cfg.takeoff_speed_mps < tz:  # noqa: PLR1730 (no min/max call: hot loop)
            tz = cfg.takeoff_speed_mps
        if abs(err) < 0.03 and abs(self._vz) < 0.1:
            self._takeoff_z = None
            self._hold = (self._x, self._y, self._z)
        return tz

    def _fly(self, tx: float, ty: float, tz: float, tyaw: float, dt_s: float, resting: bool) -> None:
        """The autopilot's velocity loop toward a target velocity and yaw rate for one step, then the contacts.

        Speed limits, the first-order lag, acceleration limits, the wind, the motion; then ground contact or, with
        ``resting`` (held up by a support in LAND mode), the landing detector.
        """
        cfg = self.config
        if dt_s != self._lag_dt:
            self._lag_dt = dt_s
            self._lag_k = (1.0 - math.exp(-dt_s / cfg.velocity_tau_s)) / dt_s
            self._yaw_k = 1.0 - math.exp(-dt_s / cfg.yaw_tau_s)
        vx, vy, vz = self._vx, self._vy, self._vz
        # Speed limits.
        sxy = math.sqrt(tx * tx + ty * ty)
        if sxy > cfg.max_speed_xy_mps:
            f = cfg.max_speed_xy_mps / sxy
            tx, ty = tx * f, ty * f
        max_descent = cfg.max_descent_mps
        if not tz > -max_descent:  # min(max_climb, max(-max_descent, tz))
            tz = -max_descent
        if cfg.max_climb_mps < tz:  # noqa: PLR1730 (no min/max call: hot loop)
            tz = cfg.max_climb_mps

        # First-order lag, then acceleration limits.
        k = self._lag_k
        ax, ay, az = (tx - vx) * k, (ty - vy) * k, (tz - vz) * k
        axy = math.sqrt(ax * ax + ay * ay)
        if axy > cfg.max_accel_xy_mps2:
            f = cfg.max_accel_xy_mps2 / axy
            ax, ay = ax * f, ay * f
        amax = cfg.max_accel_z_mps2
        if not az > -amax:  # min(amax, max(-amax, az))
            az = -amax
        if amax < az:  # noqa: PLR1730 (no min/max call: hot loop)
            az = amax
        if self.wind is not None:
            # the tilt (attitude_rad) shows the thrust, leaning into the wind; the motion takes the net push
            self._ax, self._ay, ax, ay, az = self._wind_push(ax, ay, az, vx, vy, vz, dt_s)
        else:
            self._ax, self._ay = ax, ay
        ax, ay = ax + self._push[0], ay + self._push[1]  # a test's steady push (0.0: the same numbers)
        vx, vy, vz = vx + ax * dt_s, vy + ay * dt_s, vz + az * dt_s
        self._vx, self._vy, self._vz = vx, vy, vz
        dx, dy, dz = vx * dt_s, vy * dt_s, vz * dt_s
        self._x += dx
        self._y += dy
        z = self._z + dz
        self.distance_m += math.sqrt(dx * dx + dy * dy + dz * dz)

        ymax = cfg.max_yaw_rate_radps
        if not tyaw > -ymax:  # min(ymax, max(-ymax, tyaw))
            tyaw = -ymax
        if ymax < tyaw:  # noqa: PLR1730 (no min/max call: hot loop)
            tyaw = ymax
        rate = self._yaw_rate = self._yaw_rate + (tyaw - self._yaw_rate) * self._yaw_k
        self._yaw = (self._yaw + rate * dt_s + _PI) % _TWO_PI - _PI  # wrap_angle_rad, inline

        # Ground contact, or resting on a support (hold_above) in LAND mode.
        ground = self.ground_z_m
        if z <= ground:
            self._z = ground
            self._touchdown()
            return
        self._z = z
        if resting:
            self._contact_s += dt_s
            if self._contact_s >= cfg.land_detect_s:
                self._touchdown()
        else:
            self._contact_s = 0.0
            if self.on_ground and z > ground + 0.01:
                self.on_ground = False
                self._liftoff_s = self._t

    def _ramped_climb(self, tz: float) -> float:
        """The climb ``tz`` (m/s) within what the take-off's thrust ramp allows now (``takeoff_ramp_s`` after
        leaving the ground: from a tenth of ``max_climb_mps`` to all of it)."""
        since = self._t - self._liftoff_s if not self.on_ground else 0.0
        cfg = self.config
        if since >= cfg.takeoff_ramp_s:
            return tz
        return min(tz, cfg.max_climb_mps * (0.1 + 0.9 * since / cfg.takeoff_ramp_s))

    def _wind_push(
        self, ax: float, ay: float, az: float, vx: float, vy: float, vz: float, dt_s: float
    ) -> tuple[float, float, float, float, float]:
        """The tilt's and the net acceleration for the loop's commanded one, in wind: ``(a - push estimate) + push``, with the
        thrust's horizontal part within the tilt limit.

        The commanded acceleration is what the still-air loop asks of the airframe net of its drag at the ground
        speed; the wind's push is what the drag at the airspeed adds to that (zero in still air). Returns it and
        sets the state the wind leaves behind (the push estimate, the wind estimate, the wind seen). The tilt's
        acceleration is the thrust's net of the drag at the ground speed: the command itself in still air, as
        :attr:`attitude_rad` reconstructs it there.
        """
        cfg = self.config
        wx, wy, wz = self.wind.at(self._t, self._z - self.ground_z_m)  # type: ignore[union-attr]
        self._wx, self._wy, self._wz = wx, wy, wz
        k, q = cfg.drag_per_s, cfg.drag_quad_per_m
        rx, ry, rz = wx - vx, wy - vy, wz - vz  # the air relative to the airframe
        rel = math.sqrt(rx * rx + ry * ry + rz * rz)
        own = math.sqrt(vx * vx + vy * vy + vz * vz)
        # push = drag(airspeed) - drag(ground speed): k w + q (|w - v| (w - v) + |v| v)
        px, py, pz = (
            k * wx + q * (rel * rx + own * vx),
            k * wy + q * (rel * ry + own * vy),
            k * wz + q * (rel * rz + own * vz),
        )
        if self._wind_k[0] != dt_s:
            self._wind_k = (
                dt_s,
                1.0 - math.exp(-dt_s / cfg.wind_reject_tau_s),
                1.0 - math.exp(-dt_s / cfg.wind_estimate_tau_s),
                1.0 - math.exp(-dt_s / cfg.wind_reject_z_tau_s),
            )
        _, kr, ke, kz = self._wind_k
        d = self._dhat
        # tilt: the thrust's horizontal part (the command minus the push estimate, plus the drag at the ground
        # speed that the still-air loop hides) within the tilt limit
        drag_x, drag_y = k * vx + q * own * vx, k * vy + q * own * vy
        tx, ty = ax - d[0] + drag_x, ay - d[1] + drag_y
        limit = GRAVITY_MPS2 * math.tan(cfg.tilt_limit_rad)
        t = math.sqrt(tx * tx + ty * ty)
        nx, ny = d[0] + (px - d[0]) * kr, d[1] + (py - d[1]) * kr
        if t > limit:
            # the integrators stop winding up at the limit (ArduPilot's limit flags), but unwind: an estimate
            # left stale at the limit (a gust that turned) otherwise holds the thrust saturated along the motion
            # and the vehicle runs away downwind faster than the wind (issue 18: 16 m/s in a 10 m/s gust)
            ux, uy = ax - nx + drag_x, ay - ny + drag_y
            if ux * ux + uy * uy < t * t:
                d[0], d[1] = nx, ny
            tx, ty = tx * limit / t, ty * limit / t
        else:
            d[0], d[1] = nx, ny
        net_z = az - d[2] + pz
        d[2] += (pz - d[2]) * kz
        e = self._west
        e[0] += (wx - e[0]) * ke
        e[1] += (wy - e[1]) * ke
        return tx - drag_x, ty - drag_y, tx - drag_x + px, ty - drag_y + py, net_z

    def _touchdown(self) -> None:
        # a take-off starts on the ground: with a shaper's delay the climb begins a few steps after the command
        climbing = self._takeoff_z is not None and (self._vz > 0.0 or self._shaper is not None)
        if climbing:
            return
        self.on_ground = True
        self._vx = self._vy = self._vz = self._ax = self._ay = self._yaw_rate = 0.0
        self._contact_s = 0.0
        self._hold = None
        self._takeoff_z = None
        if self.mode == "LAND":
            self.armed = False

    def _fall(self, dt_s: float) -> None:
        if self.on_ground:
            self._vx = self._vy = self._vz = 0.0
            return
        self._vz -= GRAVITY_MPS2 * dt_s
        damp = math.exp(-self.config.drag_per_s * dt_s)
        self._vx *= damp
        self._vy *= damp
        self._x += self._vx * dt_s
        self._y += self._vy * dt_s
        self._z += self._vz * dt_s
        if self._z <= self.ground_z_m or self._held:
            self._z = max(self._z, self.ground_z_m)
            self.on_ground = True
            self._vx = self._vy = self._vz = self._ax = self._ay = 0.0
        self._held = False
