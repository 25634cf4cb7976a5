"""The brick UAV aligns on what its camera sees, not on the absolute position (issue 20, GNSS-grade noise).

The brick's pose is estimated in the world frame from the camera's view and the position the autopilot reports:
``brick_world = p_reported + R @ brick_in_camera``. With motion capture ``p_reported`` is the truth to a couple
of millimetres and one estimate, taken in the estimate hover, serves the alignment and the descent. With GNSS
(PX4's EKF2: about +-15 cm of slow wander) ``p_reported = p_true + e(t)``: an estimate taken at ``t0`` puts the
brick at ``brick + e(t0)``, and flying the effector there on ``p_reported`` later misses it by ``e(t0) - e(t)``,
centimetres after a few seconds. Re-estimated every tick from the same telemetry the position loop closes on,
the target moves with ``e(t)``: position minus target is ``p_true - brick``, the relative offset the camera
measures, and the wander cancels.

:class:`CameraAlign` keeps the latest few estimates; :func:`track_brick` shifts the motion in hand (the align
hover, the descent) and the brick's estimate once their mean has moved by more than ``shift_m``. It only acts
while the camera sees the brick: near the brick, out of the camera's view, the last estimate stands.
"""

from __future__ import annotations

import math
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    from masonry.fsm.brick import BrickUav
    from masonry.ports import Telemetry

__all__ = ["CameraAlign", "track_brick"]


class CameraAlign:
    """The latest ``size`` world estimates of the brick's top-face centre, and the centre the target is at.

    Args:
        size: estimates averaged (at the 10 Hz control rate, half a second: GNSS wanders slower).
        min_estimates: fewer than this do not move the target.
        shift_m: the target follows once the mean is this far from it (a deadband for the camera's own noise).
        span_s: estimates older than this (s) before the newest are left out of the mean (``add``'s ``time_s``;
            inf: the last ``size`` whatever their age). Five frames are half a second at the 10 Hz control rate; a
            brick that drops out of view between frames leaves the last five seconds apart, and their mean holds
            the wander of those seconds (:mod:`masonry.fsm.wall_align`, ``frames_span_s``).
    """

    def __init__(
        self, size: int = 5, min_estimates: int = 3, shift_m: float = 0.002, span_s: float = math.inf
    ) -> None:
        self.size = size
        self.min_estimates = min_estimates
        self.shift_m = shift_m
        self.span_s = span_s
        self._recent: deque[np.ndarray] = deque(maxlen=size)
        self._times: deque[float] = deque(maxlen=size)
        self._count = 0  # estimates added since the reset
        self.center_m: np.ndarray | None = None
        self.shifted_m = 0.0  # the total distance the target was moved (for the record)

    def reset(self, center_m: np.ndarray) -> None:
        """A new alignment on the brick estimated at ``center_m``."""
        self._recent.clear()
        self._times.clear()
        self._count = 0
        self.center_m = np.asarray(center_m, dtype=float).copy()
        self.shifted_m = 0.0

    @property
    def times_s(self) -> tuple[float, ...]:
        """When (s) the estimates the mean is over were taken (``add``'s ``time_s``; 0.0 without one)."""
        return tuple(self._times)

    def add(self, center_m: np.ndarray, time_s: float = 0.0) -> np.ndarray | None:
        """One fresh estimate taken at ``time_s``; the move to make (m, world) when the mean has moved past
        ``shift_m``, else None. Once ``min_estimates`` have been added since the reset, the mean is over the last
        ``size`` of them no older than ``span_s`` before this one, however few."""
        if self.center_m is None:
            self.reset(center_m)
            return None
        self._recent.append(np.asarray(center_m, dtype=float))
        self._times.append(float(time_s))
        self._count += 1
        while self._times[0] < time_s - self.span_s:
            self._times.popleft()
            self._recent.popleft()
        if self._count < self.min_estimates:
            return None
        mean = np.mean(np.stack(self._recent), axis=0)
        delta = mean - self.center_m
        if float(np.linalg.norm(delta)) <= self.shift_m:
            return None
        self.center_m = mean
        self.shifted_m += float(np.linalg.norm(delta))
        return np.asarray(delta, dtype=float)


def track_brick(uav: BrickUav, tracker: CameraAlign, tel: Telemetry) -> bool:
    """Follow the brick as the camera sees it now: shift ``uav``'s motion and brick estimate; True if moved.

    It reads the brick UAV's camera (``_fresh_estimate``) and moves its attempt's estimate and its navigator.
    """
    estimate = uav._fresh_estimate(tel)
    if estimate is None or uav.attempt.brick_estimate is None:
        return False
    delta = tracker.add(estimate[0])
    if delta is None:
        return False
    center, yaw = uav.attempt.brick_estimate
    uav.attempt.brick_estimate = (np.asarray(center, dtype=float) + delta, yaw)
    uav.nav.shift(delta)
    return True
