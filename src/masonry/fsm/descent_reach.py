"""When the adhesion UAV's spray descent has arrived on a noisy position source (issue 29).

The descent (``AdhesionUav.do_descend``) ends on one tick with the body within ``spray_tolerance_m`` (1.5 cm) of
the spraying point in three dimensions and slower than ``arrive_speed_mps``; both double ``align_patience_s`` after
its planned end, and the attempt fails ``max(release_timeout_s, 2 x align_patience_s)`` after it ("could not reach
the spraying height"). On motion capture that is the right test. On PX4 v1.16 SITL (the ``px4`` preset, masonry's
own velocity loop) the hover at the bottom is 5.5 cm rms off sideways and 2.7 cm vertically, a ~2 s oscillation:
one tick in 60 lies within 1.5 cm, and replayed from each recorded start tick the single-tick gate waited 3.2 s
median, over 6 s in 15 %, never passed within the 8 s in 4 % (docs/performance/autopilots.md).

Where the preset sets a window (``UavConfig.gate_window_s`` > 0), the descent is judged as the brick's drop-off
is (:mod:`masonry.fsm.dropoff_reach`): by the mean of the body's deviation from the descent's reference over the
window (the reference is known, not noisy, so the descent itself is neither spread nor lag), three-dimensional
here, within the tolerance; the tick's own speed as before. The mean is where the hover is centred: the spray
pass (:mod:`masonry.fsm.bead`) then opens the valve tick by tick wherever the measured nozzle is within
``spray_valve_radius_m`` (3 cm) of the segment and within reach of the surface, and passes back over what a swing
left, so what the descent must deliver is a hover centred within the valve's radius: the ``px4`` preset sets
``spray_tolerance_m`` to it. Without a window the test is the single tick, unchanged.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.fsm.config import UavConfig
from masonry.fsm.navigator import Navigator
from masonry.fsm.noise_gate import HoverNoise

__all__ = ["HEIGHT_RUN_OFF_M", "HEIGHT_RUN_OFF_S", "DescentReach", "HeightRunOff"]

#: A reported height this far from the descent's end point past its planned end is no hover's wander (on the
#: real PX4 2.7 cm rms vertically) but EKF2's height running off (0.3-1.2 m for 3-5 s, issue 29).
HEIGHT_RUN_OFF_M = 0.15
#: ... for this long without a break: a vehicle still catching up with a short leg's end is no run-off (the
#: simulated px4 model's body 16-17 cm above a side look's last leg for 0.3 s past its end; a wait there moved a
#: pyramid's timing onto three failed drop-offs of one brick)
HEIGHT_RUN_OFF_S = 1.0


class DescentReach:
    """The spray descent's arrival on a noisy position source (see the module docstring).

    Args:
        window_s: the averaging window (s; the preset's ``gate_window_s``).
    """

    def __init__(self, window_s: float) -> None:
        self._horizontal = HoverNoise(window_s)
        self._height = HoverNoise(window_s)
        self._seen_s = window_s

    def reset(self, duration_s: float = math.inf) -> None:
        """A new descent of ``duration_s`` (planned): forget the deviations seen. A descent shorter than the window
        (a chained segment's ``chain_descent_s``, 0.5 s: the UAV is at the spraying height already) is judged on
        what it has seen by its end, not held for a whole window."""
        self._horizontal.reset()
        self._height.reset()
        self._seen_s = min(self._horizontal.window_s, duration_s)

    def add(self, now_s: float, deviation_m: Sequence[float]) -> None:
        """One tick of the descent: the body's deviation from the descent's reference now (body minus reference,
        world, m)."""
        self._horizontal.add(now_s, (float(deviation_m[0]), float(deviation_m[1])), (0.0, 0.0))
        self._height.add(now_s, (float(deviation_m[2]), 0.0), (0.0, 0.0))

    def mean_error_m(self, reference_error_m: Sequence[float]) -> float | None:
        """The distance (m) of the window's mean position from the target, given where the descent's reference is
        now relative to the target (reference minus target: zero once the descent is over by plan); None until
        a window (or the whole of a shorter descent) has been seen."""
        if self._horizontal.seen_s < self._seen_s:
            return None
        mx, my = self._horizontal.mean_m
        mz = self._height.mean_m[0]
        return math.sqrt(
            (float(reference_error_m[0]) + mx) ** 2
            + (float(reference_error_m[1]) + my) ** 2
            + (float(reference_error_m[2]) + mz) ** 2
        )

    def reached(self, reference_error_m: Sequence[float], tolerance_m: float) -> bool:
        """The window's mean position is within ``tolerance_m`` of the target (see :meth:`mean_error_m`)."""
        error_m = self.mean_error_m(reference_error_m)
        return error_m is not None and error_m <= tolerance_m


class HeightRunOff:
    """The descent's timeout held while the reported height has run off (issue 29).

    On the real PX4 v1.16 SITL under load EKF2's reported height runs off the descent's reference by 0.3-1.2 m for
    3-5 s now and then while masonry commands the descent, then comes back (PX4's log says nothing;
    docs/performance/autopilots.md): a spray descent's window mean cannot pass while it lasts nor for a window
    after, and the descent's timeout (8 s past its end) ran out on it, twice in a row on a loaded CI machine
    ("could not reach the spraying height over A0 after 2 descents"). While the height is more than
    :data:`HEIGHT_RUN_OFF_M` off past the descent's end for :data:`HEIGHT_RUN_OFF_S` on end, the timeout waits
    (counts from the height's return), up to a budget (``leg_timeout_s``) a descent, after which it runs as before.
    """

    def __init__(self) -> None:
        self.waited_s = 0.0
        self._off_since_s: float | None = None

    def reset(self) -> None:
        """A new descent: its budget whole again."""
        self.waited_s = 0.0
        self._off_since_s = None

    def waits(self, now_s: float, height_off_m: float, dt_s: float, budget_s: float) -> bool:
        """The tick at ``now_s`` past the descent's end with the reported height ``height_off_m`` off its end point
        (m): True when the timeout is to wait this tick (``dt_s`` of it; a run-off, within the budget)."""
        if abs(height_off_m) <= HEIGHT_RUN_OFF_M:
            self._off_since_s = None
            return False
        if self._off_since_s is None:
            self._off_since_s = now_s
        if now_s - self._off_since_s < HEIGHT_RUN_OFF_S or self.waited_s >= budget_s:
            return False
        self.waited_s += dt_s
        return True

    def hold(self, nav: Navigator, now_s: float, height_m: float, config: UavConfig) -> None:
        """A descent's tick at ``now_s`` with the reported height ``height_m`` (m): on a noisy position source
        (``gate_window_s`` > 0) past the leg's end, the leg's timeout waits this tick while the height has run off
        its end point (:meth:`waits`, ``leg_timeout_s`` its budget)."""
        if config.gate_window_s > 0.0 and now_s > nav.end_s:
            off_m = height_m - float(nav.target_m[2])
            if self.waits(now_s, off_m, config.control_period_s, config.leg_timeout_s):
                nav.wait(now_s)
