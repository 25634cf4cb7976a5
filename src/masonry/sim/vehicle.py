"""A multirotor as its autopilot presents it: velocity setpoints in, motion and telemetry out.

The model (plain floats, no numpy on the hot path: a world steps many of these thousands of times per second):

- The autopilot's velocity loop is a first-order lag with time constant ``velocity_tau_s`` toward the commanded
  velocity, whose magnitude is limited (horizontal speed, climb, descent), and the resulting acceleration is
  limited too (horizontal, vertical). Yaw rate follows its setpoint with its own lag and limit.
- Wind (``wind``: a :class:`masonry.sim.wind.WindField`, mean wind and Dryden turbulence): the air pushes the
  airframe through its drag on the airspeed (linear rotor drag ``drag_per_s`` plus quadratic body drag
  ``drag_quad_per_m``); the autopilot's integral action estimates that push and takes it out over
  ``wind_reject_tau_s``, so a steady wind is held against, and the thrust's horizontal part is limited by the
  tilt limit (``VehicleConfig.tilt_limit_rad``): beyond it the vehicle is blown away, as a real one is. In still
  air (no ``wind``) none of this runs: the loop is the lag above, exactly.
- Like ArduPilot's GUIDED mode: a velocity setpoint is followed for ``setpoint_timeout_s``, then the vehicle
  brakes and holds the position where it stopped. ``takeoff`` climbs to the altitude on its own (a velocity
  setpoint during the climb takes over, as on ArduCopter); ``land`` descends at ``land_speed_mps`` and disarms on
  touchdown. On the ground only ``takeoff`` moves it.
- Failsafes: link lost -> hover ``link_failsafe_s`` then land; battery at ``battery_land_fraction`` -> land;
  battery empty in the air -> the motors stop. ``fail()`` stops the motors now: the vehicle falls.
- Ground contact at ``ground_z_m``; ``hold_above(z)`` lets the world stop the airframe on a brick top (the
  rod pushing on a brick); in LAND mode a vehicle held up for ``land_detect_s`` counts as landed there.
- Telemetry adds motion-capture noise (``mocap_noise_m``, millimetres) to the true state.

Roll and pitch are reconstructed from the horizontal acceleration (a multirotor tilts to accelerate):
body frame FLU, so accelerating forward is a positive pitch and accelerating left a negative roll.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from masonry.errors import CommandRejected, InvalidArgument
from masonry.geometry import wrap_angle_rad
from masonry.ports import Telemetry, Vec3
from masonry.sim.shaping import Shaper
from masonry.sim.vehicle_autopilot import _PI, _TWO_PI, GRAVITY_MPS2, _Autopilot
from masonry.sim.vehicle_config import VehicleConfig
from masonry.sim.wind import WindConfig, WindField

__all__ = ["GRAVITY_MPS2", "SimVehicle", "VehicleConfig"]

_new_telemetry = object.__new__


class _Gauss:
    """Standard normal draws from a Generator, fetched in blocks (one numpy call per 4096 draws)."""

    __slots__ = ("_buf", "_i", "_rng")

    def __init__(self, rng: np.random.Generator) -> None:
        self._rng = rng
        self._buf: list[float] = []
        self._i = 0

    def __call__(self) -> float:
        if self._i >= len(self._buf):
            self._buf = self._rng.standard_normal(4096).tolist()
            self._i = 0
        value = self._buf[self._i]
        self._i += 1
        return value

    def take(self, k: int) -> list[float]:
        """``k`` draws at once."""
        if self._i + k > len(self._buf):
            self._buf = self._buf[self._i :] + self._rng.standard_normal(4096).tolist()
            self._i = 0
        out = self._buf[self._i : self._i + k]
        self._i += k
        return out


class SimVehicle(_Autopilot):
    """One simulated multirotor with its autopilot (state + ``step(dt_s)`` + commands).

    Args:
        config: dynamics, limits, failsafes and noise.
        position_m: where it stands (ENU); it starts landed and disarmed there.
        yaw_rad: initial heading.
        rng: randomness for wind and telemetry noise (own stream: other vehicles are unaffected).
        gusts_mps: the old ``gusts`` knob: a Dryden turbulence of this horizontal intensity (m/s) in no mean
            wind (ignored when ``wind`` is given).
        wind: the wind this vehicle flies in (None: still air, unless ``gusts_mps``).
        battery_drain_per_s: override of ``config.battery_drain_per_s``.
        ground_z_m: height of the ground under it (default: the starting height).
        start_s: the vehicle's clock at creation (keep it equal to the simulation clock).
    """

    def __init__(
        self,
        config: VehicleConfig | None = None,
        *,
        position_m: Vec3 = (0.0, 0.0, 0.0),
        yaw_rad: float = 0.0,
        rng: np.random.Generator | None = None,
        gusts_mps: float = 0.0,
        wind: WindField | None = None,
        battery_drain_per_s: float | None = None,
        ground_z_m: float | None = None,
        start_s: float = 0.0,
    ) -> None:
        self.config = config if config is not None else VehicleConfig()
        self._gauss = _Gauss(rng if rng is not None else np.random.default_rng(0))
        self.ground_z_m = float(position_m[2] if ground_z_m is None else ground_z_m)
        self._x, self._y = float(position_m[0]), float(position_m[1])
        self._z = max(float(position_m[2]), self.ground_z_m)
        self._vx = self._vy = self._vz = 0.0
        self._ax = self._ay = 0.0
        self._yaw = wrap_angle_rad(float(yaw_rad))
        self._yaw_rate = 0.0
        self._t = float(start_s)
        self.armed = False
        self.mode = "GUIDED"
        self.on_ground = True
        self.failed = False
        self.battery_fraction = 1.0
        self.gusts_mps = float(gusts_mps)
        self._drain = (
            self.config.battery_drain_per_s if battery_drain_per_s is None else float(battery_drain_per_s)
        )
        self._wx = self._wy = self._wz = 0.0
        if wind is None and self.gusts_mps > 0:
            wind_rng = np.random.default_rng(rng.integers(2**63) if rng is not None else 1)
            wind = WindField(
                WindConfig(turbulence="custom", turbulence_mps=self.gusts_mps), wind_rng, start_s
            )
        self.wind = wind
        self._dhat = [0.0, 0.0, 0.0]  # the autopilot's estimate of the wind's push (its integrators), m/s^2
        self._west = [0.0, 0.0]  # its wind estimate (what the WIND message reports), m/s
        self._wind_k = (-1.0, 0.0, 0.0, 0.0)
        self._push: tuple[float, float] = (0.0, 0.0)  # SimVehicle.push_mps2
        self._sp: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
        self._sp_time = -math.inf
        self._takeoff_z: float | None = None
        #: where LAND or the automatic climb of ``takeoff`` began: both hold it horizontally (as ArduCopter's
        #: LAND and take-off do with a position estimate), so a gust does not set the vehicle down off its pad
        self._anchor_xy: tuple[float, float] | None = None
        self._hold: tuple[float, float, float] | None = None
        self._link_lost_at: float | None = None
        self._contact_s = 0.0
        self._held = False
        self.distance_m = 0.0
        self.airborne_s = 0.0
        self._lag_dt = -1.0
        self._tel: tuple[bool, Telemetry] | None = None
        self._lag_k = self._yaw_k = 0.0
        self._shaper = Shaper(self.config.shaping) if self.config.shaping is not None else None
        self._liftoff_s = -math.inf  # when it last left the ground (the take-off's thrust ramp)

    # ------------------------------------------------------------------ state
    def reseed(self, rng: np.random.Generator, first: list[float] | None = None) -> None:
        """Draw the noise from ``rng`` from now on (a SITL in lock-step at its first grant: masonry.adapters.sitl);
        ``first``: the draws ``rng`` would give first (its first block, already drawn: ``rng`` is past it)."""
        gauss = _Gauss(rng)
        if first is not None:
            gauss._buf = first  # read, never written: a list shared by every reseed from the same seed
        self._gauss = gauss
        self._tel = None

    @property
    def time_s(self) -> float:
        """The vehicle's own time: the sum of the steps it has taken."""
        return self._t

    @property
    def position_m(self) -> Vec3:
        return (self._x, self._y, self._z)

    @property
    def velocity_mps(self) -> Vec3:
        return (self._vx, self._vy, self._vz)

    @property
    def yaw_rad(self) -> float:
        return self._yaw

    @property
    def yaw_rate_radps(self) -> float:
        return self._yaw_rate

    @property
    def attitude_rad(self) -> Vec3:
        """Roll, pitch, yaw: the tilt a multirotor needs for its current horizontal acceleration (FLU body)."""
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        a_fwd = c * self._ax + s * self._ay
        a_left = -s * self._ax + c * self._ay
        return (-math.atan2(a_left, GRAVITY_MPS2), math.atan2(a_fwd, GRAVITY_MPS2), self._yaw)

    @property
    def wind_mps(self) -> tuple[float, float]:
        """The air's horizontal velocity at the vehicle at its last step (m/s, ENU)."""
        return (self._wx, self._wy)

    @property
    def wind_estimate_mps(self) -> tuple[float, float]:
        """The autopilot's wind estimate (ArduPilot's WIND message): the wind, smoothed over
        ``wind_estimate_tau_s``; (0, 0) in still air."""
        return (self._west[0], self._west[1])

    @property
    def taking_off(self) -> bool:
        return self._takeoff_z is not None

    @property
    def link_lost(self) -> bool:
        return self._link_lost_at is not None

    @property
    def airborne(self) -> bool:
        """Flying under power (armed, off the ground, not failed)."""
        return self.armed and not self.on_ground and not self.failed

    # --------------------------------------------------------------- commands
    def arm(self) -> None:
        """Arm the motors (on the ground, with enough battery); GUIDED mode.

        Arming moves nothing: this instant's telemetry sample, if drawn, stays the one reported (with the new
        flags), so that a caller reading the ground once armed (the take-off's) draws no fresh noise."""
        sample, self._tel = self._tel, None
        if self.failed:
            raise CommandRejected("arm", "the vehicle has failed")
        if self.armed:
            return
        if not self.on_ground:
            raise CommandRejected("arm", "not on the ground")
        if self.battery_fraction < self.config.battery_arm_min_fraction:
            raise CommandRejected("arm", f"battery at {self.battery_fraction:.0%}, below the arming minimum")
        self.armed = True
        self.mode = "GUIDED"
        self._sp_time = -math.inf
        self._takeoff_z = None
        self._hold = None
        if sample is not None:
            self._tel = (sample[0], dataclasses.replace(sample[1], armed=True, mode="GUIDED"))

    def disarm(self, force: bool = False) -> None:
        """Disarm; refused in the air unless ``force`` (then the vehicle falls)."""
        self._tel = None
        if not self.armed:
            return
        if not self.on_ground and not force:
            raise CommandRejected("disarm", "airborne (land first)")
        self.armed = False
        self._takeoff_z = None

    def takeoff(self, altitude_m: float) -> None:
        """Climb on its own to ``altitude_m`` above the ground it stands on."""
        self._tel = None
        if not (math.isfinite(altitude_m) and altitude_m > 0):
            raise CommandRejected("takeoff", f"altitude must be > 0 m, got {altitude_m!r}")
        if self.failed:
            raise CommandRejected("takeoff", "the vehicle has failed")
        if not self.armed:
            raise CommandRejected("takeoff", "not armed")
        if not self.on_ground:
            raise CommandRejected("takeoff", "already flying")
        self.mode = "GUIDED"
        self._takeoff_z = self._z + float(altitude_m)
        self._anchor_xy = (self._x, self._y)
        self._hold = None
        self._sp_time = -math.inf

    def land(self) -> None:
        """Switch to LAND: descend where it is and disarm on touchdown."""
        self._tel = None
        if self.failed:
            raise CommandRejected("land", "the vehicle has failed")
        if not self.armed:
            return
        if self.on_ground:
            self.disarm()
            return
        self.mode = "LAND"
        self._takeoff_z = None
        self._anchor_xy = (self._x, self._y)

    def command_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float, now_s: float) -> None:
        """A velocity (ENU, m/s) and yaw-rate (rad/s) setpoint, valid for ``setpoint_timeout_s`` from ``now_s``.

        Ignored (as by ArduPilot) on the ground, disarmed or in LAND; in the air it ends an auto climb.
        """
        vx, vy, vz = float(velocity_mps[0]), float(velocity_mps[1]), float(velocity_mps[2])
        if not math.isfinite(vx + vy + vz + yaw_rate_radps):
            raise CommandRejected("velocity", f"setpoint not finite: {velocity_mps!r}, {yaw_rate_radps!r}")
        if self.failed or not self.armed or self.on_ground or self.mode != "GUIDED":
            return
        self._sp = (vx, vy, vz, float(yaw_rate_radps))
        self._sp_time = float(now_s)
        self._takeoff_z = None
        self._hold = None

    def fail(self) -> None:
        """The motors stop now (power or ESC failure): the vehicle disarms and falls."""
        self._tel = None
        self.failed = True
        self.armed = False
        self.mode = "FAILED"
        self._takeoff_z = None

    def lose_link(self) -> None:
        """The ground link goes silent: no more setpoints; hover, then land after ``link_failsafe_s``."""
        self._tel = None
        if self._link_lost_at is None:
            self._link_lost_at = self._t

    def swap_battery(self) -> None:
        """A fresh pack (ground crew): only landed and disarmed."""
        sample, self._tel = self._tel, None
        if self.armed or not self.on_ground:
            raise CommandRejected("swap battery", "only on the ground and disarmed")
        self.battery_fraction = 1.0
        if sample is not None:  # a swap moves nothing: the same sample, with the full pack (as arm)
            self._tel = (sample[0], dataclasses.replace(sample[1], battery_fraction=1.0))

    def hold_above(self, z_min_m: float) -> None:
        """Contact: the world stops the airframe from going below ``z_min_m`` (e.g. the rod on a brick)."""
        if self._z < z_min_m:
            self._tel = None
            self._z = z_min_m
            self._vz = max(self._vz, 0.0)
            self._held = True

    # ------------------------------------------------------------------- step
    def idle(self, dt_s: float) -> None:
        """Advance the clock of a vehicle that cannot move (disarmed on the ground): ``step`` in less time."""
        if self.armed or not self.on_ground:
            self.step(dt_s)
            return
        self._tel = None
        self._t += dt_s
        self._held = False

    def follow(
        self,
        position_m: Vec3,
        velocity_mps: Vec3,
        attitude_rad: Vec3,
        *,
        on_ground: bool,
        armed: bool,
        mode: str | None = None,
        battery_fraction: float | None = None,
        dt_s: float = 0.0,
    ) -> None:
        """Take the state measured elsewhere (a real autopilot's telemetry) instead of integrating the model.

        The simulated world then moves with a real UAV: its simulated camera sees from there and its simulated
        magnet reaches what the real tool reaches (``masonry fly --fc URL --camera sim``). Roll and pitch are
        kept as the horizontal acceleration they imply (the tilt convention of :attr:`attitude_rad`), so
        ``attitude_rad`` reads back what was given (tilts are clamped to ±80°).

        Args:
            position_m, velocity_mps: ENU, metres and m/s.
            attitude_rad: roll, pitch, yaw (body FLU).
            on_ground, armed: as the autopilot reports them.
            mode: the autopilot's mode name (None: unchanged).
            battery_fraction: the charge (None: unchanged, e.g. no battery monitor).
            dt_s: time since the previous sample: the vehicle's clock advances by it, and so does its airborne
                time when it flies.

        Raises:
            InvalidArgument: (a ValueError) a non-finite position, velocity or attitude, or a negative ``dt_s``.
        """
        x, y, z = (float(c) for c in position_m)
        vx, vy, vz = (float(c) for c in velocity_mps)
        roll, pitch, yaw = (float(c) for c in attitude_rad)
        if not math.isfinite(x + y + z + vx + vy + vz + roll + pitch + yaw) or not dt_s >= 0.0:
            raise InvalidArgument(
                f"follow: state must be finite and dt_s >= 0, got {position_m}, {velocity_mps}, "
                f"{attitude_rad}, dt_s={dt_s}"
            )
        self._tel = None
        self._t += dt_s
        if armed and not on_ground:
            self.airborne_s += dt_s
        self.distance_m += math.sqrt((x - self._x) ** 2 + (y - self._y) ** 2 + (z - self._z) ** 2)
        self._x, self._y, self._z = x, y, z
        self._vx, self._vy, self._vz = vx, vy, vz
        self._yaw = wrap_angle_rad(yaw)
        limit = math.radians(80.0)
        a_fwd = GRAVITY_MPS2 * math.tan(min(limit, max(-limit, pitch)))
        a_left = -GRAVITY_MPS2 * math.tan(min(limit, max(-limit, roll)))
        c, s = math.cos(self._yaw), math.sin(self._yaw)
        self._ax, self._ay = c * a_fwd - s * a_left, s * a_fwd + c * a_left
        self._yaw_rate = 0.0
        self.armed = bool(armed)
        self.on_ground = bool(on_ground)
        if mode is not None:
            self.mode = mode
        if battery_fraction is not None and math.isfinite(battery_fraction):
            self.battery_fraction = float(battery_fraction)
        self._takeoff_z = None
        self._hold = None
        self._held = False
        self._contact_s = 0.0

    def step(self, dt_s: float) -> None:
        """Advance the vehicle by ``dt_s`` seconds."""
        # Hot path (every airborne vehicle, every physics step). Here: the guards, the battery and the velocity
        # the active mode asks for; then the autopilot's velocity loop and the contacts (``_fly``). One call on
        # the common paths (the climb and the failsafes have their own); clamps are written as comparisons with
        # the semantics of the builtins (``max(a, b)`` is ``b if b > a else a``).
        self._tel = None
        t = self._t = self._t + dt_s
        if self.failed:
            self._fall(dt_s)
            return
        held, self._held = self._held, False
        if not self.armed:
            if not self.on_ground:
                self._fall(dt_s)
            return
        if self.on_ground and self._takeoff_z is None:
            self._vx = self._vy = self._vz = self._ax = self._ay = self._yaw_rate = 0.0
            if self._shaper is not None:
                self._shaper.reset()
            return
        cfg = self.config
        mode = self.mode
        if not self.on_ground:
            self.airborne_s += dt_s
            battery = self.battery_fraction - self._drain * dt_s
            if not battery > 0.0:  # max(0.0, battery)
                battery = 0.0
            self.battery_fraction = battery
            if battery <= 0.0:
                self.fail()
                self._fall(dt_s)
                return
            if battery <= cfg.battery_land_fraction or self._link_lost_at is not None:
                mode = self._failsafes(t, mode)

        # Target velocity from the active mode.
        tyaw = 0.0
        if mode == "LAND":
            tx, ty = self._anchored()
            tz = -cfg.land_speed_mps
        elif self._takeoff_z is not None:
            tx, ty = self._anchored()
            tz = self._climb(self._takeoff_z)
        elif t - self._sp_time <= cfg.setpoint_timeout_s + 1e-9 and self._link_lost_at is None:
            tx, ty, tz, tyaw = self._sp
        else:
            tx, ty, tz = self._hold_velocity()
        if cfg.takeoff_ramp_s > 0.0 and tz > 0.0:
            tz = self._ramped_climb(tz)
        shaper = self._shaper
        if shaper is not None:
            tx, ty, tz = shaper.shape(t, tx, ty, tz, dt_s)
            shaper.drift(dt_s, self._gauss)
        self._fly(tx, ty, tz, tyaw, dt_s, held and mode == "LAND")

    @property
    def push_mps2(self) -> tuple[float, float]:
        """A steady horizontal push from outside (m/s^2, x and y; a test's steady wind), added to the gusts'."""
        return self._push

    @push_mps2.setter
    def push_mps2(self, value: tuple[float, float]) -> None:
        self._push = (float(value[0]), float(value[1]))

    # -------------------------------------------------------------- telemetry
    def telemetry(self, *, link_ok: bool = True) -> Telemetry:
        """What the autopilot reports now: the true state plus motion-capture noise.

        One sample per instant: asking again before the state changes (a step or a command) returns the same
        sample, as reading the latest message of a telemetry stream would.
        """
        cached = self._tel
        if cached is not None and cached[0] == link_ok:
            return cached[1]
        cfg = self.config
        gauss = self._gauss  # seven draws, as ``gauss.take(7)`` (inline: one sample per UAV per control tick)
        i = gauss._i
        if i + 7 > len(gauss._buf):
            g = gauss.take(7)
        else:
            gauss._i = i + 7
            g = gauss._buf[i : i + 7]
        n, v = cfg.mocap_noise_m, cfg.velocity_noise_mps
        yaw = self._yaw
        c, s = math.cos(yaw), math.sin(yaw)  # attitude_rad, inline
        ax, ay = self._ax, self._ay
        roll = -math.atan2(-s * ax + c * ay, GRAVITY_MPS2)
        pitch = math.atan2(c * ax + s * ay, GRAVITY_MPS2)
        # Telemetry is a frozen dataclass without validation; filling its __dict__ directly is the same value
        # built 8x faster than through the generated __init__ (one sample per UAV per control tick).
        x, y, z = self._x + n * g[0], self._y + n * g[1], self._z + n * g[2]
        if self._shaper is not None:
            e = self._shaper.gps_error_m
            x, y, z = x + e[0], y + e[1], z + e[2]
        tel = _new_telemetry(Telemetry)
        tel.__dict__.update(
            time_s=self._t,
            position_m=(x, y, z),
            velocity_mps=(self._vx + v * g[3], self._vy + v * g[4], self._vz + v * g[5]),
            attitude_rad=(roll, pitch, (yaw + cfg.yaw_noise_rad * g[6] + _PI) % _TWO_PI - _PI),
            armed=self.armed,
            mode=self.mode,
            battery_fraction=self.battery_fraction,
            link_ok=link_ok and self._link_lost_at is None and not self.failed,
            position_ok=not self.failed,
            on_ground=self.on_ground,
            landing=self.mode == "LAND",
        )
        self._tel = (link_ok, tel)
        return tel
