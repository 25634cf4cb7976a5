"""The wall's offset carried past the last sighting (issue 30): the GNSS wander's trend, extrapolated.

The wall alignment (:mod:`masonry.fsm.wall_align`) puts the drop-off at the mean of the wall's offset over its last
five frames: ``(true - design) + e(t)``, the bricks' own deviation plus the position source's error ``e`` at those
frames. At the release the target is that mean's age old: half a second on a pyramid (the five frames span 0.4 s
and more when a sighting is missed), 0.5-0.8 s on a tower (its support leaves the view in the last leg, 0.3-0.4 s
before the release). The ``px4`` model's wander moves 6.4 mm rms per axis in 0.5 s, and much more at times (30-60
mm/s in a trace of the towers, seed 0): the worst bricks' targets were 15-25 mm off where their supports were.

EKF2's error is smooth (:data:`masonry.sim.shaping.PX4`: an Ornstein-Uhlenbeck wander of 8 s smoothed over 2 s,
as EKF2's output predictor smooths it): its rate holds over a second. :class:`WallTrend` fits the rate to the
offsets of the last ``span_s`` seconds (a straight line through at least ``MIN_FRAMES`` frames of one set of
reference bricks) and moves the target by that rate times the age of the wall alignment's mean, at most
``MAX_SHIFT_M``: the target follows the wander through the frames missed and the last leg. With the wall out of
view for longer (a release after the looks, :mod:`masonry.fsm.release_gate`) too few frames of the span are left
and nothing is carried: the last mean stands, as before (carried on, the px4 towers' worst brick, let go 1.0 s
after its last sighting, landed 27.6 mm off its support). A source with no
trend (motion capture, a camera rendered from the reported position) gives a rate of noise: the target stays
within a millimetre or two (the shift's deadband :data:`SHIFT_M`).

With ``UavConfig.wall_drift_mps_per_sqrt_s`` (the ``px4`` preset's 0.015) the straight line gives way to a Kalman
filter on the wander's drift (:mod:`masonry.fsm.wall_drift`, issue 30, branch ``drift30``): the target moves by
the filter's prediction now less the mean of the frames it is, at any age (the rate it carries relaxes over 2 s,
so a long-stale release is not carried far). The px4 towers' bricks against their neighbours, seeds 0-9 and
10-19: 11.9 / 51.9 and 11.8 / 26.7 mm mean / max, 3 and 6 of 60 over 2 cm -> 10.8 / 22.2 and 10.5 / 22.5, 3 and
2 of 60 (docs/performance/as-built.md).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Hashable

import numpy as np

from masonry.fsm.wall_drift import DriftFilter

__all__ = ["MAX_SHIFT_M", "MIN_FRAMES", "SHIFT_M", "WallTrend"]

#: Frames over the span needed to fit the rate (the span must also be over 60 % covered by them).
MIN_FRAMES = 8
#: The extrapolated shift is capped at this (m): beyond it the line is not to be trusted.
MAX_SHIFT_M = 0.03
#: The target moves when the extrapolation has changed by more than this (m).
SHIFT_M = 0.001


class WallTrend:
    """The offsets of one placement's frames and the shift that carries the target to now.

    Args:
        span_s: the rate is fitted over the frames of this last stretch of time (s; 0: no extrapolation).
    """

    def __init__(self, span_s: float) -> None:
        self.span_s = span_s
        #: > 0: the offset is predicted by :class:`~masonry.fsm.wall_drift.DriftFilter` with this rate noise
        #: (m/s per square-root second) and :attr:`drift_tau_s`, not by the straight line
        self.drift_mps_per_sqrt_s = 0.0
        self.drift_tau_s = 2.0
        self._drift: DriftFilter | None = None
        self._mean_offsets: deque[np.ndarray] = deque(maxlen=1)
        self._frames: deque[tuple[float, np.ndarray]] = deque()
        self._key: Hashable | None = None
        self._mean_times: deque[float] = deque(maxlen=1)
        self._mean_t: float | None = None
        #: the shift now applied on top of the wall alignment's target (world, m)
        self.shift_m = np.zeros(3)
        #: the wall alignment's mean is over its frames no older than this (s) before the newest
        #: (:attr:`masonry.fsm.camera_align.CameraAlign.span_s`)
        self.mean_span_s = math.inf

    def reset(self, size: int) -> None:
        """A new placement; the wall alignment averages its last ``size`` frames."""
        self._frames.clear()
        self._key = None
        self._mean_times = deque(maxlen=size)
        self._mean_offsets = deque(maxlen=size)
        self._mean_t = None
        self._drift = None
        self.shift_m = np.zeros(3)

    def add(self, now_s: float, offset_m: np.ndarray, key: Hashable) -> None:
        """One frame's offset of the wall (``key``: the reference bricks it is the mean of; a new set starts a new
        line). The wall alignment's target is the mean of its last frames (or within its deadband of it): as old
        as their mean time."""
        if key != self._key:
            self._key = key
            self._frames.clear()
            if self._drift is not None:
                self._drift.reset()
        self._frames.append((now_s, np.asarray(offset_m, dtype=float)))
        if self.drift_mps_per_sqrt_s > 0.0:
            if self._drift is None:
                self._drift = DriftFilter(self.drift_mps_per_sqrt_s, self.drift_tau_s)
            self._drift.add(now_s, offset_m)
        self._mean_offsets.append(np.asarray(offset_m, dtype=float))
        while self._frames and now_s - self._frames[0][0] > self.span_s:
            self._frames.popleft()
        self._mean_times.append(now_s)
        # the wall alignment's mean leaves out the frames older than its span before this one (CameraAlign.span_s)
        while self._mean_times[0] < now_s - self.mean_span_s:
            self._mean_times.popleft()
            self._mean_offsets.popleft()
        self._mean_t = float(np.mean(self._mean_times))

    def rate_mps(self, now_s: float) -> np.ndarray | None:
        """The offset's horizontal rate (m/s) over the last ``span_s`` up to now (None: too few frames in it to say:
        with the wall out of view for over ``0.4 * span_s`` the line is not carried on, the last mean stands)."""
        frames = [(t, o) for t, o in self._frames if now_s - t <= self.span_s]
        if self.span_s <= 0.0 or len(frames) < MIN_FRAMES or frames[-1][0] - frames[0][0] < 0.6 * self.span_s:
            return None
        ts = np.array([t for t, _ in frames])
        offsets = np.array([o for _, o in frames])
        dt = ts - ts.mean()
        rate = (dt[:, None] * (offsets - offsets.mean(axis=0))).sum(axis=0) / float((dt**2).sum())
        rate[2] = 0.0  # the height is the release's own test (masonry.fsm.dropoff_reach)
        return np.asarray(rate, dtype=float)

    def _want_m(self, now_s: float) -> np.ndarray:
        """The shift (world, m) the target needs now over the mean of the frames it is: the drift filter's
        prediction less that mean, or the straight line's rate times the mean's age."""
        drift = self._drift
        if drift is not None and self.drift_mps_per_sqrt_s > 0.0 and self.span_s > 0.0:
            if drift.frames < MIN_FRAMES or not self._mean_offsets:
                return np.zeros(3)
            mean = np.mean(np.stack(self._mean_offsets), axis=0)
            return np.array([*(drift.predict_m(now_s) - mean[:2]), 0.0])
        rate = self.rate_mps(now_s)
        if rate is None or self._mean_t is None:
            return np.zeros(3)
        return np.asarray(rate * (now_s - self._mean_t), dtype=float)

    def step(self, now_s: float) -> np.ndarray | None:
        """The move (world, m) to make now to carry the target along the trend; None: none (within ``SHIFT_M``)."""
        want = self._want_m(now_s)
        size = float(np.linalg.norm(want))
        if size > MAX_SHIFT_M:
            want *= MAX_SHIFT_M / size
        delta = want - self.shift_m
        if float(np.linalg.norm(delta)) <= SHIFT_M:
            return None
        self.shift_m = want
        return np.asarray(delta, dtype=float)
