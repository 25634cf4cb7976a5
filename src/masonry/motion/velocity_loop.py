"""A velocity loop closed on the reported position: velocity setpoints in, acceleration setpoints out (issue 29).

PX4 v1.16 SITL's EKF2 reports a velocity up to 0.5 m/s off what its position does (docs/hardware.md, "Against the
real PX4 v1.16 SITL"), and PX4's own velocity loop closes on that velocity: in OFFBOARD on velocity setpoints, or
holding a position setpoint itself, the reported position wanders 0.15-0.3 m (rms) and the brick UAV never aligns.
Sent as acceleration setpoints instead, the autopilot's velocity loop is left out: this loop estimates the velocity
from the reported position (an alpha-beta observer driven by the acceleration it commanded) and commands
``kv x (velocity setpoint - that velocity)``. The position loop around it (masonry's PID) is unchanged: to it the
vehicle still answers a velocity setpoint with a first-order lag of about ``1 / kv``.

Pure: no clock, no I/O; the adapter feeds it positions with their autopilot time stamps and asks for the
acceleration of a velocity setpoint (all in one frame, the autopilot's NED in practice). Optionally (issues 29/30,
``UavConfig.velocity_observer_input: tilt``) the adapter also feeds, with each position, the horizontal
acceleration the vehicle's attitude gives (:func:`tilt_acceleration_mps2`): PX4 realises a commanded acceleration as
a tilt 0.17-0.2 s later, and the observer driven by what is realised rather than what was asked predicts the
position better (docs/performance/autopilots.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from masonry.errors import InputError

Vec3 = tuple[float, float, float]

#: The acceleration of gravity (m/s^2) the tilt's horizontal acceleration is taken from.
GRAVITY_MPS2 = 9.81


def tilt_acceleration_mps2(roll_rad: float, pitch_rad: float, yaw_rad: float) -> tuple[float, float]:
    """The horizontal acceleration (north, east; m/s^2) a multicopter at this attitude (FRD body in NED, Euler
    roll-pitch-yaw) gives when its thrust's vertical part holds its weight: ``g`` times the tilt, turned by the yaw."""
    g = GRAVITY_MPS2
    tan_roll_over_cos_pitch = math.tan(roll_rad) / math.cos(pitch_rad)
    tan_pitch = math.tan(pitch_rad)
    a_n = -g * (math.cos(yaw_rad) * tan_pitch + math.sin(yaw_rad) * tan_roll_over_cos_pitch)
    a_e = -g * (math.sin(yaw_rad) * tan_pitch - math.cos(yaw_rad) * tan_roll_over_cos_pitch)
    return (a_n, a_e)


@dataclass(frozen=True)
class VelocityLoopGains:
    """Gains and limits of :class:`VelocityLoop` (measured on PX4 v1.16 SITL, docs/performance/autopilots.md).

    Args:
        kv_per_s: horizontal gain (1/s): acceleration per m/s of velocity error; the velocity's lag is ~1/kv.
        kv_z_per_s: vertical gain (1/s).
        ki_per_s2: horizontal integral gain (1/s^2): takes out what the autopilot realises differently from what
            is commanded (a tilt estimate's error; PX4 maps a zero acceleration to its hover-thrust estimate).
        ki_z_per_s2: vertical integral gain (1/s^2).
        integral_limit_mps2: the largest acceleration the integral adds (each axis).
        accel_limit_mps2: the largest horizontal acceleration commanded (norm).
        accel_limit_z_mps2: the largest vertical acceleration commanded (either way).
        observer_position_rate_per_s: how fast the observer's position follows the reported one (1/s).
        observer_velocity_rate_per_s2: how fast the observer's velocity absorbs the position's residual (1/s^2).
    """

    kv_per_s: float = 4.0
    kv_z_per_s: float = 3.0
    ki_per_s2: float = 1.0
    ki_z_per_s2: float = 2.0
    integral_limit_mps2: float = 1.5
    accel_limit_mps2: float = 3.0
    accel_limit_z_mps2: float = 2.0
    observer_position_rate_per_s: float = 15.0
    observer_velocity_rate_per_s2: float = 135.0

    def __post_init__(self) -> None:
        for name in (
            "kv_per_s",
            "kv_z_per_s",
            "ki_per_s2",
            "ki_z_per_s2",
            "integral_limit_mps2",
            "accel_limit_mps2",
            "accel_limit_z_mps2",
            "observer_position_rate_per_s",
            "observer_velocity_rate_per_s2",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise InputError(f"velocity loop {name} must be finite and > 0, got {value!r}")


class VelocityLoop:
    """Velocity setpoint -> acceleration setpoint, on a velocity observed from the reported position."""

    def __init__(self, gains: VelocityLoopGains | None = None) -> None:
        self.gains = gains or VelocityLoopGains()
        self._t_s: float | None = None
        self._x: list[float] = [0.0, 0.0, 0.0]
        self._v: list[float] = [0.0, 0.0, 0.0]
        self._a: list[float] = [0.0, 0.0, 0.0]  # the observer's input: the last command less the integral
        self._v_sp: list[float] | None = (
            None  # the velocity setpoint last asked (None: not flying on this loop)
        )
        self._i: list[float] = [0.0, 0.0, 0.0]  # the integral's acceleration

    @property
    def ready(self) -> bool:
        """Whether a position has been observed since the last :meth:`reset`."""
        return self._t_s is not None

    @property
    def observed_s(self) -> float | None:
        """The autopilot's time (s) of the last position observed; None since the last :meth:`reset`."""
        return self._t_s

    @property
    def velocity_mps(self) -> Vec3:
        """The observed velocity (the frame of the positions fed in)."""
        return (self._v[0], self._v[1], self._v[2])

    def reset(self, velocity_mps: Vec3 = (0.0, 0.0, 0.0)) -> None:
        """Forget the positions seen; the next one starts the observer at ``velocity_mps``."""
        self._t_s = None
        self._v = [float(c) for c in velocity_mps]
        self.release()

    def release(self) -> None:
        """The autopilot flies on its own again: forget the setpoint, the integral and the commanded input."""
        self._a = [0.0, 0.0, 0.0]
        self._v_sp = None
        self._i = [0.0, 0.0, 0.0]

    def observe(
        self, t_s: float, position_m: Vec3, horizontal_acceleration_mps2: tuple[float, float] | None = None
    ) -> None:
        """A reported position, stamped ``t_s`` on the autopilot's clock (repeats and older stamps are ignored).

        ``horizontal_acceleration_mps2``: the horizontal acceleration the vehicle is measured to realise now
        (:func:`tilt_acceleration_mps2` of its attitude): the observer predicts on it rather than on the horizontal
        acceleration last commanded (which it otherwise takes as realised at once); None: on the command.
        """
        p = [float(c) for c in position_m]
        if not all(math.isfinite(c) for c in p) or not math.isfinite(t_s):
            return
        if horizontal_acceleration_mps2 is not None and all(
            math.isfinite(c) for c in horizontal_acceleration_mps2
        ):
            self._a[0], self._a[1] = (float(c) for c in horizontal_acceleration_mps2)
        if self._t_s is None:
            self._t_s, self._x = float(t_s), p
            return
        dt = float(t_s) - self._t_s
        if dt <= 0.0:
            return
        self._t_s = float(t_s)
        dt = min(dt, 0.5)  # a gap in the stream: predict no farther than this
        g = self.gains
        alpha = min(1.0, g.observer_position_rate_per_s * dt)
        beta = min(1.0, g.observer_velocity_rate_per_s2 * dt * dt)
        if self._v_sp is not None:
            for i, ki in enumerate((g.ki_per_s2, g.ki_per_s2, g.ki_z_per_s2)):
                step = self._i[i] + ki * (self._v_sp[i] - self._v[i]) * dt
                self._i[i] = max(-g.integral_limit_mps2, min(g.integral_limit_mps2, step))
        for i in range(3):
            x_pred = self._x[i] + self._v[i] * dt + 0.5 * self._a[i] * dt * dt
            v_pred = self._v[i] + self._a[i] * dt
            r = p[i] - x_pred
            self._x[i] = x_pred + alpha * r
            self._v[i] = v_pred + beta * r / dt

    def acceleration(self, velocity_mps: Vec3) -> Vec3:
        """The acceleration (m/s^2) that drives the observed velocity to ``velocity_mps``, within the limits."""
        g = self.gains
        self._v_sp = [float(c) for c in velocity_mps]
        ax = g.kv_per_s * (self._v_sp[0] - self._v[0]) + self._i[0]
        ay = g.kv_per_s * (self._v_sp[1] - self._v[1]) + self._i[1]
        az = g.kv_z_per_s * (self._v_sp[2] - self._v[2]) + self._i[2]
        norm = math.hypot(ax, ay)
        if norm > g.accel_limit_mps2:
            ax, ay = ax * g.accel_limit_mps2 / norm, ay * g.accel_limit_mps2 / norm
        az = max(-g.accel_limit_z_mps2, min(g.accel_limit_z_mps2, az))
        # the observer's input: what the vehicle should realise, the integral being the autopilot's offset from it
        self._a = [ax - self._i[0], ay - self._i[1], az - self._i[2]]
        return (ax, ay, az)
