"""Bounded waits for the contract suites: poll a condition on an Event's timeout, never a bare sleep."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_for(poll: Callable[[], T], timeout_s: float = 10.0, what: str = "condition") -> T:
    """Call ``poll`` until it returns something truthy (returned) or ``timeout_s`` passes (AssertionError)."""
    tick = threading.Event()
    deadline = time.monotonic() + timeout_s
    while True:
        got = poll()
        if got:
            return got
        if time.monotonic() > deadline:
            raise AssertionError(f"{what}: not within {timeout_s} s")
        tick.wait(0.01)
