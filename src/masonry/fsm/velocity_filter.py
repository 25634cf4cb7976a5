"""A velocity consistent with the reported position, for an autopilot whose velocity estimate is not (issue 29).

PX4 v1.16 SITL (SIH, GNSS) reports a velocity its own position does not follow: measured against the simulator's
truth (``HIL_STATE_QUATERNION``) in PX4's own hover, EKF2's position tracks the truth (correlation 0.97-0.99,
0.15-0.4 s behind) while its velocity barely correlates with it (0.25-0.54) and sits up to 0.5 m/s off it for
seconds; its GNSS claims 0.4 m/s of speed accuracy, which is as much as EKF2 corrects it by (docs/hardware.md
"Against the real PX4 v1.16 SITL"). Gates that read that velocity (the swing check, the alignment's and the
hover's speed limits) see a UAV "swinging at 0.68 m/s rms" that is nearly still.

:func:`position_consistent` blends the two as a complementary filter: the reported velocity's fast part (above
``1 / tau_s``) and the position's derivative for the slow part, ``v - lowpass(v) + d/dt lowpass(p)``. The
derivative of a first-order low-pass is exact, ``(p - lowpass(p)) / tau_s``, so no finite difference amplifies
the position's noise. Where the autopilot's velocity is consistent with its position (motion capture, the
simulator, ArduCopter) the output equals it; where it is not, it follows the position.
:class:`PositionVelocityFc` lays the filter over a flight controller's telemetry (``UavConfig.velocity_from_position_s``).
"""

from __future__ import annotations

import dataclasses
import math
from typing import TYPE_CHECKING

from masonry.errors import InvalidArgument

if TYPE_CHECKING:
    from masonry.ports import FlightController, Telemetry

__all__ = ["PositionVelocity", "PositionVelocityFc"]

Vec3 = tuple[float, float, float]


class PositionVelocity:
    """The complementary filter of one position/velocity stream (world frame, SI units).

    Args:
        tau_s: the crossover time constant (s): slower than this the velocity comes from the position.
    """

    __slots__ = ("_fp", "_fv", "_last_s", "tau_s")

    def __init__(self, tau_s: float) -> None:
        if not (math.isfinite(tau_s) and tau_s > 0.0):
            raise InvalidArgument(f"tau_s must be finite and > 0, got {tau_s!r}")
        self.tau_s = float(tau_s)
        self.reset()

    def reset(self) -> None:
        """Forget the history: the next sample starts the filter (its velocity is passed through)."""
        self._last_s: float | None = None
        self._fp = [0.0, 0.0, 0.0]
        self._fv = [0.0, 0.0, 0.0]

    def update(self, now_s: float, position_m: Vec3, velocity_mps: Vec3) -> Vec3:
        """One sample; the velocity consistent with the position (m/s). A sample no later than the last one
        (the same telemetry read twice) changes nothing."""
        fp, fv = self._fp, self._fv
        if self._last_s is None:
            # started as if the position had been moving at the reported velocity: the first sample passes through
            self._last_s = now_s
            fv[:] = [float(c) for c in velocity_mps]
            fp[:] = [float(position_m[i]) - self.tau_s * fv[i] for i in range(3)]
        elif now_s > self._last_s:
            a = min(1.0, (now_s - self._last_s) / self.tau_s)
            self._last_s = now_s
            for i in range(3):
                fp[i] += a * (position_m[i] - fp[i])
                fv[i] += a * (velocity_mps[i] - fv[i])
        tau = self.tau_s
        return (
            velocity_mps[0] - fv[0] + (position_m[0] - fp[0]) / tau,
            velocity_mps[1] - fv[1] + (position_m[1] - fp[1]) / tau,
            velocity_mps[2] - fv[2] + (position_m[2] - fp[2]) / tau,
        )


def position_consistent(flt: PositionVelocity, tel: Telemetry) -> Telemetry:
    """``tel`` with its velocity replaced by the filter's; restarted on the ground or without a position."""
    if tel.on_ground or not tel.position_ok or not tel.link_ok:
        flt.reset()
        return tel
    velocity = flt.update(tel.time_s, tel.position_m, tel.velocity_mps)
    return dataclasses.replace(tel, velocity_mps=velocity)


class PositionVelocityFc:
    """A flight controller whose telemetry's velocity is :func:`position_consistent`; everything else is the
    wrapped one's (its other methods and attributes are passed through)."""

    def __init__(self, fc: FlightController, tau_s: float) -> None:
        self.inner = fc
        self.filter = PositionVelocity(tau_s)

    def telemetry(self) -> Telemetry:
        return position_consistent(self.filter, self.inner.telemetry())

    def connect(self) -> None:
        self.inner.connect()

    def close(self) -> None:
        self.inner.close()

    def arm(self) -> None:
        self.inner.arm()

    def disarm(self) -> None:
        self.inner.disarm()

    def takeoff(self, altitude_m: float, timeout_s: float | None = None) -> None:
        self.inner.takeoff(altitude_m, timeout_s)

    def land(self) -> None:
        self.inner.land()

    def send_velocity(self, velocity_mps: Vec3, yaw_rate_radps: float) -> None:
        self.inner.send_velocity(velocity_mps, yaw_rate_radps)

    def __getattr__(self, name: str) -> object:
        return getattr(self.inner, name)
