"""Position PID producing velocity references for the flight controller (paper Sec. IV, UAV Control).

The flight controller tracks velocity; this outer loop turns the position error into a velocity reference:
``u = v_ff + kp e + ki integral(e) - kd d(measurement)/dt``, clamped per axis. Design choices:

- derivative on the measurement, not the error, so a jump of the target (a new waypoint) gives no kick;
- anti-windup by conditional integration: the integral is frozen while the output is saturated in the direction
  the error pushes it, and it is also clamped to ``integral_limit`` (in output units);
- yaw uses the wrapped error ``wrap(target - yaw)`` and the wrapped yaw increment for its derivative, so crossing
  +-pi neither flips the command nor spikes the derivative;
- ``step(now_s, ...)`` is pure apart from the controller's own memory: ``dt`` is the time since the previous call.
  The first call integrates nothing and has no derivative term; a call with ``dt <= 0`` (repeated or rewound
  clock) integrates nothing and reuses the last rate estimate, and a rewound clock re-anchors the time base.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from masonry.errors import InputError
from masonry.geometry import wrap_angle_rad


@dataclass(frozen=True)
class AxisGains:
    """Gains and limits of one axis.

    Attributes:
        kp: proportional gain (1/s: m/s per m, or rad/s per rad).
        ki: integral gain (1/s^2).
        kd: derivative gain (dimensionless), applied to the measurement's rate.
        output_limit: clamp on the axis output (m/s for x, y, z; rad/s for yaw), positive; ``inf`` for none.
        integral_limit: clamp on the integral contribution ``ki * integral(e)`` in output units.
    """

    kp: float
    ki: float = 0.0
    kd: float = 0.0
    output_limit: float = math.inf
    integral_limit: float = math.inf

    def __post_init__(self) -> None:
        for name in ("kp", "ki", "kd"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0.0):
                raise InputError(f"PID gain {name} must be a finite non-negative number, got {value!r}")
        for name in ("output_limit", "integral_limit"):
            value = getattr(self, name)
            if math.isnan(value) or value <= 0.0:
                raise InputError(f"PID {name} must be positive (inf for none), got {value!r}")


@dataclass(frozen=True)
class PIDGains:
    """Per-axis gains of the position controller (x, y, z in the world frame) and the yaw controller.

    Defaults are tuned for a 2-5 kg multirotor tracking mocap positions at 10-50 Hz through an autopilot velocity
    loop with a ~0.3 s lag: horizontally kp 3 /s and a strong integral (ki 2 /s^2, up to 1 m/s) so that wind is
    rejected (the autopilot's own integral takes a steady wind out over a second or so, and this one what
    is left of gusts; with kp 1.2, ki 0.1, on a loop without integral action, the UAV could not hold 1.5 cm in
    1 m/s gusts, see docs/performance/history.md, "Issue 5: gusts"), output up to 1.5 m/s. The
    position ``kd`` defaults to 0: the flight controller's velocity loop already damps the vehicle, and a derivative
    on the measurement would scale down the trajectory's velocity feed-forward while tracking.
    ``derivative_tau_s`` is the time constant of a first-order low-pass on the measured rate (0 for none).
    """

    x: AxisGains = field(
        default_factory=lambda: AxisGains(kp=3.0, ki=2.0, kd=0.0, output_limit=1.5, integral_limit=1.0)
    )
    y: AxisGains = field(
        default_factory=lambda: AxisGains(kp=3.0, ki=2.0, kd=0.0, output_limit=1.5, integral_limit=1.0)
    )
    z: AxisGains = field(
        default_factory=lambda: AxisGains(kp=1.5, ki=0.2, kd=0.0, output_limit=0.7, integral_limit=0.3)
    )
    yaw: AxisGains = field(default_factory=lambda: AxisGains(kp=1.5, ki=0.0, kd=0.0, output_limit=1.0))
    derivative_tau_s: float = 0.0

    def __post_init__(self) -> None:
        if not (math.isfinite(self.derivative_tau_s) and self.derivative_tau_s >= 0.0):
            raise InputError(f"PID derivative_tau_s must be finite and >= 0, got {self.derivative_tau_s!r}")

    @classmethod
    def uniform(
        cls, axis: AxisGains, yaw: AxisGains | None = None, derivative_tau_s: float = 0.0
    ) -> PIDGains:
        """The same gains on x, y and z (and on yaw unless ``yaw`` is given)."""
        return cls(
            x=axis, y=axis, z=axis, yaw=yaw if yaw is not None else axis, derivative_tau_s=derivative_tau_s
        )


def _floats3(name: str, value: Sequence[float] | np.ndarray) -> tuple[float, float, float]:
    items = value.tolist() if isinstance(value, np.ndarray) else value
    try:
        x, y, z = items
        x, y, z = float(x), float(y), float(z)
    except (TypeError, ValueError):
        raise InputError(f"PID {name} must be a finite 3-vector, got {value!r}") from None
    if not (math.isfinite(x) and math.isfinite(y) and math.isfinite(z)):
        raise InputError(f"PID {name} must be a finite 3-vector, got {value!r}")
    return x, y, z


def _floats9(
    position_m: Sequence[float] | np.ndarray,
    target_m: Sequence[float] | np.ndarray,
    velocity_ff_mps: Sequence[float] | np.ndarray,
) -> tuple[float, float, float, float, float, float, float, float, float]:
    """The three 3-vectors of :meth:`PID.step_floats` as nine finite floats (InputError names a bad one)."""
    isfinite = math.isfinite
    try:  # the common case, inline: three finite numbers each
        px, py, pz = position_m
        tx, ty, tz = target_m
        fx, fy, fz = velocity_ff_mps
        px, py, pz, tx, ty, tz = float(px), float(py), float(pz), float(tx), float(ty), float(tz)
        fx, fy, fz = float(fx), float(fy), float(fz)
        # one test for the nine: a sum of finite floats is finite unless it overflows (then each is asked below)
        if isfinite(px + py + pz + tx + ty + tz + fx + fy + fz) or (
            isfinite(px)
            and isfinite(py)
            and isfinite(pz)
            and isfinite(tx)
            and isfinite(ty)
            and isfinite(tz)
            and isfinite(fx)
            and isfinite(fy)
            and isfinite(fz)
        ):
            return px, py, pz, tx, ty, tz, fx, fy, fz
    except (TypeError, ValueError):
        pass
    # say which argument is wrong
    return (
        *_floats3("position_m", position_m),
        *_floats3("target_m", target_m),
        *_floats3("velocity_ff_mps", velocity_ff_mps),
    )


class PID:
    """Position-to-velocity PID with per-axis gains, clamping, anti-windup and wrapped yaw.

    Usage: ``velocity_mps, yaw_rate_radps = pid.step(clock.now_s(), position_m, target_m, velocity_ff_mps=v_ref)``.
    """

    def __init__(self, gains: PIDGains | None = None) -> None:
        self.gains = gains if gains is not None else PIDGains()
        self._axes = (self.gains.x, self.gains.y, self.gains.z, self.gains.yaw)
        self._flat = tuple((g.kp, g.ki, g.kd, g.output_limit, g.integral_limit) for g in self._axes)
        self._flat_xyz = self._flat[:3]
        self.reset()

    def set_gains(self, gains: PIDGains) -> None:
        """Fly ``gains`` from the next tick on (the integral and the measured rate kept)."""
        self.gains = gains
        self._axes = (gains.x, gains.y, gains.z, gains.yaw)
        self._flat = tuple((g.kp, g.ki, g.kd, g.output_limit, g.integral_limit) for g in self._axes)
        self._flat_xyz = self._flat[:3]

    def reset(self) -> None:
        """Forget the integral, the previous measurement and the previous time (e.g. after a mode change)."""
        self._integral = [0.0, 0.0, 0.0, 0.0]  # ki * integral(e), in output units, axes x, y, z, yaw
        self._rate = [0.0, 0.0, 0.0, 0.0]  # filtered measured rate (m/s, rad/s)
        self._prev_t_s: float | None = None
        self._prev_meas: list[float] | None = None  # x, y, z, yaw of the previous call
        self._yaw_active = False

    @property
    def integral(self) -> np.ndarray:
        """Current integral contributions ``ki * integral(e)`` for x, y, z, yaw (copy)."""
        return np.array(self._integral, dtype=float)

    def step(
        self,
        now_s: float,
        position_m: Sequence[float] | np.ndarray,
        target_m: Sequence[float] | np.ndarray,
        *,
        velocity_ff_mps: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        yaw_rad: float = 0.0,
        target_yaw_rad: float | None = None,
    ) -> tuple[np.ndarray, float]:
        """One control tick.

        Args:
            now_s: current time (s) of the injected clock.
            position_m: measured position (m, world frame).
            target_m: reference position (m).
            velocity_ff_mps: reference velocity (m/s) from the trajectory, added before the clamp.
            yaw_rad: measured yaw (rad).
            target_yaw_rad: reference yaw (rad); ``None`` commands zero yaw rate and resets the yaw integral.

        Returns:
            The velocity reference (m/s, shape (3,)) and the yaw-rate reference (rad/s).
        """
        vx, vy, vz, w = self.step_floats(
            now_s,
            position_m,
            target_m,
            velocity_ff_mps=velocity_ff_mps,
            yaw_rad=yaw_rad,
            target_yaw_rad=target_yaw_rad,
        )
        return np.array((vx, vy, vz)), w

    def step_floats(
        self,
        now_s: float,
        position_m: Sequence[float] | np.ndarray,
        target_m: Sequence[float] | np.ndarray,
        *,
        velocity_ff_mps: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0),
        yaw_rad: float = 0.0,
        target_yaw_rad: float | None = None,
    ) -> tuple[float, float, float, float]:
        """:meth:`step` returning plain floats ``(vx, vy, vz, yaw_rate)``: the same computation, no numpy.

        The control loops call this one (a few microseconds instead of ~20 µs on numpy 3-vectors).
        """
        px, py, pz, tx, ty, tz, fx, fy, fz = _floats9(position_m, target_m, velocity_ff_mps)
        yaw = float(yaw_rad)
        now = float(now_s)
        if not (math.isfinite(yaw) and math.isfinite(now)):
            raise InputError(f"PID yaw_rad and now_s must be finite, got {yaw_rad!r}, {now_s!r}")

        integral = self._integral
        rate = self._rate
        yaw_active = target_yaw_rad is not None
        if yaw_active and not self._yaw_active:
            integral[3] = 0.0
        self._yaw_active = yaw_active
        yaw_error = wrap_angle_rad(float(target_yaw_rad) - yaw) if target_yaw_rad is not None else 0.0
        error = (tx - px, ty - py, tz - pz, yaw_error)
        # the filtered rates from the previous measurement, and the time since it (None: none yet)
        prev_t = self._prev_t_s
        dt = None if prev_t is None else now - prev_t
        prev = self._prev_meas
        if dt is not None and dt > 0.0 and prev is not None:
            tau = self.gains.derivative_tau_s
            alpha = 1.0 if tau == 0.0 else dt / (tau + dt)
            rate[0] += alpha * ((px - prev[0]) / dt - rate[0])
            rate[1] += alpha * ((py - prev[1]) / dt - rate[1])
            rate[2] += alpha * ((pz - prev[2]) / dt - rate[2])
            rate[3] += alpha * (wrap_angle_rad(yaw - prev[3]) / dt - rate[3])
        if dt is None or dt != 0.0:
            self._prev_t_s = now
            self._prev_meas = [px, py, pz, yaw]

        integrate = dt is not None and dt > 0.0
        ff = (fx, fy, fz, 0.0)
        out = [0.0, 0.0, 0.0, 0.0]
        # Without a yaw target the yaw axis's output is not used and its integral is zeroed below: skip it.
        for i, (kp, ki, kd, out_lim, int_lim) in enumerate(self._flat if yaw_active else self._flat_xyz):
            e = error[i]
            base = ff[i] + kp * e - kd * rate[i]
            if integrate:
                # candidate = min(int_lim, max(-int_lim, ...)), written out (this loop runs 40 times a second per UAV)
                candidate = integral[i] + ki * e * dt  # type: ignore[operator]
                if not candidate >= -int_lim:
                    candidate = -int_lim
                if candidate > int_lim:  # noqa: PLR1730 (no min() call: hot loop)
                    candidate = int_lim
                unsat = base + candidate
                # Conditional integration: keep the new integral unless the output saturates and the error pushes
                # it further into saturation (the classic windup situation).
                if not (abs(unsat) > out_lim and unsat * e > 0.0):
                    integral[i] = candidate
            u = base + integral[i]
            if not u >= -out_lim:
                u = -out_lim
            if u > out_lim:  # noqa: PLR1730 (no min() call: hot loop)
                u = out_lim
            out[i] = u
        if not yaw_active:
            integral[3] = 0.0
            return out[0], out[1], out[2], 0.0
        return out[0], out[1], out[2], out[3]
