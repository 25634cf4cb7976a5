"""The position gains a first hover's identification gives, within stable limits, or the preset's with a reason.

:mod:`masonry.fsm.first_hover` measures the autopilot's velocity response on the first hover (issue 29): a lag
(dead time plus time constant: the time to 63 % of a step), how much of the measured velocity that model explains,
the hover's speed noise and how far the UAV strayed. :func:`derive_gains` turns it into the horizontal gains by
the rule of :mod:`masonry.fsm.identify` (a third of the proportional loop's stability limit pi / (2 x lag),
``ki`` = 0.2 x ``kp``; the ``arducopter`` preset's 1.0 / 0.2 at its 0.57 s lag), clamped to
[:data:`KP_MIN_PER_S`, :data:`KP_MAX_PER_S`] and never above half the limit; or, when the measurement is unusable
(too noisy, too slow, not following the commands, blown off its hover), None and the reason: the UAV then flies
its autopilot's preset.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: The lags (s) a derivation accepts: below, a response faster than the loop's tick cannot be told from noise;
#: above, too slow an autopilot to place bricks with (ArduCopter's default 0.57 s, PX4 through masonry's loop ~0.4 s).
LAG_MIN_S = 0.1
LAG_MAX_S = 1.5
#: The horizontal kp (1/s) a derivation stays within: the fastest is the simulated ideal vehicle's default.
KP_MIN_PER_S = 0.4
KP_MAX_PER_S = 3.0
#: kp as a fraction of the stability limit pi / (2 lag) (the --identify rule), never over STABLE_FRACTION_MAX.
KP_FRACTION_OF_LIMIT = 1.0 / 3.0
STABLE_FRACTION_MAX = 0.5
KI_PER_KP = 0.2  # 1/s
#: The least share of the measured velocity's variance the fitted lag model explains (else: too noisy).
FIT_MIN = 0.5
#: The fitted gain of the response (measured / commanded speed) outside this: the autopilot did not follow.
GAIN_RANGE = (0.5, 1.5)
#: The hover's speed noise (rms, m/s) above which the steps cannot be read (gusts, a swinging hover).
HOVER_NOISE_MAX_MPS = 0.25


@dataclass(frozen=True)
class HoverFit:
    """What the first hover measured (:mod:`masonry.fsm.first_hover`)."""

    lag_s: float  # dead time + time constant: to 63 % of a step
    delay_s: float
    gain: float  # measured / commanded speed at rest (1: follows)
    fit: float  # the share of the measured velocity's variance the model explains (R^2)
    hover_noise_mps: float  # speed rms in the still part, before the steps
    excursion_m: float  # the largest horizontal distance from the hover point
    excursion_limit_m: float


@dataclass(frozen=True)
class HoverTuning:
    """The derived gains (``kp`` None: unusable, fly the preset because of ``reason``) and one line saying so."""

    kp: float | None
    ki: float | None
    lag_s: float | None
    reason: str

    @property
    def usable(self) -> bool:
        return self.kp is not None

    def line(self) -> str:
        """``identified on first hover: lag 0.57 s (fit 90%, 6 cm off the hover at most) -> kp 0.92 /s, ...``."""
        if self.kp is None:
            return f"first hover's identification unusable ({self.reason}): flies its preset's gains"
        return f"identified on first hover: {self.reason} -> kp {self.kp:.2f} /s, ki {self.ki:.3f} /s^2"


def stability_limit_kp(lag_s: float) -> float:
    """The proportional position gain (1/s) at which a loop behind ``lag_s`` of delay oscillates."""
    return math.pi / (2.0 * lag_s)


def gains_for_lag(lag_s: float) -> tuple[float, float]:
    """(kp, ki) for a lag within [LAG_MIN_S, LAG_MAX_S]: a third of the limit, clamped, under half of it."""
    limit = stability_limit_kp(lag_s)
    kp = min(KP_MAX_PER_S, max(KP_MIN_PER_S, KP_FRACTION_OF_LIMIT * limit), STABLE_FRACTION_MAX * limit)
    kp = round(kp, 2)
    return kp, round(KI_PER_KP * kp, 3)


def derive_gains(m: HoverFit) -> HoverTuning:
    """The gains from a first hover's measurement, or why it is unusable (checked in this order)."""
    if not all(math.isfinite(v) for v in (m.lag_s, m.gain, m.fit, m.hover_noise_mps, m.excursion_m)):
        return HoverTuning(None, None, None, "no measurement")
    if m.excursion_m > m.excursion_limit_m:
        return HoverTuning(
            None,
            None,
            None,
            f"blown {m.excursion_m:.2f} m off its hover, over {m.excursion_limit_m:.2f} m: wind?",
        )
    if m.hover_noise_mps > HOVER_NOISE_MAX_MPS:
        return HoverTuning(
            None, None, None, f"the hover swings at {m.hover_noise_mps:.2f} m/s rms: too noisy (wind?)"
        )
    if m.fit < FIT_MIN:
        return HoverTuning(
            None, None, None, f"a lag model explains {m.fit:.0%} of the measured velocity: too noisy"
        )
    if not GAIN_RANGE[0] <= m.gain <= GAIN_RANGE[1]:
        return HoverTuning(None, None, None, f"it flew {m.gain:.2f} of the commanded speed: not following")
    if m.lag_s > LAG_MAX_S:
        return HoverTuning(None, None, None, f"lag {m.lag_s:.2f} s: too slow (over {LAG_MAX_S:g} s)")
    lag = max(LAG_MIN_S, m.lag_s)
    kp, ki = gains_for_lag(lag)
    return HoverTuning(
        kp,
        ki,
        lag,
        f"lag {m.lag_s:.2f} s (fit {m.fit:.0%}, {m.excursion_m * 100:.0f} cm off the hover at most)",
    )
