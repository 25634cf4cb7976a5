"""PX4's setpoint stream as the project's SITL sees it (issue 29): what its OFFBOARD answers depend on.

PX4 v1.16 SITL (../shared/px4, docs/performance/autopilots.md, "OFFBOARD without setpoints"): disarmed, a switch
to OFFBOARD is accepted whatever the stream; the arming in OFFBOARD is then TEMPORARILY_REJECTED unless a
setpoint came within COM_OF_LOSS_T (1.0 s; a burst 0.8 s before armed, 1.0 s before did not); armed, a switch
to OFFBOARD without the stream is TEMPORARILY_REJECTED. A client thread starved under load meets those answers;
``starved_answers`` makes the first ones see the stream stale on purpose (tests: no reliance on load).

In lock-step (``masonry sitl --lockstep``) the silence is timed on the SITL's simulated clock, as PX4's lock-step SITL
times COM_OF_LOSS_T on its own: on the wall, a client stalled for a second under load (the SITL's time standing
meanwhile, no grant) found its autopilot in AUTO.LOITER, "the autopilot took control", and the same seed flew
another flight (tests/test_sitl_lockstep.py's repeat test, the SITL load loop's runs 8 and 10, branch ``px447``).
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable

__all__ = ["SetpointStream"]


class SetpointStream:
    """When the last setpoint arrived (on ``clock``, s: the wall's by default; a lock-step SITL's simulated clock), and
    how many answers are still to see it stale on purpose."""

    def __init__(self, starved_answers: int = 0, clock: Callable[[], float] | None = None) -> None:
        self.last_wall_s = -math.inf
        self.starved_left = starved_answers
        self._clock = clock

    def _now_s(self) -> float:
        return time.monotonic() if self._clock is None else self._clock()

    def heard(self) -> None:
        """A setpoint arrived now."""
        self.last_wall_s = self._now_s()

    def silent_for(self, loss_s: float) -> bool:
        """No setpoint for more than ``loss_s`` seconds of its clock (PX4's offboard-loss failsafe; nothing
        injected)."""
        return self._now_s() - self.last_wall_s > loss_s

    def stale(self, loss_s: float) -> bool:
        """A command's view (arming in OFFBOARD, an armed switch to it): silent, or an injected starvation."""
        if self.starved_left > 0:
            self.starved_left -= 1
            return True
        return self.silent_for(loss_s)
