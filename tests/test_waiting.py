from __future__ import annotations

import threading

import pytest

from waiting import wait_until


def test_returns_once_the_condition_holds() -> None:
    done = threading.Event()
    timer = threading.Timer(0.02, done.set)
    timer.start()
    try:
        waited_s = wait_until(done.is_set, 5.0, "the timer")
    finally:
        timer.cancel()
    assert done.is_set() and 0.0 <= waited_s < 5.0


def test_a_condition_already_true_does_not_wait() -> None:
    assert wait_until(lambda: True, 0.0) < 0.05


def test_fails_after_the_bound_naming_what_it_waited_for() -> None:
    with pytest.raises(AssertionError, match=r"timed out after 0\.05 s waiting for the moon"):
        wait_until(lambda: False, 0.05, "the moon")
