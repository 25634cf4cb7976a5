"""The first hover's identification: small velocity doublets over the take-off point, the lag fitted (issue 29).

With ``identify_first_hover`` (uav.yaml ``tuning: identify``) the take-off's hover, before the first leg, flies
:class:`FirstHover`'s schedule: ``STILL_S`` holding still (the hover's speed noise), then along x and then y
``DOUBLETS`` velocity doublets (``+DOUBLET_MPS`` for ``DOUBLET_S``, ``-DOUBLET_MPS`` as long, then ``REST_S`` of
none) on a reference position that goes out ``DOUBLET_MPS x DOUBLET_S`` = 8 cm and back, held by a weak position
loop (``HOLD_KP_PER_S``). The UAV holds the column over its pad then (mission control's take-off column,
:func:`masonry.mission.airspace_ground.take_off`): the reference stays within the tracking share the separation
allows each UAV around its volume (:data:`masonry.separation.TRACK_SHARE_M`, 10 cm); a UAV blown more than
``EXCURSION_LIMIT_M`` off it stops the steps at once and flies the preset.

:func:`fit_lag` fits a first-order lag behind a dead time (gain and offset by least squares) to the measured
velocity against the command sent, over a grid of delays and time constants: the lag is dead time + time
constant (to 63 % of a step), as ``masonry fly --identify`` measures it, but read from the whole record, so that
small steps in a noisy hover still give it. :func:`masonry.fsm.hover_gains.derive_gains` turns it into gains.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from masonry.fsm.hover_gains import HoverFit
from masonry.ports import Telemetry
from masonry.separation import TRACK_SHARE_M

Vec3 = tuple[float, float, float]

STILL_S = 2.0
DOUBLET_S = 0.5
DOUBLET_MPS = 0.8 * TRACK_SHARE_M / DOUBLET_S  # 0.16 m/s: the reference goes 8 cm out and back
REST_S = 1.5
DOUBLETS = 2
HOLD_KP_PER_S = 0.5  # stable behind lags up to pi / (2 x 0.5) = 3.1 s
#: Farther than this off the hover point (m), the steps stop: the preset is flown (a gust, a wind).
EXCURSION_LIMIT_M = 0.3
_AXIS_S = DOUBLETS * (2.0 * DOUBLET_S + REST_S)
DURATION_S = STILL_S + 2.0 * _AXIS_S
_DELAYS_S = np.arange(0.0, 1.0001, 0.05)
_TAUS_S = np.geomspace(0.05, 1.5, 24)
_GRID_S = 0.01


def reference(t_s: float) -> tuple[int, float, float]:
    """The excited axis (0 x, 1 y; -1 still), its reference velocity and position offset, ``t_s`` into the hover."""
    if t_s < STILL_S:
        return -1, 0.0, 0.0
    u = t_s - STILL_S
    axis = 0 if u < _AXIS_S else 1
    u = (u - axis * _AXIS_S) % (2.0 * DOUBLET_S + REST_S)
    if u < DOUBLET_S:
        return axis, DOUBLET_MPS, DOUBLET_MPS * u
    if u < 2.0 * DOUBLET_S:
        return axis, -DOUBLET_MPS, DOUBLET_MPS * (2.0 * DOUBLET_S - u)
    return axis, 0.0, 0.0


class FirstHover:
    """The schedule in flight: :meth:`command` each tick, then :meth:`fit` (see the module's docstring)."""

    def __init__(self, start_s: float, hold_m: Sequence[float]) -> None:
        self.start_s = float(start_s)
        self.hold_m = (float(hold_m[0]), float(hold_m[1]), float(hold_m[2]))
        #: (seconds in, axis, command along it, measured velocity along it) of the excited ticks
        self.samples: list[tuple[float, int, float, float]] = []
        self.still_sq: list[float] = []  # squared horizontal speeds in the still part's second half
        self.excursion_m = 0.0
        self.done = False

    def command(self, now_s: float, tel: Telemetry) -> Vec3 | None:
        """The velocity to send this tick (None: the schedule is over, or stopped: blown off the hover)."""
        t = now_s - self.start_s
        x, y, z = tel.position_m
        off_x, off_y = x - self.hold_m[0], y - self.hold_m[1]
        self.excursion_m = max(self.excursion_m, math.hypot(off_x, off_y))
        if self.done or t >= DURATION_S or self.excursion_m > EXCURSION_LIMIT_M:
            self.done = True
            return None
        axis, v_ref, p_ref = reference(t)
        cmd = [HOLD_KP_PER_S * -off_x, HOLD_KP_PER_S * -off_y, HOLD_KP_PER_S * (self.hold_m[2] - z)]
        if axis >= 0:
            cmd[axis] += v_ref + HOLD_KP_PER_S * p_ref
            self.samples.append((t, axis, cmd[axis], float(tel.velocity_mps[axis])))
        elif t >= STILL_S / 2.0:
            self.still_sq.append(float(tel.velocity_mps[0]) ** 2 + float(tel.velocity_mps[1]) ** 2)
        return (cmd[0], cmd[1], cmd[2])

    def fit(self) -> HoverFit:
        """The lag model fitted to the samples (non-finite fields: too few of them)."""
        noise = math.sqrt(sum(self.still_sq) / len(self.still_sq)) if self.still_sq else math.inf
        lag, delay, gain, share = fit_lag(self.samples)
        return HoverFit(lag, delay, gain, share, noise, self.excursion_m, EXCURSION_LIMIT_M)


def fit_lag(samples: Sequence[tuple[float, int, float, float]]) -> tuple[float, float, float, float]:
    """(lag, delay, gain, R^2) of a first-order lag behind a dead time fitted to (t, axis, command, velocity)."""
    per_axis = []
    for axis in (0, 1):
        rows = [(t, c, v) for t, a, c, v in samples if a == axis]
        if len(rows) >= 8:
            per_axis.append(np.array(rows))
    if not per_axis:
        return math.nan, math.nan, math.nan, math.nan
    # here: the state machines (and `masonry --help`) import no scipy until a fit
    from scipy.signal import lfilter

    best = (math.inf, math.nan, math.nan, math.nan, math.nan)
    measured = np.concatenate([r[:, 2] for r in per_axis])
    total = float(np.sum((measured - measured.mean()) ** 2))
    for delay in _DELAYS_S:
        shifted = [_held(r, delay) for r in per_axis]
        for tau in _TAUS_S:
            a = math.exp(-_GRID_S / tau)
            model = np.concatenate(
                [
                    np.interp(r[:, 0], grid, lfilter([1.0 - a], [1.0, -a], u))
                    for r, (grid, u) in zip(per_axis, shifted)
                ]
            )
            design = np.column_stack([model, np.ones_like(model)])
            coef, *_ = np.linalg.lstsq(design, measured, rcond=None)
            sse = float(np.sum((design @ coef - measured) ** 2))
            if sse < best[0]:
                best = (
                    sse,
                    float(delay + tau),
                    float(delay),
                    float(coef[0]),
                    1.0 - sse / total if total > 0 else 0.0,
                )
    return best[1], best[2], best[3], best[4]


def _held(rows: np.ndarray, delay_s: float) -> tuple[np.ndarray, np.ndarray]:
    """A fine time grid over ``rows`` and the command held from each tick, ``delay_s`` late (0 before)."""
    grid = np.arange(rows[0, 0], rows[-1, 0] + _GRID_S / 2.0, _GRID_S)
    idx = np.searchsorted(rows[:, 0], grid - delay_s, side="right") - 1
    u = np.where(idx >= 0, rows[np.clip(idx, 0, None), 1], 0.0)
    return grid, u
