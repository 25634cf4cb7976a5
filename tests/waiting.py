"""Waiting on another thread or process in a test: poll a condition with a bound, never a bare sleep.

A fixed ``time.sleep`` before an assertion guesses how long the other side needs; on a busy machine the guess
is wrong and the test flakes. ``wait_until`` waits for the evidence itself and fails with what it waited for.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Protocol

POLL_S = 0.005


def wait_until(
    predicate: Callable[[], object],
    timeout_s: float,
    what: str = "the condition",
    detail: Callable[[], str] | None = None,
) -> float:
    """Poll ``predicate`` until it is true; return the seconds waited.

    Raises:
        AssertionError: still false after ``timeout_s`` (wall seconds), naming ``what``, and with ``detail()``'s
            lines (what the other side was doing then) where given.
    """
    started = time.monotonic()
    while not predicate():
        if time.monotonic() - started > timeout_s:
            more = f"\n{detail()}" if detail is not None else ""
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}{more}")
        time.sleep(POLL_S)
    return time.monotonic() - started


class SteppedClock(Protocol):
    """A clock whose time moves as it is told (a SITL's lock-step: ``masonry.adapters.lockstep.LockstepClock``)."""

    def now_s(self) -> float: ...

    def sleep(self, duration_s: float) -> None: ...


def step_until(
    clock: SteppedClock,
    predicate: Callable[[], object],
    within_s: float,
    what: str = "the condition",
    *,
    step_s: float = 0.02,
    detail: Callable[[], str] | None = None,
) -> float:
    """Step ``clock`` ``step_s`` at a time until ``predicate`` is true; return the clock's seconds it took.

    The bound is on the clock's time, not the wall's: against a SITL in lock-step, what the test waits for
    happens at the same simulated time however loaded the machine is, and so does a miss.

    Raises:
        AssertionError: still false after ``within_s`` of the clock's time, naming ``what`` (and ``detail()``).
    """
    started = clock.now_s()
    while not predicate():
        if clock.now_s() - started > within_s:
            more = f"\n{detail()}" if detail is not None else ""
            raise AssertionError(f"not within {within_s} s of the clock's time: {what}{more}")
        clock.sleep(step_s)
    return clock.now_s() - started


class HeldClock:
    """A monotonic clock (s) a test can hold still at an instant it chooses, to ask what a deadline says then.

    Injected where an adapter reads its local clock (``MavlinkFlightController(monotonic=...)``), it follows
    ``time.monotonic`` until held: a watchdog window is then checked at its edges, exactly, however busy the machine.
    """

    def __init__(self) -> None:
        self._held_s: float | None = None

    def __call__(self) -> float:
        held_s = self._held_s
        return time.monotonic() if held_s is None else held_s

    @contextmanager
    def held_at(self, t_s: float) -> Iterator[None]:
        """Read ``t_s`` (and only that) inside the block; follow the wall again after it."""
        self._held_s = t_s
        try:
            yield
        finally:
            self._held_s = None


class SteppingClock:
    """A monotonic clock (s) that moves ``step_s`` on every read and never otherwise.

    Injected into an adapter whose waits poll its clock, it makes a timeout a count of polls: where the adapter
    gave up is then exact on this clock, however long the machine took between the polls.
    """

    def __init__(self, step_s: float = 0.01, start_s: float = 100.0) -> None:
        self.step_s = step_s
        self.now_s = start_s

    def __call__(self) -> float:
        self.now_s += self.step_s
        return self.now_s
