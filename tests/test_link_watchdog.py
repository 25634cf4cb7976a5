"""The MAVLink link watchdog counts the autopilot's silence from what the receiver has read (issue 29).

A ``masonry fly`` held up by a loaded machine (its receiver thread not run, messages waiting in the socket) must
not read that as a lost link; a receiver that listens and hears nothing must, after ``heartbeat_timeout_s`` as
before; a receiver that has read nothing for ``RECEIVER_HUNG_S`` counts wall time. The receiver's state is set
by hand on an adapter that opens nothing, at held clock readings.
"""

from __future__ import annotations

import pytest

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.mavlink_link import RECEIVER_HUNG_S
from masonry.errors import LinkLost


class Held:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


def link(clock: Held) -> MavlinkFlightController:
    fc = MavlinkFlightController("udpin:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    fc._conn = object()  # "connected": nothing is sent or read here
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    return fc


def test_a_process_held_up_with_messages_unread_is_not_a_lost_link() -> None:
    clock = Held()
    fc = link(clock)
    fc._state.listened_s = 99.98  # the receiver's last quiet read began before the last message
    clock.t = 103.0  # three wall seconds later, the receiver has not run since
    assert fc.telemetry().link_ok
    fc._check_link("hover")  # no LinkLost


def test_a_receiver_that_listens_and_hears_nothing_fires_the_watchdog_after_its_timeout() -> None:
    clock = Held()
    fc = link(clock)
    clock.t = fc._state.listened_s = 100.99
    assert fc.telemetry().link_ok  # not before the watchdog time (1 s)
    clock.t = fc._state.listened_s = 101.01
    assert not fc.telemetry().link_ok  # nor later
    with pytest.raises(LinkLost, match=r"no message from the autopilot .* for 1\.0 s"):
        fc._check_link("hover")


def test_a_receiver_that_reads_nothing_for_long_counts_wall_time() -> None:
    clock = Held()
    fc = link(clock)
    fc._state.listened_s = 99.0
    clock.t = 100.0 + RECEIVER_HUNG_S + 0.1
    assert not fc.telemetry().link_ok
    with pytest.raises(LinkLost, match="no message from the autopilot"):
        fc._check_link("hover")
