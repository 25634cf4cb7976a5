"""The wall's offset as a drifting state (issue 30): a small Kalman filter on the GNSS wander the camera sees.

The wall alignment measures the offset of the bricks in view from their design, ``(true - design) + e(t)``, where
``e`` is the position source's error (:mod:`masonry.fsm.wall_align`). On the ``px4`` model ``e`` is EKF2's GNSS
wander (:data:`masonry.sim.shaping.PX4`): an Ornstein-Uhlenbeck error of 6 cm over 8 s, smoothed over 2 s. Its
rate is then itself a slow random process: ``e' = (w - e) / T`` moves with ``w``, whose increments are white, so
the rate diffuses at ``sigma * sqrt(2 / tau) / T`` = 0.06 * 0.5 / 2 = 0.015 m/s per square-root second and
relaxes over ``T`` (2 s). :class:`DriftFilter` carries, per horizontal axis, the offset and its rate on that model
(an integrated Ornstein-Uhlenbeck rate), updated by each frame's offset (the camera's 3.6 mm per frame, white:
measured on the px4 towers, seeds 0-9, against the simulator's truth), and predicts the offset at the release, past the last sighting.

On the frames recorded on the px4 towers (seeds 0-9, every frame of each placement with the simulator's GNSS
error at it), the offset at the release (0.2-0.4 s past the last sighting) was predicted to 5.9 mm rms (2-D)
against the straight line's 6.7 (:mod:`masonry.fsm.wall_trend`); from cuts through the frames, 0.4 s past the
last frame to 7.3 mm against 9.6, 0.6 s past it to 9.8 against 15.1, 1 s to 15.0 against 21.1. The model's own
values (0.015 m/s per square-root second, 2 s, 3.6 mm) were the best of those tried (the rate's noise 0.005-0.03,
its time 0.5 s to none, the frame's noise 3.6-5 mm; docs/performance/as-built.md, branch ``drift30``).
"""

from __future__ import annotations

import math

import numpy as np

from masonry.errors import InvalidArgument

__all__ = ["FRAME_NOISE_M", "DriftFilter"]

#: One frame's offset of the wall, its noise (m, per axis, white): the camera's, as measured on the px4 towers.
FRAME_NOISE_M = 0.0036
#: The rate's spread before any frame (m/s, per axis): the px4 wander's rate, 13 mm/s rms.
RATE_PRIOR_MPS = 0.013


class DriftFilter:
    """The horizontal offset and its rate, per axis, on an integrated Ornstein-Uhlenbeck rate.

    Args:
        rate_noise_mps_per_sqrt_s: how fast the rate diffuses (m/s per square-root second).
        rate_tau_s: the rate's relaxation time (s).
        frame_noise_m: one frame's noise (m, per axis).
    """

    def __init__(
        self, rate_noise_mps_per_sqrt_s: float, rate_tau_s: float, frame_noise_m: float = FRAME_NOISE_M
    ) -> None:
        if rate_noise_mps_per_sqrt_s <= 0.0 or rate_tau_s <= 0.0 or frame_noise_m <= 0.0:
            raise InvalidArgument("the drift filter's noises and time must be positive")
        self.q = rate_noise_mps_per_sqrt_s
        self.tau_s = rate_tau_s
        self.r2 = frame_noise_m**2
        self.frames = 0  # frames taken since the last reset
        self._t_s = 0.0
        self._x = np.zeros((2, 2))  # per axis (x, y): offset (m), rate (m/s)
        self._p = np.zeros((2, 2, 2))  # per axis: the state's covariance

    def reset(self) -> None:
        """Forget every frame (a new placement, a new set of reference bricks)."""
        self.frames = 0

    def _transition(self, dt_s: float) -> tuple[np.ndarray, np.ndarray]:
        """The state's transition and process noise over ``dt_s`` (the rate's white diffusion, integrated)."""
        a = math.exp(-dt_s / self.tau_s)
        f = np.array([[1.0, self.tau_s * (1.0 - a)], [0.0, a]])
        q2 = self.q**2
        noise = q2 * np.array([[dt_s**3 / 3.0, dt_s**2 / 2.0], [dt_s**2 / 2.0, dt_s]])
        return f, noise

    def add(self, t_s: float, offset_m: np.ndarray) -> None:
        """One frame's offset (world, m; its horizontal part is filtered) at ``t_s``."""
        z = np.asarray(offset_m, dtype=float)[:2]
        if self.frames == 0:
            self._t_s = t_s
            self._x = np.stack([z, np.zeros(2)], axis=1)
            self._p = np.tile(np.diag([self.r2, RATE_PRIOR_MPS**2]), (2, 1, 1))
            self.frames = 1
            return
        f, noise = self._transition(max(0.0, t_s - self._t_s))
        self._t_s = t_s
        for i in range(2):
            x = f @ self._x[i]
            p = f @ self._p[i] @ f.T + noise
            gain = p[:, 0] / (p[0, 0] + self.r2)
            self._x[i] = x + gain * (z[i] - x[0])
            self._p[i] = p - np.outer(gain, p[0, :])
        self.frames += 1

    def predict_m(self, t_s: float) -> np.ndarray:
        """The horizontal offset (m, x and y) predicted at ``t_s`` (at or after the last frame)."""
        dt_s = max(0.0, t_s - self._t_s)
        a = math.exp(-dt_s / self.tau_s)
        return np.asarray(self._x[:, 0] + self._x[:, 1] * self.tau_s * (1.0 - a), dtype=float)
