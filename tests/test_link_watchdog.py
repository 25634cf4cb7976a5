"""The MAVLink link watchdog counts the autopilot's silence from what the receiver has read (issue 29).

A ``masonry fly`` held up by a loaded machine (its receiver thread not run, messages waiting in the socket) must
not read that as a lost link; a receiver that listens and hears nothing must, after ``heartbeat_timeout_s`` as
before; a receiver that has read nothing for ``RECEIVER_HUNG_S`` counts wall time. A missing HEARTBEAT counts on
the slower of the local clock and the autopilot's own (masonry.adapters.link_silence): an autopilot that stood
still (ArduCopter's SITL starved by the machine) has not missed a beat. The receiver's state is set by hand, or
fed messages through its handler, on an adapter that opens nothing, at held clock readings.
"""

from __future__ import annotations

import pytest

from masonry.adapters.link_silence import beatless_s
from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.mavlink_link import RECEIVER_HUNG_S
from masonry.adapters.takeoff import ClimbMonitor, climb_limit_s
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


class Msg:
    """A received MAVLink message as the receiver's handler reads it (the fields it uses)."""

    def __init__(self, kind: str, **fields: float) -> None:
        self.kind = kind
        self.__dict__.update(fields)

    def get_type(self) -> str:
        return self.kind

    def get_srcSystem(self) -> int:
        return 1

    def get_srcComponent(self) -> int:
        return 1


def heard(
    fc: MavlinkFlightController, clock: Held, wall_s: float, boot_s: float, *, beat: bool = False
) -> None:
    """The receiver reads, at local ``wall_s``, an ATTITUDE stamped ``boot_s`` on the autopilot's clock (and a
    HEARTBEAT after it), having listened until then."""
    clock.t = wall_s
    fc._handle(Msg("ATTITUDE", roll=0.0, pitch=0.0, yaw=0.0, time_boot_ms=round(boot_s * 1000)), wall_s)
    if beat:
        fc._handle(Msg("HEARTBEAT", base_mode=0, custom_mode=0), wall_s)
    fc._state.listened_s = wall_s


def streaming(clock: Held, rate: float) -> MavlinkFlightController:
    """A link to an autopilot whose clock runs ``rate`` times the local one, heard at 30 Hz (its clock) for 1 s."""
    fc = MavlinkFlightController("udpin:127.0.0.1:9", heartbeat_timeout_s=1.0, monotonic=clock)
    fc._conn = object()
    fc.target_system = fc.target_component = 1
    for i in range(31):
        heard(fc, clock, 100.0 + i / 30 / rate, 50.0 + i / 30, beat=i % 30 == 0)
    return fc


@pytest.mark.parametrize("rate", [1.0, 5.0])
def test_an_autopilot_whose_clock_stood_still_has_not_lost_its_heartbeat(rate: float) -> None:
    """ArduCopter's SITL starved by a loaded machine (seen at x5: 2.7 s of wall between two messages, 0.13 s on
    its clock): the first message after the pause finds the last HEARTBEAT old in wall time, not on its clock."""
    clock = Held()
    fc = streaming(clock, rate)
    beat_wall_s, beat_boot_s = fc._state.last_heartbeat_s, 51.0
    assert fc.telemetry().link_ok
    heard(fc, clock, beat_wall_s + 2.88, beat_boot_s + 0.13)  # the pause, then a message
    assert fc.telemetry().link_ok
    fc._check_link("takeoff")  # no LinkLost
    # still no HEARTBEAT once its clock has moved on 2.5 s from the last (and the wall clock too): lost
    heard(fc, clock, beat_wall_s + 2.88 + 2.37 / rate, beat_boot_s + 2.50)
    assert fc.telemetry().link_ok
    heard(fc, clock, beat_wall_s + 2.88 + 2.40 / rate, beat_boot_s + 2.53)
    assert not fc.telemetry().link_ok
    with pytest.raises(LinkLost, match=r"no HEARTBEAT from the autopilot .* for 2\.5 s"):
        fc._check_link("hover")


def test_a_stream_without_heartbeats_is_lost_after_the_slower_clock_counts_2_5_s() -> None:
    """An autopilot clock running at x5 (a SITL) counts 2.5 s in half a wall second: the wall clock decides."""
    clock = Held()
    fc = streaming(clock, 5.0)
    beat_wall_s, beat_boot_s = fc._state.last_heartbeat_s, 51.0
    heard(fc, clock, beat_wall_s + 2.49, beat_boot_s + 5 * 2.49)  # 12.5 s on its clock, 2.49 s of wall
    assert fc.telemetry().link_ok
    heard(fc, clock, beat_wall_s + 2.51, beat_boot_s + 5 * 2.51)
    assert not fc.telemetry().link_ok
    heard(fc, clock, beat_wall_s + 2.6, beat_boot_s + 5 * 2.6, beat=True)  # a HEARTBEAT: back
    assert fc.telemetry().link_ok


def test_without_the_autopilots_clock_or_after_its_reboot_the_wall_clock_counts() -> None:
    assert beatless_s(103.0, 100.0, None, None) == 3.0  # no time-stamped telemetry yet
    assert beatless_s(103.0, 100.0, 51.0, None) == 3.0  # the last HEARTBEAT came before any
    assert beatless_s(103.0, 100.0, 2.0, 50.0) == 3.0  # its clock went back: rebooted
    assert beatless_s(103.0, 100.0, 50.2, 50.0) == pytest.approx(0.2)
    assert beatless_s(103.0, 100.0, 70.0, 50.0) == 3.0


def test_the_watchdog_logs_how_far_the_autopilots_clock_moved_while_the_link_was_down(
    caplog: pytest.LogCaptureFixture,
) -> None:
    """The x5 loop's remaining failure (docs/performance/autopilots.md): 1.55 s of wall without a message while the
    receiver listened, 35 ms on the SITL's clock. A total silence is a lost link (nothing arrives to read a clock
    from); the log line at its end says the autopilot stood still meanwhile."""
    clock = Held()
    fc = streaming(clock, 5.0)
    last_s = clock.t
    clock.t = fc._state.listened_s = last_s + 1.07  # the receiver listens and hears nothing
    with caplog.at_level("WARNING", logger="masonry.adapters.mavlink_link"):
        assert not fc.telemetry().link_ok
        heard(fc, clock, last_s + 1.55, 51.0 + 0.035)
        assert fc.telemetry().link_ok
    down, back = (r.getMessage() for r in caplog.records)
    assert "link down (" in down and "last message 1.07 s ago" in down and "autopilot clock 51.00 s" in down
    assert back.endswith(
        "since the last message before it went down 1.55 s of this computer's clock, 0.03 s of the autopilot's"
    )


def test_the_autopilots_clock_holds_while_the_watchdog_holds_the_link_and_runs_on_once_it_is_lost() -> None:
    """Issue 29: ``LinkClock`` extrapolated a silent autopilot's time at its rate for ever (x5: 0.9 s of silence
    read 4.5 s on the machines' timers). Now 0.5 s of its clock at most past the last message; held while the
    watchdog holds the link alive (a stand-still: its clock stood still too); once the link is lost, on at this
    computer's rate, so that the machine's own handling of a lost link (its emergency's give-up) runs."""
    clock = Held()
    fc = streaming(clock, 5.0)
    last_s, last_boot_s = clock.t, fc.clock.last_boot_s
    assert fc.clock.rate == pytest.approx(5.0, rel=0.01) and not fc.clock.stale
    clock.t = fc._state.listened_s = last_s + 0.9  # the receiver listens and hears nothing
    assert fc.telemetry().link_ok
    assert fc.clock.now_s() == pytest.approx(last_boot_s + 0.5) and fc.clock.stale  # (was + 4.5)
    assert fc.telemetry().time_s == pytest.approx(last_boot_s + 0.5)
    clock.t = fc._state.listened_s = last_s + 1.5
    assert not fc.telemetry().link_ok
    assert fc.clock.now_s() == pytest.approx(last_boot_s + 1.0)  # on at 1x past its 1 s hold (was + 7.5)


def taking_off(
    clock: Held, rate: float, autopilot: str
) -> tuple[MavlinkFlightController, list[tuple[float, float, float]]]:
    """An armed, streaming link to ``autopilot`` (:func:`streaming`), and the velocity setpoints it sends."""
    fc = streaming(clock, rate)
    fc.autopilot = autopilot
    sent: list[tuple[float, float, float]] = []
    fc._send_position_target = lambda velocity, yaw_rate: sent.append(velocity)  # type: ignore[method-assign]
    fc._state.armed, fc._streaming = True, True
    return fc, sent


def test_a_px4_climb_holds_its_altitude_and_is_not_judged_on_a_stale_clock() -> None:
    """The take-off climb's monitor (masonry.adapters.takeoff) judges progress on the autopilot's clock and sets
    the climb from the last altitude heard: over a silence the stream went on climbing on that altitude while the
    monitor's timers ran. On a stale clock the stream holds the altitude and the monitor judges nothing."""
    clock = Held()
    fc, sent = taking_off(clock, 5.0, "px4")
    fc._state.position_ned, fc._state.velocity_ned = (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)
    fc._takeoff_target_m = 1.2
    fc._climb = ClimbMonitor(fc.clock.now_s(), 1.2)
    fc._stream_setpoint(clock.t)
    assert sent[-1][2] < -0.1  # climbing (NED: up is negative)
    clock.t = fc._state.listened_s = clock.t + 3.0  # silent: the link lost, the clock on at 1x past its hold
    assert not fc.telemetry().link_ok
    fc._stream_setpoint(clock.t)
    assert sent[-1] == (0.0, 0.0, 0.0)  # held
    assert fc._climb is not None and fc._climb.state == "climbing", fc._climb.reason  # not judged


@pytest.mark.parametrize(("timeout_s", "limit_s"), [(None, 28.0), (30.0, 28.0), (12.0, 10.8)])
def test_an_ardupilot_take_off_is_timed_on_the_autopilots_clock(
    timeout_s: float | None, limit_s: float
) -> None:
    """The adapter lets the stream fly (and says why) once ArduPilot's own climb has reached its altitude or run
    out of its time; that time-out counted this computer's seconds while the machine's take-off counts the
    autopilot's. A SITL slower than the wall (x0.5: lock-step behind a loaded client) then had its climb cut short
    after 10 s of its own time by the stream's setpoints. Its time is the machine's ``takeoff_timeout_s`` (what
    of it the machine passes to ``takeoff``; ``TAKEOFF_TIMEOUT_S``, 30 s, when none) less ``REPORT_MARGIN_S``: it
    was 20 s of the adapter's own against the machine's 30: a machine told 12 s gave the take-off up, and the
    setpoints of its failsafe and return waited for ArduPilot's climb until the adapter's 20 s."""
    assert climb_limit_s(timeout_s) == pytest.approx(limit_s)
    clock = Held()
    fc, sent = taking_off(clock, 0.5, "ardupilot")
    fc._state.position_ned, fc._state.velocity_ned = (0.0, 0.0, -0.5), (0.0, 0.0, -0.3)  # climbing, 0.5 m up
    fc._takeoff_target_m, fc._takeoff_started_s = 1.2, fc.clock.now_s()
    fc._takeoff_limit_s = climb_limit_s(timeout_s)  # (as takeoff() sets it)
    wall0_s, boot0_s = clock.t, fc.clock.last_boot_s
    assert boot0_s is not None
    steps = round((limit_s - 0.3) / 0.05)
    for i in range(1, steps):  # up to 0.3 s short of its time (of its clock), twice that of wall
        heard(fc, clock, wall0_s + 0.1 * i, boot0_s + 0.05 * i)
    fc._stream_setpoint(clock.t)
    assert fc._takeoff_target_m == 1.2 and fc.takeoff_problem is None and not sent  # still ArduPilot's climb
    for i in range(steps, steps + 12):  # 0.3 s past it
        heard(fc, clock, wall0_s + 0.1 * i, boot0_s + 0.05 * i)
    fc._stream_setpoint(clock.t)
    assert fc._takeoff_target_m is None
    assert fc.takeoff_problem == f"take-off at 0.50 m of 1.20 m after {limit_s:.0f} s"
