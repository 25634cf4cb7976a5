"""A take-off climb inside OFFBOARD, monitored against its progress (PX4; issue 20): pure, no I/O.

PX4 has no GUIDED-style take-off inside OFFBOARD: the ground station streams the climb. A P-law on the altitude
error (the adapter's first climb) commands less and less near the target while PX4's thrust ramps up slowly
from the ground (its smooth take-off, ``MPC_TKO_RAMP_T``): on PX4 v1.16 SITL it reached 1.09 m of 1.54 m in its
20 s and sagged back. :class:`ClimbMonitor` commands the climb speed until the approach, never less than
``min_speed_mps`` while short of the target (so the climb cannot sag short of it), ends on *reached and
steady* (within ``tolerance_m`` and slower than ``steady_speed_mps`` for ``steady_s``) and says why when it does
not: no progress over ``progress_window_s`` after the ramp's grace, or the time-out.

A stall once the climb has lifted ``own_loop_lift_m`` above where it began (off the ground, where a zero
acceleration would lift) hands it to masonry's own velocity loop instead of failing it, where the adapter flies one
(``ClimbConfig.own_loop``; :attr:`ClimbMonitor.own_loop`), with a fresh progress window: PX4's loop closes on EKF2's
vertical velocity, which on PX4 v1.16 SITL under load sat far enough off the position's that a 0.12 m/s approach
gained 5 cm in 4 s, and the climb failed "stalled at 0.99 m of 1.09 m" (issue 29). A second stall fails it.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Literal

from masonry.ports import TAKEOFF_TIMEOUT_S

__all__ = ["REPORT_MARGIN_S", "ClimbConfig", "ClimbMonitor", "ClimbState", "climb_limit_s"]

#: How long (s of the autopilot's clock) before the caller's take-off time-out the adapter ends a climb it flies
#: or watches (PX4's in OFFBOARD, ArduPilot's own) and says why (``takeoff_problem``): the machine, giving the
#: take-off up at its time-out, then has the reason, and its next setpoints are flown.
REPORT_MARGIN_S = 2.0


def climb_limit_s(timeout_s: float | None) -> float:
    """How long (s of the autopilot's clock) the adapter lets a take-off climb run: the caller's ``timeout_s``
    (the machine's ``takeoff_timeout_s``, what is left of it; None: ``TAKEOFF_TIMEOUT_S``) less
    :data:`REPORT_MARGIN_S`, or less a tenth of it when that is shorter. One number, the machine's, wins: the
    machine is what gives the task up, and a user sets it (``control: takeoff_timeout_s`` in uav.yaml)."""
    total_s = TAKEOFF_TIMEOUT_S if timeout_s is None else max(0.0, float(timeout_s))
    return total_s - min(REPORT_MARGIN_S, 0.1 * total_s)


ClimbState = Literal["climbing", "reached", "stalled", "timeout"]


@dataclass(frozen=True)
class ClimbConfig:
    """The take-off climb's law and its monitor (SI units)."""

    climb_speed_mps: float = 0.5
    approach_gain_per_s: float = 1.0  # within climb_speed / gain of the target: v = gain x the error
    min_speed_mps: float = 0.12  # the least climb while more than tolerance_m short (no sag)
    tolerance_m: float = 0.05
    steady_speed_mps: float = 0.1
    steady_s: float = 1.0
    grace_s: float = 6.0  # the thrust ramp: no progress is expected before this
    progress_window_s: float = 4.0
    min_progress_m: float = 0.05
    timeout_s: float = 30.0
    own_loop: bool = False  # the adapter can fly the climb on masonry's own velocity loop (PX4, issue 29)
    own_loop_lift_m: float = 0.3  # this far above where it began the climb is airborne (ClimbMonitor.lifted)


class ClimbMonitor:
    """One take-off climb from ``start_s`` to ``target_m`` (world altitude): the command each tick, the outcome.

    Args:
        start_s: when the take-off was asked for (the caller's clock, s).
        target_m: the altitude to reach (world, m).
        config: the law and the monitor's limits.
    """

    def __init__(self, start_s: float, target_m: float, config: ClimbConfig | None = None) -> None:
        self.config = config or ClimbConfig()
        self.start_s = float(start_s)
        self.target_m = float(target_m)
        self.state: ClimbState = "climbing"
        self.reason: str | None = None
        self._history: deque[tuple[float, float]] = deque()
        self._steady_since_s: float | None = None
        self._rate_mps = 0.0
        self._last_s: float | None = None
        self._first_altitude_m: float | None = None
        self._lifted = False
        #: a stall handed the climb to masonry's own velocity loop (``ClimbConfig.own_loop``): the adapter flies it
        self.own_loop = False

    @property
    def done(self) -> bool:
        """The climb is over: reached, or given up (``reason`` says why)."""
        return self.state != "climbing"

    @property
    def lifted(self) -> bool:
        """The climb has risen ``own_loop_lift_m`` above the first altitude it was stepped with (it stays so)."""
        return self._lifted

    def step(self, now_s: float, altitude_m: float, climb_mps: float) -> float:
        """The climb speed to command now (m/s, up) for the altitude and climb rate measured; 0 once done."""
        if self.done:
            return 0.0
        cfg = self.config
        if self._first_altitude_m is None:
            self._first_altitude_m = altitude_m
        self._lifted = self._lifted or altitude_m - self._first_altitude_m >= cfg.own_loop_lift_m
        dt = 0.0 if self._last_s is None else max(0.0, now_s - self._last_s)
        self._last_s = now_s
        # the climb rate smoothed over about a quarter second: EKF2's vertical speed is noisy (+-0.2 m/s)
        self._rate_mps += min(1.0, dt / 0.25) * (climb_mps - self._rate_mps) if dt > 0.0 else 0.0
        error = self.target_m - altitude_m
        if abs(error) <= cfg.tolerance_m and abs(self._rate_mps) <= cfg.steady_speed_mps:
            if self._steady_since_s is None:
                self._steady_since_s = now_s
            if now_s - self._steady_since_s >= cfg.steady_s:
                self.state = "reached"
                return 0.0
        else:
            self._steady_since_s = None
        self._history.append((now_s, altitude_m))
        while self._history and self._history[0][0] < now_s - cfg.progress_window_s:
            self._history.popleft()
        elapsed = now_s - self.start_s
        if elapsed > cfg.timeout_s:
            self.state = "timeout"
            self.reason = (
                f"take-off not steady at {self.target_m:.2f} m within {cfg.timeout_s:.0f} s "
                f"(at {altitude_m:.2f} m, climbing {self._rate_mps:+.2f} m/s)"
            )
            return 0.0
        if elapsed > cfg.grace_s and error > 2.0 * cfg.tolerance_m:
            t0, z0 = self._history[0]
            if now_s - t0 >= 0.9 * cfg.progress_window_s and altitude_m - z0 < cfg.min_progress_m:
                if cfg.own_loop and self._lifted and not self.own_loop:
                    self.own_loop = True  # the rest on the own loop, a fresh window to show progress in
                    self._history.clear()
                    self._history.append((now_s, altitude_m))
                    return self._command(error)
                self.state = "stalled"
                self.reason = (
                    f"take-off stalled at {altitude_m:.2f} m of {self.target_m:.2f} m: "
                    f"{altitude_m - z0:+.2f} m in the last {now_s - t0:.0f} s, {elapsed:.0f} s after it began "
                    "(is the thrust enough, the vehicle free to climb?)"
                )
                return 0.0
        return self._command(error)

    def hand_over(self, altitude_m: float, climb_mps: float, within_m: float = 0.1) -> bool:
        """The caller wants to fly on (a velocity setpoint): end the climb as reached if it is within ``within_m``
        of the target and slower than ``steady_speed_mps`` (True), else keep climbing (False)."""
        if self.done:
            return self.state == "reached"
        near = abs(self.target_m - altitude_m) <= within_m and abs(climb_mps) <= self.config.steady_speed_mps
        if near:
            self.state = "reached"
        return near

    def _command(self, error_m: float) -> float:
        cfg = self.config
        v = cfg.approach_gain_per_s * error_m
        if error_m > cfg.tolerance_m:
            v = max(v, cfg.min_speed_mps)
        return math.copysign(min(abs(v), cfg.climb_speed_mps), v)
