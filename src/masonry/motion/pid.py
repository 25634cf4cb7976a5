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

    Defaults are a conservative tuning for a 2-5 kg multirotor tracking mocap positions at 20-50 Hz. The
    position ``kd`` defaults to 0: the flight controller's velocity loop already damps the vehicle, and a derivative
    on the measurement would scale down the trajectory's velocity feed-forward while tracking.
    ``derivative_tau_s`` is the time constant of a first-order low-pass on the measured rate (0 for none).
    """

    x: AxisGains = field(
        default_factory=lambda: AxisGains(kp=1.2, ki=0.1, kd=0.0, output_limit=1.0, integral_limit=0.3)
    )
    y: AxisGains = field(
        default_factory=lambda: AxisGains(kp=1.2, ki=0.1, kd=0.0, output_limit=1.0, integral_limit=0.3)
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


class PID:
    """Position-to-velocity PID with per-axis gains, clamping, anti-windup and wrapped yaw.

    Usage: ``velocity_mps, yaw_rate_radps = pid.step(clock.now_s(), position_m, target_m, velocity_ff_mps=v_ref)``.
    """

    def __init__(self, gains: PIDGains | None = None) -> None:
        self.gains = gains if gains is not None else PIDGains()
        self._axes = (self.gains.x, self.gains.y, self.gains.z, self.gains.yaw)
        self.reset()

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
        pos = _floats3("position_m", position_m)
        tgt = _floats3("target_m", target_m)
        ff = _floats3("velocity_ff_mps", velocity_ff_mps)
        yaw = float(yaw_rad)
        now = float(now_s)
        if not (math.isfinite(yaw) and math.isfinite(now)):
            raise InputError(f"PID yaw_rad and now_s must be finite, got {yaw_rad!r}, {now_s!r}")

        yaw_active = target_yaw_rad is not None
        if yaw_active and not self._yaw_active:
            self._integral[3] = 0.0
        self._yaw_active = yaw_active
        yaw_error = wrap_angle_rad(float(target_yaw_rad) - yaw) if target_yaw_rad is not None else 0.0
        error = (tgt[0] - pos[0], tgt[1] - pos[1], tgt[2] - pos[2], yaw_error)
        meas = [pos[0], pos[1], pos[2], yaw]

        dt = None if self._prev_t_s is None else now - self._prev_t_s
        if dt is not None and dt > 0.0 and self._prev_meas is not None:
            tau = self.gains.derivative_tau_s
            alpha = 1.0 if tau == 0.0 else dt / (tau + dt)
            for i in range(4):
                delta = meas[i] - self._prev_meas[i]
                if i == 3:
                    delta = wrap_angle_rad(delta)
                self._rate[i] += alpha * (delta / dt - self._rate[i])
        if dt is None or dt != 0.0:
            self._prev_t_s = now
            self._prev_meas = meas

        integrate = dt is not None and dt > 0.0
        out = [0.0, 0.0, 0.0, 0.0]
        for i, g in enumerate(self._axes):
            e = error[i]
            base = (ff[i] if i < 3 else 0.0) + g.kp * e - g.kd * self._rate[i]
            if integrate and dt is not None:
                candidate = min(g.integral_limit, max(-g.integral_limit, self._integral[i] + g.ki * e * dt))
                unsat = base + candidate
                # Conditional integration: keep the new integral unless the output saturates and the error pushes
                # it further into saturation (the classic windup situation).
                winding = abs(unsat) > g.output_limit and unsat * e > 0.0
                if not winding:
                    self._integral[i] = candidate
            if i == 3 and not yaw_active:
                self._integral[3] = 0.0
            out[i] = min(g.output_limit, max(-g.output_limit, base + self._integral[i]))
        return np.array(out[:3]), (out[3] if yaw_active else 0.0)
