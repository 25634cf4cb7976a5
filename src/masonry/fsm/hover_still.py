"""When the adhesion UAV hovers still over a segment's start on a noisy position source (issue 29).

The hover before the spray descent (``AdhesionUav.do_hover``) passes once the body has stayed, tick after tick for
``stable_time_s`` (1 s), within ``2 x align_tolerance_m`` (3 cm) of the start in three dimensions, slower than
``settle_speed_mps``; both double ``align_patience_s`` after the leg's end, and past ``swing_patience_s`` the swing
gate fails the attempt if the hover's rms speed is above ``swing_speed_mps``. On motion capture that is the right
test. On PX4 v1.16 SITL (the ``px4`` preset, masonry's own velocity loop) the hover is 4-6 cm rms off the point
with a ~2 s oscillation: a second in a row within 6 cm is luck, and beside a busy process the hover waited past
the swing gate's 8 s, which then failed it at 0.20-0.22 m/s rms (2 of 10 loaded A0 flights;
docs/performance/autopilots.md).

Where the preset sets a window (``UavConfig.gate_window_s`` > 0) the hover is judged as the brick UAV's alignments
are (:func:`masonry.fsm.noise_gate.noise_aligned`): a window seen, the window's mean position within the tolerance
by two standard errors of its measured spread, in three dimensions, and the window's mean velocity below the speed.
That is what the descent after it needs (it is judged on its own window, :mod:`masonry.fsm.descent_reach`): a hover
centred on the start, not drifting. Without a window the test is the ticks', unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.fsm.noise_gate import HoverNoise

__all__ = ["HoverStill"]


class HoverStill:
    """The hover's windowed statistics: horizontal and vertical, each a :class:`HoverNoise`.

    Args:
        window_s: the averaging window (s; the preset's ``gate_window_s``).
    """

    def __init__(self, window_s: float) -> None:
        self._horizontal = HoverNoise(window_s)
        self._height = HoverNoise(window_s)

    def reset(self) -> None:
        """A new hover: forget what was seen."""
        self._horizontal.reset()
        self._height.reset()

    def add(self, now_s: float, error_m: Sequence[float], velocity_mps: Sequence[float]) -> None:
        """One tick of the hover: the body's error (body minus point, m) and its velocity (m/s), world frame."""
        self._horizontal.add(
            now_s, (float(error_m[0]), float(error_m[1])), (float(velocity_mps[0]), float(velocity_mps[1]))
        )
        self._height.add(now_s, (float(error_m[2]), 0.0), (float(velocity_mps[2]), 0.0))

    def still(self, tolerance_m: float, speed_mps: float, *, margin: bool = True) -> bool:
        """A window seen, its mean position within ``tolerance_m`` of the point (3-D) by two standard errors (where
        ``margin``; the mean alone without: from half the leg's timeout, masonry.fsm.noise_gate), and its mean velocity
        slower than ``speed_mps`` (3-D)."""
        h, z = self._horizontal, self._height
        if h.seen_s < h.window_s:
            return False
        mean_m = math.hypot(h.mean_error_m, z.mean_error_m)
        margin_m = 2.0 * math.hypot(h.standard_error_m, z.standard_error_m) if margin else 0.0
        return (
            mean_m + margin_m <= tolerance_m and math.hypot(h.mean_speed_mps, z.mean_speed_mps) <= speed_mps
        )
