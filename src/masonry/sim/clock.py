"""The simulated clock: time advances only when told (by ``World.step`` or a ``sleep``), never with the wall."""

from __future__ import annotations

import math

from masonry.errors import InvalidArgument

__all__ = ["SimClock"]


class SimClock:
    """A ``masonry.ports.Clock`` on simulated time: ``sleep`` returns at once, having advanced the time.

    Args:
        start_s: the time the clock reads first, seconds.
    """

    def __init__(self, start_s: float = 0.0) -> None:
        if not math.isfinite(start_s):
            raise InvalidArgument(f"SimClock start_s must be finite, got {start_s!r}")
        self._now_s = float(start_s)

    def now_s(self) -> float:
        """The current simulated time, seconds."""
        return self._now_s

    def advance(self, dt_s: float) -> None:
        """Move the time forward by ``dt_s`` >= 0 seconds."""
        if not dt_s >= 0.0 or not math.isfinite(dt_s):
            raise InvalidArgument(f"SimClock cannot advance by {dt_s!r} s (must be finite and >= 0)")
        self._now_s += dt_s

    def sleep(self, duration_s: float) -> None:
        """Advance by ``duration_s`` (the ``Clock`` protocol); in a ``World`` prefer ``World.step``, which moves the physics too."""
        self.advance(duration_s)

    def __repr__(self) -> str:
        return f"SimClock(now_s={self._now_s!r})"
