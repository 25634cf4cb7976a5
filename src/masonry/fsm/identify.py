"""``masonry fly --identify``: measure a connected autopilot's velocity response and suggest the control tuning.

The UAV takes off to a safe hover, holds still (the hover's position noise is measured), then flies velocity
steps along x and y (0 -> +v -> 0 -> -v -> 0, each held ``step_s``). From each step's response it takes the time
to 10 %, 63 % and 90 % of the step and the overshoot; the median time to 63 % is the *lag* the position loop sees
(dead time plus the velocity loop's time constant). From it:

- ``velocity_lag_s`` = the lag (the legs' acceleration feed-forward, :class:`~masonry.fsm.UavConfig`);
- the horizontal ``kp`` a third of the proportional loop's stability limit, pi / (2 x lag) (an integrator behind
  a delay L oscillates at kp = pi / (2 L)), and ``ki`` = 0.2 x kp (the ArduCopter preset, 1.0 and 0.2, is this
  rule at the 0.57 s lag issue 19 measured);
- the hover gates (``ask_settle_tolerance_m``, ``settle_speed_mps``) at least three standard deviations of the
  measured hover noise (position and speed), never below the defaults.

Everything here runs on the flight-controller port and the clock the caller gives (the autopilot's clock on
hardware, simulated time in the simulator), so a test identifies the simulated vehicle in simulated time.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from masonry.errors import HardwareError
from masonry.fsm.config import UavConfig
from masonry.ports import Clock, FlightController

#: Fractions of the step whose crossing times are measured.
_FRACTIONS = (0.1, 0.632, 0.9)


@dataclass(frozen=True)
class StepResponse:
    """One velocity step along ``axis``: commanded ``from_mps`` -> ``to_mps`` at ``start_s``."""

    axis: str
    start_s: float
    from_mps: float
    to_mps: float
    t10_s: float | None  # seconds from the command to 10 % of the step (None: never reached)
    t63_s: float | None
    t90_s: float | None
    overshoot: float  # the largest excursion past the step, as a fraction of it

    def to_dict(self) -> dict[str, Any]:
        return {
            "axis": self.axis,
            "from_mps": self.from_mps,
            "to_mps": self.to_mps,
            "t10_s": _r(self.t10_s),
            "t63_s": _r(self.t63_s),
            "t90_s": _r(self.t90_s),
            "overshoot": round(self.overshoot, 3),
        }


@dataclass(frozen=True)
class Identification:
    """What ``--identify`` measured and what it suggests (uav.yaml keys)."""

    steps: tuple[StepResponse, ...]
    hover_position_std_m: float  # horizontal, about the hover's mean
    hover_speed_rms_mps: float
    lag_s: float  # median time to 63 % of a step
    delay_s: float  # median time to 10 %
    kp: float
    ki: float
    ask_settle_tolerance_m: float
    settle_speed_mps: float

    @property
    def stability_limit_kp(self) -> float:
        return math.pi / (2.0 * self.lag_s)

    def suggestion(self) -> dict[str, Any]:
        """The uav.yaml settings it suggests."""
        return {
            "velocity_lag_s": round(self.lag_s, 2),
            "control": {
                "ask_settle_tolerance_m": round(self.ask_settle_tolerance_m, 3),
                "settle_speed_mps": round(self.settle_speed_mps, 3),
            },
            "pid": {"xy": {"kp": self.kp, "ki": self.ki}},
        }

    def to_dict(self) -> dict[str, Any]:
        return {
            "lag_s": round(self.lag_s, 3),
            "delay_s": round(self.delay_s, 3),
            "stability_limit_kp": round(self.stability_limit_kp, 2),
            "hover_position_std_m": round(self.hover_position_std_m, 4),
            "hover_speed_rms_mps": round(self.hover_speed_rms_mps, 4),
            "steps": [s.to_dict() for s in self.steps],
            "suggested": self.suggestion(),
        }

    def lines(self) -> list[str]:
        out = [
            f"hover: position noise {self.hover_position_std_m * 100:.1f} cm (std, horizontal), "
            f"speed {self.hover_speed_rms_mps:.3f} m/s (rms)"
        ]
        for s in self.steps:
            times = ", ".join(
                f"{name} {'-' if t is None else f'{t:.2f} s'}"
                for name, t in (("10%", s.t10_s), ("63%", s.t63_s), ("90%", s.t90_s))
            )
            out.append(
                f"step {s.axis} {s.from_mps:+.2f} -> {s.to_mps:+.2f} m/s: {times}, overshoot {s.overshoot:.0%}"
            )
        out.append(
            f"lag (median time to 63 %) {self.lag_s:.2f} s, delay (to 10 %) {self.delay_s:.2f} s: a proportional "
            f"position loop oscillates from kp {self.stability_limit_kp:.2f} /s"
        )
        sug = self.suggestion()
        out.append("suggested uav.yaml:")
        out.append(f"  velocity_lag_s: {sug['velocity_lag_s']}")
        out.append(
            f"  control: {{ask_settle_tolerance_m: {sug['control']['ask_settle_tolerance_m']}, "
            f"settle_speed_mps: {sug['control']['settle_speed_mps']}}}"
        )
        out.append(f"  pid: {{xy: {{kp: {self.kp}, ki: {self.ki}}}}}")
        return out


def _r(v: float | None) -> float | None:
    return None if v is None else round(v, 3)


def step_response(
    axis: str,
    start_s: float,
    from_mps: float,
    to_mps: float,
    times_s: Sequence[float],
    speeds_mps: Sequence[float],
) -> StepResponse:
    """The crossing times and overshoot of one step from samples (time, measured speed along the axis)."""
    span = to_mps - from_mps
    crossings: list[float | None] = []
    for frac in _FRACTIONS:
        hit = next((t - start_s for t, v in zip(times_s, speeds_mps) if (v - from_mps) / span >= frac), None)
        crossings.append(hit)
    peak = max(((v - from_mps) / span for v in speeds_mps), default=0.0)
    t10, t63, t90 = crossings
    return StepResponse(axis, start_s, from_mps, to_mps, t10, t63, t90, overshoot=max(0.0, peak - 1.0))


def suggest(
    steps: Sequence[StepResponse], hover_std_m: float, hover_speed_rms_mps: float, defaults: UavConfig
) -> Identification:
    """The lag and the tuning from measured steps and hover noise (see the module docstring)."""
    t63 = [s.t63_s for s in steps if s.t63_s is not None]
    t10 = [s.t10_s for s in steps if s.t10_s is not None]
    if not t63:
        raise HardwareError(
            "no velocity step reached 63 % of its command: the autopilot does not follow them"
        )
    lag = statistics.median(t63)
    limit = math.pi / (2.0 * lag)
    kp = round(limit / 3.0, 2)
    return Identification(
        steps=tuple(steps),
        hover_position_std_m=hover_std_m,
        hover_speed_rms_mps=hover_speed_rms_mps,
        lag_s=lag,
        delay_s=statistics.median(t10) if t10 else lag,
        kp=kp,
        ki=round(0.2 * kp, 2),
        ask_settle_tolerance_m=max(defaults.ask_settle_tolerance_m, 3.0 * hover_std_m),
        settle_speed_mps=max(defaults.settle_speed_mps, 3.0 * hover_speed_rms_mps),
    )


def identify(
    fc: FlightController,
    clock: Clock,
    advance: Callable[[float], None],
    *,
    config: UavConfig,
    altitude_m: float = 1.5,
    step_mps: float = 0.5,
    step_s: float = 4.0,
    hover_s: float = 5.0,
    dt_s: float = 0.05,
    timeout_s: float = 60.0,
) -> Identification:
    """Take off, hover, fly the steps, land; the measurements (the caller connects and closes ``fc``).

    Raises:
        HardwareError: take-off or landing not done within ``timeout_s``, or no step followed.
    """
    fc.arm()
    ground = fc.telemetry().position_m[2]  # once armed: the ground the autopilot climbs from (issue 29)
    fc.takeoff(altitude_m)

    def wait(done: Callable[[Any], bool], what: str) -> None:
        start = clock.now_s()
        while not done(fc.telemetry()):
            if clock.now_s() - start > timeout_s:
                raise HardwareError(f"identification: {what} not done in {timeout_s:g} s")
            advance(dt_s)

    wait(lambda t: t.position_m[2] >= ground + altitude_m - 0.15 and abs(t.velocity_mps[2]) < 0.1, "take-off")
    try:
        hover = _fly(fc, clock, advance, [((0.0, 0.0, 0.0), hover_s)], dt_s)
        tail = [s for s in hover if s[0] >= hover[0][0] + hover_s / 2.0]  # its second half: settled
        xy = np.array([s[1][:2] for s in tail])
        std = float(np.sqrt(np.mean(np.sum((xy - xy.mean(axis=0)) ** 2, axis=1))))
        speed = float(np.sqrt(np.mean([s[2][0] ** 2 + s[2][1] ** 2 + s[2][2] ** 2 for s in tail])))
        steps: list[StepResponse] = []
        for i, axis in enumerate(("x", "y")):
            levels = (step_mps, 0.0, -step_mps, 0.0)
            plan = [(tuple(v if k == i else 0.0 for k in range(3)), step_s) for v in levels]
            samples = _fly(fc, clock, advance, plan, dt_s)
            start = samples[0][0]
            previous = 0.0
            for j, level in enumerate(levels):
                s0 = start + j * step_s
                seg = [s for s in samples if s0 <= s[0] < s0 + step_s]
                steps.append(
                    step_response(axis, s0, previous, level, [s[0] for s in seg], [s[2][i] for s in seg])
                )
                previous = level
    finally:
        fc.land()
    wait(lambda t: t.on_ground, "landing")
    return suggest(steps, std, speed, config)


Sample = tuple[float, tuple[float, float, float], tuple[float, float, float]]


def _fly(
    fc: FlightController,
    clock: Clock,
    advance: Callable[[float], None],
    plan: Sequence[tuple[tuple[float, ...], float]],
    dt_s: float,
) -> list[Sample]:
    """Command each (velocity, seconds) of ``plan`` in turn; (time, position, velocity) at every tick."""
    out: list[Sample] = []
    start = clock.now_s()
    end = start
    for velocity, seconds in plan:
        end += seconds
        while clock.now_s() < end:
            fc.send_velocity((velocity[0], velocity[1], velocity[2]), 0.0)
            tel = fc.telemetry()
            out.append((clock.now_s(), tuple(tel.position_m), tuple(tel.velocity_mps)))  # type: ignore[arg-type]
            advance(dt_s)
    return out
