"""A SITL on this computer left unrun by the machine is not a silent autopilot (issue 29).

The link watchdog takes out of the autopilot's silence the time its process (found from a ``tcp:`` loopback URL)
stood runnable and unrun (masonry.adapters.sitl_standstill). Here: the URL's rule and the process found through
a real TCP server in a child process, read from the kernel; then the watchdog on held clock readings with what
the kernel says of the process set by hand (a machine's stall cannot be made to order): a stand-still is ridden
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
from masonry.adapters.sitl_standstill import (
    Standstill,
    loopback_tcp_port,
    run_state,
    server_pid,
    unrun_stretches_s,
)
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
        state = run_state(child.pid)
        assert state is not None and state[1] > 0  # asleep or running, it has run
    finally:
        child.kill()
        child.wait()
    assert run_state(child.pid) is None  # gone: its silence counts in full
    assert server_pid(port) is None


class Held:
    def __init__(self) -> None:
        self.t = 0.0

    def __call__(self) -> float:
        return self.t


class Kernel:
    """What the kernel would say of the autopilot's process: runnable (state R), its CPU time (ns); None: gone."""

    def __init__(self) -> None:
        self.state: tuple[bool, int] | None = (True, 1_000)

    def __call__(self, pid: int) -> tuple[bool, int] | None:
        assert pid == 4242
        return self.state


def link(clock: Held, kernel: Kernel) -> MavlinkFlightController:
    fc = MavlinkFlightController("tcp:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    fc.standstill = Standstill(fc.url, pid=4242, run_state=kernel)
    fc._conn = object()  # "connected": nothing is sent or read here
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    clock.t = fc._state.listened_s = 100.02  # the watchdog's tick after the last message: a reading
    assert fc.telemetry().link_ok
    return fc


def silent_until(fc: MavlinkFlightController, clock: Held, t: float) -> None:
    clock.t = fc._state.listened_s = t  # the receiver listening all along, hearing nothing


def test_a_sitl_the_machine_left_unrun_has_not_gone_silent() -> None:
    clock, kernel = Held(), Kernel()
    fc = link(clock, kernel)
    silent_until(fc, clock, 101.5)  # runnable, its CPU time the same: it waited for a CPU all along
    assert fc.telemetry().link_ok
    fc._check_link("hover")  # no LinkLost
    assert fc._silences(clock.t)[0] == pytest.approx(0.02)
    kernel.state = (True, 2_000)  # then run, and still silent: counted from here
    silent_until(fc, clock, 102.2)
    assert fc.telemetry().link_ok
    kernel.state = (True, 3_000)
    silent_until(fc, clock, 102.55)  # 0.02 + 1.05 s counted
    assert not fc.telemetry().link_ok
    with pytest.raises(LinkLost, match=r"no message from the autopilot .* for 1\.1 s"):
        fc._check_link("hover")


def test_a_sitl_that_was_run_and_said_nothing_is_lost_after_the_timeout_as_before() -> None:
    clock, kernel = Held(), Kernel()
    fc = link(clock, kernel)
    for t, cpu_ns in ((100.5, 2_000), (100.99, 3_000)):  # it ran between the readings (its CPU time moved)
        kernel.state = (True, cpu_ns)
        silent_until(fc, clock, t)
        assert fc.telemetry().link_ok
    kernel.state = (True, 4_000)
    silent_until(fc, clock, 101.01)
    assert not fc.telemetry().link_ok


@pytest.mark.parametrize("how", ["asleep (hung)", "stopped", "gone"])
def test_a_hung_stopped_or_gone_process_counts_in_full(how: str) -> None:
    clock, kernel = Held(), Kernel()
    fc = link(clock, kernel)
    kernel.state = None if how == "gone" else (False, 1_000)  # not runnable: its state S, D or T
    silent_until(fc, clock, 100.6)
    assert fc.telemetry().link_ok
    silent_until(fc, clock, 101.01)
    assert not fc.telemetry().link_ok


def test_a_wait_the_watchdog_did_not_see_begin_after_the_last_message_is_not_taken_out() -> None:
    clock, kernel = Held(), Kernel()
    fc = link(clock, kernel)
    fc._state.last_message_s = 100.5  # a message after the last reading, then silence
    silent_until(fc, clock, 101.6)  # the first reading since that message: nothing to measure from
    assert not fc.telemetry().link_ok


def test_a_silence_past_the_hung_receivers_bound_counts_wall_time() -> None:
    clock, kernel = Held(), Kernel()
    fc = link(clock, kernel)
    silent_until(fc, clock, 100.0 + RECEIVER_HUNG_S / 2)
    assert fc.telemetry().link_ok
    silent_until(fc, clock, 100.0 + RECEIVER_HUNG_S + 1.0)
    assert not fc.telemetry().link_ok


def test_only_stretches_runnable_and_unrun_for_a_tick_or_more_count() -> None:
    assert unrun_stretches_s([]) == 0.0
    assert unrun_stretches_s([(0.0, True, 5)]) == 0.0
    flat = [(0.0, True, 5), (0.3, True, 5), (0.7, True, 5)]
    assert unrun_stretches_s(flat) == pytest.approx(0.7)
    ran = [(0.0, True, 5), (0.3, True, 6), (0.7, True, 7)]  # it ran between each reading
    assert unrun_stretches_s(ran) == 0.0
    asleep = [(0.0, False, 5), (0.3, False, 5)]
    assert unrun_stretches_s(asleep) == 0.0
    mixed = [
        (0.0, True, 5),
        (0.4, True, 5),
        (0.5, False, 9),
        (0.6, True, 9),
        (1.0, True, 9),
        (1.01, True, 10),
    ]
    assert unrun_stretches_s(mixed) == pytest.approx(0.4 + 0.4)
    short = [(0.0, True, 5), (0.004, True, 5), (0.008, True, 5)]  # within a tick: it may have been running
    assert unrun_stretches_s(short) == 0.0


def test_any_other_autopilot_is_judged_as_before() -> None:
    clock = Held()
    fc = MavlinkFlightController("udpin:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    assert fc.standstill.port is None and fc.standstill.pid is None
    fc._conn = object()
    fc._state.last_message_s = fc._state.last_heartbeat_s = 100.0
    clock.t = fc._state.listened_s = 101.01
    assert not fc.telemetry().link_ok
