"""Waiting on another thread or process in a test: poll a condition with a bound, never a bare sleep.

A fixed ``time.sleep`` before an assertion guesses how long the other side needs; on a busy machine the guess
is wrong and the test flakes. ``wait_until`` waits for the evidence itself and fails with what it waited for.
"""

from __future__ import annotations

import time
from collections.abc import Callable

POLL_S = 0.005


def wait_until(predicate: Callable[[], object], timeout_s: float, what: str = "the condition") -> float:
    """Poll ``predicate`` until it is true; return the seconds waited.

    Raises:
        AssertionError: still false after ``timeout_s`` (wall seconds), naming ``what``.
    """
    started = time.monotonic()
    while not predicate():
        if time.monotonic() - started > timeout_s:
            raise AssertionError(f"timed out after {timeout_s} s waiting for {what}")
        time.sleep(POLL_S)
    return time.monotonic() - started
