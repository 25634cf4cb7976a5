"""What a real autopilot does to a velocity setpoint before its airframe follows it (the ``arducopter`` preset).

:class:`~masonry.sim.vehicle.SimVehicle` alone is a first-order lag toward the commanded velocity. ArduCopter's
GUIDED mode does more (issue 19, measured with ``masonry fly --identify`` on ArduCopter 4.7 SITL: 10 % of a
0.5 m/s step after 0.31-0.34 s, 63 % after 0.71 s, 90 % after 1.0-1.4 s):

- a transport and loop delay: the link, the 400 Hz loop's scheduling, the EKF's output lag (``delay_s``);
- jerk- and acceleration-limited shaping of the velocity target (AC_PosControl's ``shape_vel_accel``:
  ``PSC_JERK_XY`` 5 m/s^3 and ``WPNAV_ACCEL`` 2.5 m/s^2 horizontally, ``PSC_JERK_Z`` 5 m/s^3 and
  ``PILOT_ACCEL_Z`` 2.5 m/s^2 vertically): the target velocity moves toward the setpoint along a jerk-limited
  S-curve, never faster than the acceleration limit;
- GPS-like position noise (``gps_noise_m``, correlated over ``gps_noise_tau_s``: it wanders, unlike
  motion-capture noise) beside the vehicle's white motion-capture noise.

The vehicle's own first-order lag (``VehicleConfig.velocity_tau_s``) then follows the shaped target. The
numbers of :data:`ARDUCOPTER` are fitted so that ``masonry fly --identify --sim --vehicle arducopter``
measures what it measures on the SITL (``benchmarks/bench_vehicle_fit.py`` prints both;
docs/performance/autopilots.md, "The fit, again").
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from masonry.errors import InvalidArgument

__all__ = ["ARDUCOPTER", "PX4", "PX4_BELOW_OWN_LOOP", "Shaper", "ShapingConfig"]


@dataclass(frozen=True)
class ShapingConfig:
    """An autopilot's setpoint shaping and delay (SI units in the names)."""

    delay_s: float = 0.0
    jerk_xy_mps3: float = math.inf
    accel_xy_mps2: float = math.inf
    jerk_z_mps3: float = math.inf
    accel_z_mps2: float = math.inf
    gps_noise_m: float = 0.0  # standard deviation of the wandering position error, per axis (0: none)
    gps_noise_tau_s: float = 2.0  # its correlation time
    # > 0: the wander is smoothed by a second first-order stage with this time constant (an EKF's output is
    # smooth: its error wanders without the Ornstein-Uhlenbeck process's white-noise velocity); 0: none
    gps_noise_smooth_s: float = 0.0
    # > 0: the airframe's velocity wanders about the setpoint by this much (standard deviation per axis, m/s,
    # correlated over ``velocity_wander_tau_s``): a velocity loop closed on a noisy velocity estimate (on a real
    # PX4, masonry's own, on the velocity it observes from EKF2's position) moves the airframe itself, unlike
    # the telemetry's noise; 0: none
    velocity_wander_mps: float = 0.0
    velocity_wander_tau_s: float = 0.25
    # > 0: the airframe first reaches only ``1 - velocity_droop`` of a horizontal setpoint's change and the rest over
    # ``velocity_droop_s`` (a PI velocity loop against the airframe's drag: the proportional part balances the drag
    # with an error its slow integral then takes out); 0: none
    velocity_droop: float = 0.0
    velocity_droop_s: float = 4.0

    def __post_init__(self) -> None:
        for name in (
            "jerk_xy_mps3",
            "accel_xy_mps2",
            "jerk_z_mps3",
            "accel_z_mps2",
            "gps_noise_tau_s",
            "velocity_wander_tau_s",
            "velocity_droop_s",
        ):
            value = getattr(self, name)
            if math.isnan(value) or value <= 0:
                raise InvalidArgument(f"ShapingConfig.{name} must be > 0 (inf for none), got {value!r}")
        for name in ("delay_s", "gps_noise_m", "gps_noise_smooth_s", "velocity_wander_mps"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise InvalidArgument(f"ShapingConfig.{name} must be finite and >= 0, got {value!r}")
        if not 0.0 <= self.velocity_droop < 1.0:
            raise InvalidArgument(
                f"ShapingConfig.velocity_droop must be in [0, 1), got {self.velocity_droop!r}"
            )


#: ArduCopter 4.7 defaults (PSC_JERK_XY, WPNAV_ACCEL, PSC_JERK_Z, PILOT_ACCEL_Z) with the delay fitted to the SITL.
ARDUCOPTER = ShapingConfig(
    delay_s=0.10,
    jerk_xy_mps3=5.0,
    accel_xy_mps2=2.5,
    jerk_z_mps3=5.0,
    accel_z_mps2=2.5,
    gps_noise_m=0.003,
    gps_noise_tau_s=2.0,
)

#: PX4 v1.16 on GNSS as masonry flies it (issue 20; refitted to the real PX4 v1.16 SITL in issue 29): velocity
#: setpoints unshaped (masonry's own velocity loop, acceleration setpoints), behind 0.25 s of dead time (the link,
#: the loop, EKF2's position lag: a 0.5 m/s step starts to move the reported position 0.3-0.4 s later); the
#: airframe's velocity wanders 7.5 cm/s about the setpoint over 0.1 s (behind the 0.15 s lag: 4-5 cm/s rms, as the
#: real one with zero velocity commanded) and first reaches about 75 % of a step (1-2 s after a 0.5 m/s step the
#: real one moves at 0.30-0.51 m/s: the drag against the velocity loop's proportional part); the position its EKF2 reports wanders slowly (GNSS errors are correlated
#: over seconds): 6 cm per axis (smoothed over 2 s: EKF2's output predictor), issue 20's +-15 cm in a hover (kept:
#: SIH's estimate cannot show it, docs/performance/autopilots.md "The px4 model refitted").
PX4 = ShapingConfig(
    delay_s=0.25,
    gps_noise_m=0.06,
    gps_noise_tau_s=8.0,
    gps_noise_smooth_s=2.0,
    velocity_wander_mps=0.075,
    velocity_wander_tau_s=0.1,
    velocity_droop=0.25,
    velocity_droop_s=4.0,
)


#: PX4 below masonry's own velocity loop (``masonry sitl --vehicle px4``, where the adapter closes that loop itself on
#: acceleration setpoints): issue 20's short delay and the GNSS wander, without what :data:`PX4` adds for the loop
#: (its dead time, droop and velocity wander).
PX4_BELOW_OWN_LOOP = ShapingConfig(delay_s=0.1, gps_noise_m=0.06, gps_noise_tau_s=8.0, gps_noise_smooth_s=2.0)


class _Axis:
    """One axis of ArduPilot's ``shape_vel_accel``: the shaped velocity ``v`` moves toward its target with the
    acceleration ``sqrt_controller(error, jerk / accel, jerk)`` (linear, gain jerk / accel, for errors below
    jerk / gain^2; a jerk-limited braking curve beyond), within the acceleration limit, reached at the jerk limit."""

    __slots__ = ("_half_linear", "_linear", "_shaped", "_two_jerk", "a", "accel", "gain", "jerk", "v")

    def __init__(self, jerk: float, accel: float) -> None:
        self.jerk, self.accel = jerk, accel
        self.gain = jerk / accel if math.isfinite(jerk) and math.isfinite(accel) else math.inf
        self.v = self.a = 0.0
        self._shaped = math.isfinite(self.gain)
        # _sqrt_controller's constants for this axis (the same floats it computes on every call)
        self._linear = jerk / (self.gain * self.gain) if self._shaped else math.inf
        self._half_linear, self._two_jerk = self._linear / 2.0, 2.0 * jerk

    def step(self, target: float, dt: float) -> float:
        """One step toward ``target``: :func:`_sqrt_controller` inline (every vehicle, every physics step)."""
        e = target - self.v
        if not self._shaped:  # no shaping on this axis
            self.v, self.a = target, 0.0
            return target
        linear = self._linear
        if e > linear:
            want = math.sqrt(self._two_jerk * (e - self._half_linear))
        elif e < -linear:
            want = -math.sqrt(self._two_jerk * (-e - self._half_linear))
        else:
            want = e * self.gain
        limit = abs(e) / dt  # never past the error in one step
        want = limit if want > limit else (-limit if want < -limit else want)
        accel = self.accel
        want = accel if want > accel else (-accel if want < -accel else want)
        da = want - self.a
        step = self.jerk * dt
        self.a += step if da > step else (-step if da < -step else da)
        self.v += self.a * dt
        return self.v


def _sqrt_controller(error: float, p: float, second_order_limit: float, dt: float) -> float:
    """ArduPilot's ``sqrt_controller`` (AP_Math/control.cpp): linear near zero, square root beyond."""
    linear = second_order_limit / (p * p)
    if error > linear:
        out = math.sqrt(2.0 * second_order_limit * (error - linear / 2.0))
    elif error < -linear:
        out = -math.sqrt(2.0 * second_order_limit * (-error - linear / 2.0))
    else:
        out = error * p
    limit = abs(error) / dt  # never past the error in one step
    return limit if out > limit else (-limit if out < -limit else out)


class Shaper:
    """The state of one vehicle's shaping: the delay line, the shaped velocity and the GPS error."""

    def __init__(self, config: ShapingConfig) -> None:
        self.config = config
        self._line: deque[tuple[float, float, float, float]] = deque()
        self._out = (0.0, 0.0, 0.0)
        self._axes = (
            _Axis(config.jerk_xy_mps3, config.accel_xy_mps2),
            _Axis(config.jerk_xy_mps3, config.accel_xy_mps2),
            _Axis(config.jerk_z_mps3, config.accel_z_mps2),
        )
        self.gps_error_m = [0.0, 0.0, 0.0]  # what the telemetry adds: the wander (smoothed, if so configured)
        self._wander_m = [0.0, 0.0, 0.0]
        self._velocity_wander_mps = [0.0, 0.0, 0.0]  # what the airframe's velocity target gets (m/s)
        self._slow_xy = [0.0, 0.0]  # the horizontal setpoint followed over ``velocity_droop_s`` (the droop's)
        self._drift_dt_s = math.nan  # (the step :attr:`_drift`'s constants are for; NaN: none yet)
        self._drift = self._drift_constants(0.0)

    def reset(self, velocity_mps: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Forget the delay line; the shaped velocity is ``velocity_mps`` (on the ground: zero)."""
        self._line.clear()
        self._out = velocity_mps
        for axis, v in zip(self._axes, velocity_mps):
            axis.v, axis.a = v, 0.0
        self._slow_xy = [velocity_mps[0], velocity_mps[1]]

    def shape(self, t_s: float, tx: float, ty: float, tz: float, dt_s: float) -> tuple[float, float, float]:
        """The target velocity the airframe follows at ``t_s``, for the autopilot's target ``(tx, ty, tz)`` now."""
        line = self._line
        line.append((t_s, tx, ty, tz))
        due = t_s - self.config.delay_s + 1e-9
        out = self._out
        while line and line[0][0] <= due:
            _, vx, vy, vz = line.popleft()
            out = (vx, vy, vz)
        self._out = out
        ax, ay, az = self._axes
        w = self._velocity_wander_mps
        vx, vy = ax.step(out[0], dt_s), ay.step(out[1], dt_s)
        droop = self.config.velocity_droop
        if droop > 0.0:
            slow = self._slow_xy
            k = min(1.0, dt_s / self.config.velocity_droop_s)
            slow[0] += (vx - slow[0]) * k
            slow[1] += (vy - slow[1]) * k
            vx, vy = vx - droop * (vx - slow[0]), vy - droop * (vy - slow[1])
        return vx + w[0], vy + w[1], az.step(out[2], dt_s) + w[2]

    def drift(self, dt_s: float, gauss: Callable[[], float]) -> None:
        """Move the GPS error and the velocity's wander on by ``dt_s`` (Ornstein-Uhlenbeck; ``gauss()`` a standard
        normal draw; a ``gauss`` with ``take(k)``, :class:`masonry.sim.vehicle._Gauss`, gives three at once, the
        same three in the same order)."""
        if dt_s != self._drift_dt_s:  # (every physics step has the same dt_s: its constants once)
            self._drift_dt_s, self._drift = dt_s, self._drift_constants(dt_s)
        wander, a, b, sigma, c, d, smooth, k = self._drift
        take = getattr(gauss, "take", None)
        if wander:
            w = self._velocity_wander_mps
            g = take(3) if take is not None else [gauss(), gauss(), gauss()]
            w[0] += -w[0] * a + b * g[0]
            w[1] += -w[1] * a + b * g[1]
            w[2] += -w[2] * a + b * g[2]
        if not sigma:
            return
        err = self._wander_m if smooth else self.gps_error_m
        g = take(3) if take is not None else [gauss(), gauss(), gauss()]
        err[0] += -err[0] * c + d * g[0]
        err[1] += -err[1] * c + d * g[1]
        err[2] += -err[2] * c + d * g[2]
        if smooth:
            out = self.gps_error_m
            out[0] += k * (err[0] - out[0])
            out[1] += k * (err[1] - out[1])
            out[2] += k * (err[2] - out[2])

    def _drift_constants(self, dt_s: float) -> tuple[bool, float, float, bool, float, float, bool, float]:
        """:meth:`drift`'s coefficients for a step of ``dt_s``: whether the velocity wanders, its decay and draw's
        scale; whether the GPS error wanders, its decay and draw's scale; whether it is smoothed, the smoothing's
        gain (the same floats the loops computed on every step)."""
        cfg = self.config
        wander = cfg.velocity_wander_mps
        a = b = 0.0
        if wander > 0.0:
            a = min(1.0, dt_s / cfg.velocity_wander_tau_s)
            b = wander * math.sqrt(a * (2.0 - a))  # stationary at ``wander`` for any step
        sigma = cfg.gps_noise_m
        c = d = k = 0.0
        if sigma > 0.0:
            c = dt_s / cfg.gps_noise_tau_s
            d = sigma * math.sqrt(2.0 * c)
            if cfg.gps_noise_smooth_s > 0.0:
                k = min(1.0, dt_s / cfg.gps_noise_smooth_s)
        return wander > 0.0, a, b, sigma > 0.0, c, d, cfg.gps_noise_smooth_s > 0.0, k
