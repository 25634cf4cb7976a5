"""PX4's setpoint stream as the project's SITL sees it (issue 29): what its OFFBOARD answers depend on.

PX4 v1.16 SITL (../shared/px4, docs/performance/autopilots.md, "OFFBOARD without setpoints"): disarmed, a switch
to OFFBOARD is accepted whatever the stream; the arming in OFFBOARD is then TEMPORARILY_REJECTED unless a
setpoint came within COM_OF_LOSS_T (1.0 s; a burst 0.8 s before armed, 1.0 s before did not); armed, a switch
to OFFBOARD without the stream is TEMPORARILY_REJECTED. A client thread starved under load meets those answers;
``starved_answers`` makes the first ones see the stream stale on purpose (tests: no reliance on load).
"""

from __future__ import annotations

import math
import time

__all__ = ["SetpointStream"]


class SetpointStream:
    """When the last setpoint arrived (wall time), and how many answers are still to see it stale on purpose."""

    def __init__(self, starved_answers: int = 0) -> None:
        self.last_wall_s = -math.inf
        self.starved_left = starved_answers

    def heard(self) -> None:
        """A setpoint arrived now."""
        self.last_wall_s = time.monotonic()

    def silent_for(self, loss_s: float) -> bool:
        """No setpoint for more than ``loss_s`` wall seconds (PX4's offboard-loss failsafe; nothing injected)."""
        return time.monotonic() - self.last_wall_s > loss_s

    def stale(self, loss_s: float) -> bool:
        """A command's view (arming in OFFBOARD, an armed switch to it): silent, or an injected starvation."""
        if self.starved_left > 0:
            self.starved_left -= 1
            return True
        return self.silent_for(loss_s)
