"""A SITL on this computer left unrun by the machine is not a silent autopilot (issue 29).

The link watchdog takes out of the autopilot's silence the time its process (found from a ``tcp:`` loopback URL)
waited for a CPU (masonry.adapters.sitl_standstill). Here: the URL's rule and the process found through a real
TCP server in a child process, read from the kernel's statistics; then the watchdog on held clock readings with
the process's run-queue wait set by hand (a machine's stall cannot be made to order): a stand-still is ridden
out, a hung, stopped or gone process and a SITL that was run and said nothing are lost after the timeout as
before.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.mavlink_link import RECEIVER_HUNG_S
from masonry.adapters.sitl_standstill import Standstill, loopback_tcp_port, run_delay_s, server_pid
from masonry.errors import LinkLost

SERVER = (
    "import socket, time\n"
    "s = socket.socket()\n"
    "s.bind(('127.0.0.1', 0))\n"
    "s.listen()\n"
    "print(s.getsockname()[1], flush=True)\n"
    "time.sleep(120)\n"
)


def test_only_a_tcp_url_on_the_loopback_names_a_process_of_this_computer() -> None:
    assert loopback_tcp_port("tcp:127.0.0.1:5770") == 5770
    assert loopback_tcp_port("tcp:localhost:5760") == 5760
    assert loopback_tcp_port("tcp:[::1]:5760") == 5760
    assert loopback_tcp_port("tcp:192.168.1.20:5760") is None  # another computer: its silence is its own
    assert loopback_tcp_port("udpin:127.0.0.1:14550") is None
    assert loopback_tcp_port("/dev/ttyACM0") is None
    assert loopback_tcp_port("tcp:127.0.0.1:port") is None


@pytest.mark.skipif(not Path("/proc/self/schedstat").exists(), reason="no /proc scheduler statistics here")
def test_the_process_serving_a_loopback_port_is_found_and_its_wait_read() -> None:
    child = subprocess.Popen([sys.executable, "-c", SERVER], stdout=subprocess.PIPE, text=True)
    try:
        assert child.stdout is not None
        port = int(child.stdout.readline())
        assert server_pid(port) == child.pid
        assert server_pid(port, own_pid=child.pid) is None  # a server in this very process is not counted
        wait_s = run_delay_s(child.pid)
        assert wait_s is not None and wait_s >= 0.0
    finally:
        child.kill()
        child.wait()
    assert run_delay_s(child.pid) is None  # gone: its silence counts in full
    assert server_pid(port) is None


class Held:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class Waits:
    """The autopilot process's run-queue wait (s) as the kernel would count it; None: gone."""

    def __init__(self) -> None:
        self.s: float | None = 5.0

    def __call__(self, pid: int) -> float | None:
        assert pid == 4242
        return self.s


def link(clock: Held, waits: Waits) -> MavlinkFlightController:
    fc = MavlinkFlightController("tcp:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    fc.standstill = Standstill(fc.url, pid=4242, run_delay=waits)
    fc._conn = object()  # "connected": nothing is sent or read here
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    clock.t = fc._state.listened_s = 100.02  # the watchdog's tick after the last message: a sample
    assert fc.telemetry().link_ok
    return fc


def silent_until(fc: MavlinkFlightController, clock: Held, t: float) -> None:
    clock.t = fc._state.listened_s = t  # the receiver listening all along, hearing nothing


def test_a_sitl_the_machine_left_unrun_has_not_gone_silent() -> None:
    clock, waits = Held(), Waits()
    fc = link(clock, waits)
    waits.s = 5.0 + 1.4  # of 1.5 s of wall, 1.4 s runnable and waiting for a CPU: it could not speak
    silent_until(fc, clock, 101.5)
    assert fc.telemetry().link_ok
    fc._check_link("hover")  # no LinkLost
    assert fc._silences(clock.t)[0] == pytest.approx(0.1)
    silent_until(fc, clock, 102.2)  # then run, and still silent: 0.1 + 0.7 s, past 1 s counted
    assert fc.telemetry().link_ok
    silent_until(fc, clock, 102.45)
    assert not fc.telemetry().link_ok
    with pytest.raises(LinkLost, match=r"no message from the autopilot .* for 1\.0 s"):
        fc._check_link("hover")


def test_a_sitl_that_was_run_and_said_nothing_is_lost_after_the_timeout_as_before() -> None:
    clock, waits = Held(), Waits()
    fc = link(clock, waits)
    waits.s = 5.0 + 0.3  # a loaded machine's share: it waited 0.3 s and ran the rest
    silent_until(fc, clock, 101.29)
    assert fc.telemetry().link_ok
    silent_until(fc, clock, 101.32)
    assert not fc.telemetry().link_ok


@pytest.mark.parametrize("how", ["hung or stopped", "gone"])
def test_a_hung_stopped_or_gone_process_counts_in_full(how: str) -> None:
    clock, waits = Held(), Waits()
    fc = link(clock, waits)
    if how == "gone":
        waits.s = None
    silent_until(fc, clock, 101.01)  # asleep or stopped (SIGSTOP): not runnable, its wait does not grow
    assert not fc.telemetry().link_ok


def test_a_wait_the_watchdog_did_not_see_begin_after_the_last_message_is_not_taken_out() -> None:
    clock, waits = Held(), Waits()
    fc = link(clock, waits)
    fc._state.last_message_s = 100.5  # a message after the last sample, then silence
    waits.s = 5.0 + 1.4
    silent_until(fc, clock, 101.6)  # the first sample since that message: nothing to measure from
    assert not fc.telemetry().link_ok


def test_a_silence_past_the_hung_receivers_bound_counts_wall_time() -> None:
    clock, waits = Held(), Waits()
    fc = link(clock, waits)
    waits.s = 5.0 + RECEIVER_HUNG_S + 0.5
    silent_until(fc, clock, 100.0 + RECEIVER_HUNG_S + 1.0)
    assert not fc.telemetry().link_ok


def test_any_other_autopilot_is_judged_as_before() -> None:
    clock = Held()
    fc = MavlinkFlightController("udpin:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    assert fc.standstill.port is None and fc.standstill.pid is None
    fc._conn = object()
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    clock.t = fc._state.listened_s = 101.01
    assert not fc.telemetry().link_ok
