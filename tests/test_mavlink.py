"""The MAVLink adapter's pure parts: ENU <-> NED frames, type mask, modes, signing keys, construction checks."""

from __future__ import annotations

import logging
import math
import threading
import time

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.adapters.link_values import EXTRAPOLATION_HORIZON_S, HOLD_S, RATE_WINDOW_S
from masonry.adapters.lockstep import LOCKSTEP_TEXT
from masonry.adapters.mavlink import (
    ARDUPILOT_MODES,
    PX4_MODES,
    TYPE_MASK_VELOCITY_YAW_RATE,
    FrameTransform,
    LinkClock,
    MavlinkFlightController,
    estimate_usable,
    load_signing_key,
    mavutil_module,
    mode_name,
)
from masonry.errors import DeviceNotFound, InputError, LinkLost
from waiting import SteppingClock

finite = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False)
angles = st.floats(min_value=-math.pi, max_value=math.pi, allow_nan=False)
vec = st.tuples(finite, finite, finite)


def close(a, b, tol=1e-9):
    return all(abs(x - y) <= tol * (1 + abs(y)) for x, y in zip(a, b))


def test_enu_ned_axes_at_identity() -> None:
    f = FrameTransform()
    assert f.position_to_ned((1.0, 2.0, 3.0)) == (2.0, 1.0, -3.0)  # east, north, up -> north, east, down
    assert f.velocity_to_world((0.5, 0.0, -1.0)) == (0.0, 0.5, 1.0)  # north and climbing
    # NED yaw 0 faces north: ENU yaw pi/2; NED yaw pi/2 faces east: ENU yaw 0
    assert f.attitude_to_world(0.0, 0.0, 0.0)[2] == pytest.approx(math.pi / 2)
    assert f.attitude_to_world(0.0, 0.0, math.pi / 2)[2] == pytest.approx(0.0)
    # the same physical nose-up rotation is +pitch about FRD's right axis and -pitch about FLU's left axis
    assert f.attitude_to_world(0.1, 0.2, 0.0)[:2] == (0.1, -0.2)
    assert FrameTransform.yaw_rate_to_ned(0.3) == -0.3  # counter-clockwise from above is negative about down


def test_offset_and_yaw_place_the_autopilot_origin_in_the_world() -> None:
    f = FrameTransform(offset_m=(10.0, 5.0, 1.0), yaw_rad=math.pi / 2)
    # the autopilot's local east axis points along world north (yaw +90 deg)
    assert close(f.position_to_world((0.0, 1.0, 0.0)), (10.0, 6.0, 1.0))
    assert close(f.position_to_world((0.0, 0.0, -2.0)), (10.0, 5.0, 3.0))
    assert close(f.velocity_to_ned((0.0, 1.0, 0.0)), (0.0, 1.0, 0.0), 1e-12)


@given(p=vec, offset=vec, yaw=angles)
def test_position_round_trip(p, offset, yaw) -> None:
    f = FrameTransform(offset_m=offset, yaw_rad=yaw)
    assert close(f.position_to_world(f.position_to_ned(p)), p, 1e-9)
    assert close(f.position_to_ned(f.position_to_world(p)), p, 1e-9)


@given(v=vec, yaw=angles)
def test_velocity_round_trip_and_norm(v, yaw) -> None:
    f = FrameTransform(yaw_rad=yaw)
    ned = f.velocity_to_ned(v)
    assert close(f.velocity_to_world(ned), v, 1e-9)
    assert math.hypot(*ned) == pytest.approx(math.hypot(*v), rel=1e-9, abs=1e-9)


@given(roll=angles, pitch=st.floats(-1.5, 1.5), yaw=angles, frame_yaw=angles)
def test_attitude_round_trip(roll, pitch, yaw, frame_yaw) -> None:
    f = FrameTransform(yaw_rad=frame_yaw)
    r, p, y = f.attitude_to_ned(*f.attitude_to_world(roll, pitch, yaw))
    assert (r, p) == pytest.approx((roll, pitch))
    assert math.cos(y - yaw) == pytest.approx(1.0)


def test_type_mask_flies_velocity_and_yaw_rate_only() -> None:
    m = mavutil_module().mavlink
    assert m.WIRE_PROTOCOL_VERSION == "2.0"
    ignored = (
        m.POSITION_TARGET_TYPEMASK_X_IGNORE
        | m.POSITION_TARGET_TYPEMASK_Y_IGNORE
        | m.POSITION_TARGET_TYPEMASK_Z_IGNORE
        | m.POSITION_TARGET_TYPEMASK_AX_IGNORE
        | m.POSITION_TARGET_TYPEMASK_AY_IGNORE
        | m.POSITION_TARGET_TYPEMASK_AZ_IGNORE
        | m.POSITION_TARGET_TYPEMASK_YAW_IGNORE
    )
    assert ignored == TYPE_MASK_VELOCITY_YAW_RATE
    for used in (
        m.POSITION_TARGET_TYPEMASK_VX_IGNORE,
        m.POSITION_TARGET_TYPEMASK_VY_IGNORE,
        m.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
        m.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE,
    ):
        assert not TYPE_MASK_VELOCITY_YAW_RATE & used


def test_mode_tables_match_pymavlink() -> None:
    mavutil = mavutil_module()
    copter = mavutil.mode_mapping_acm
    for name, number in ARDUPILOT_MODES.items():
        assert copter[number] == name
    assert mode_name("ardupilot", 4) == "GUIDED"
    assert mode_name("px4", PX4_MODES["OFFBOARD"]) == "OFFBOARD"
    assert mode_name("px4", PX4_MODES["AUTO.LAND"]) == "AUTO.LAND"
    assert mode_name("ardupilot", 99) == "MODE(99)"


def test_signing_key_formats(tmp_path) -> None:
    raw = bytes(range(32))
    (tmp_path / "raw.key").write_bytes(raw)
    (tmp_path / "hex.key").write_text(raw.hex() + "\n")
    (tmp_path / "pass.key").write_text("correct horse battery staple\n")
    (tmp_path / "empty.key").write_text("  \n")
    assert load_signing_key(tmp_path / "raw.key") == raw
    assert load_signing_key(tmp_path / "hex.key") == raw
    import hashlib

    assert load_signing_key(tmp_path / "pass.key") == hashlib.sha256(b"correct horse battery staple").digest()
    with pytest.raises(InputError, match="empty"):
        load_signing_key(tmp_path / "empty.key")
    with pytest.raises(InputError, match=r"missing\.key"):
        load_signing_key(tmp_path / "missing.key")


def test_constructor_validates_and_does_not_connect() -> None:
    fc = MavlinkFlightController("udpin:127.0.0.1:9")  # nothing is opened yet
    assert not fc.connected
    assert fc.telemetry().link_ok is False
    with pytest.raises(LinkLost, match="not connected"):
        fc.send_velocity((0.0, 0.0, 0.0), 0.0)
    with pytest.raises(InputError, match="10 Hz"):
        MavlinkFlightController("udpin:127.0.0.1:9", setpoint_rate_hz=5.0)
    with pytest.raises(InputError, match="32 bytes"):
        MavlinkFlightController("udpin:127.0.0.1:9", signing_key=b"short")
    with pytest.raises(InputError, match="autopilot"):
        MavlinkFlightController("udpin:127.0.0.1:9", autopilot="betaflight")  # type: ignore[arg-type]


def test_silent_endpoint_is_a_clear_error() -> None:
    from masonry.adapters.sitl import free_udp_port

    port = free_udp_port()
    clock = SteppingClock(0.01)
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=0.3, monotonic=clock)
    started_s = clock.now_s
    with pytest.raises(
        DeviceNotFound, match=rf"no autopilot heartbeat on udpin:127.0.0.1:{port} within 0\.3 s"
    ):
        fc.connect()
    # it gave up at its timeout on its clock, within one poll (two reads) of it: not before, not later
    assert 0.3 <= clock.now_s - started_s <= 0.3 + 3 * 0.01 + 1e-9
    assert not fc.connected


def test_unopenable_endpoint_names_it() -> None:
    fc = MavlinkFlightController("/dev/masonry-no-such-autopilot", connect_timeout_s=0.3)
    with pytest.raises(DeviceNotFound, match="/dev/masonry-no-such-autopilot"):
        fc.connect()


def test_link_clock_follows_the_autopilot_rate() -> None:
    clock = LinkClock()
    assert clock.rate == 1.0
    for i in range(11):
        clock.observe(100.0 + 0.5 * i, 1000.0 + 0.1 * i)  # autopilot runs 5x faster than us
    assert clock.rate == pytest.approx(5.0)
    clock.observe(0.2, 1001.1)  # reboot: restart the estimate
    assert clock.rate == 1.0


def test_link_clock_extrapolates_up_to_its_horizon_then_holds_then_runs_on_at_this_computers_rate() -> None:
    # issue 29: the extrapolation had no bound, so a silent autopilot's time ran on at its rate as if the link
    # were alive (a SITL at x5 left unrun for 3 s read 15 s on the machines' timers, then held while it caught up)
    local = [1000.0]
    clock = LinkClock(lambda: local[0])  # horizon 0.5 s of the autopilot's clock, hold 1 s of this computer's
    assert clock.horizon_s == EXTRAPOLATION_HORIZON_S == 0.5 and clock.hold_s == HOLD_S == 1.0
    for i in range(11):
        clock.observe(100.0 + 0.5 * i, 1000.0 + 0.1 * i)  # x5; the last: 105.0 at 1001.0
    assert clock.rate == pytest.approx(5.0)
    readings = {}
    for t in (1001.06, 1001.2, 1001.5, 1002.0, 1004.0):
        local[0] = t
        readings[t] = (clock.now_s(), clock.stale)
    assert readings[1001.06] == (pytest.approx(105.3), False)  # at the rate within the horizon
    assert readings[1001.2] == (pytest.approx(105.5), True)  # past the horizon (0.1 s here): held
    assert readings[1001.5] == (pytest.approx(105.5), True)
    assert readings[1002.0] == (pytest.approx(105.5), True)  # held for 1 s of this computer's clock
    assert readings[1004.0] == (pytest.approx(107.5), True)  # then on at 1x (the old extrapolation: 120.0)
    clock.observe(105.2, 1004.0)  # back: the SITL had moved 0.2 s
    assert clock.now_s() == pytest.approx(107.5) and not clock.stale  # never backwards
    clock.extrapolate = False  # lock-step: the time last heard, as before
    assert clock.now_s() == 105.2


def _feed(clock: LinkClock, boot_s: float, local_s: float, rate: float, wall_s: float) -> tuple[float, float]:
    """30 Hz time-stamped messages from an autopilot running at ``rate`` for ``wall_s`` of local time; the last."""
    for _ in range(round(wall_s * 30)):
        boot_s, local_s = boot_s + rate / 30, local_s + 1 / 30
        clock.observe(boot_s, local_s)
    return boot_s, local_s


def test_link_clock_follows_a_sitl_whose_speed_changes_within_its_window() -> None:
    """Issue 29: the rate was averaged since the link came up, so a SITL at x5 for 60 s that a loaded machine then
    slowed to x2 was still extrapolated (and slept for) at x4.77 after 5 s of wall at x2. Now the last ``window_s``."""
    local = [1000.0]
    clock = LinkClock(lambda: local[0])
    assert clock.window_s == RATE_WINDOW_S == 2.0
    boot_s, local[0] = _feed(clock, 100.0, 1000.0, 5.0, 60.0)
    assert clock.rate == pytest.approx(5.0)
    boot_s, local[0] = _feed(clock, boot_s, local[0], 2.0, 1.0)
    assert 2.0 < clock.rate < 5.0  # half its window at the new speed
    boot_s, local[0] = _feed(clock, boot_s, local[0], 2.0, RATE_WINDOW_S)
    assert clock.rate == pytest.approx(2.0)  # (since the link came up: 4.86)
    local[0] += 0.2  # within the horizon at x2 (0.25 s of wall): 0.4 s on
    assert clock.now_s() == pytest.approx(boot_s + 0.4) and not clock.stale  # (at 4.86: held, stale)
    boot_s, local[0] = _feed(clock, boot_s + 0.4, local[0], 5.0, RATE_WINDOW_S + 0.1)  # and back up
    assert clock.rate == pytest.approx(5.0)


def test_link_clock_leaves_a_stand_still_out_of_its_rate() -> None:
    """A SITL left unrun (1.5 s of wall, its clock still) runs on at its speed after it: the rate is the one before
    it, then measured from after it (over a window with the silence in it: x1.25 for 2 s, slept for 4 times too
    long), while a receiver that was starved (the autopilot's clock moved on meanwhile) is measured through it."""
    local = [1000.0]
    clock = LinkClock(lambda: local[0])
    boot_s, local[0] = _feed(clock, 100.0, 1000.0, 5.0, 10.0)
    local[0] += 1.5
    clock.observe(boot_s + 1 / 30, local[0])  # stood still
    assert clock.rate == pytest.approx(5.0)
    boot_s, local[0] = _feed(clock, boot_s + 1 / 30, local[0], 5.0, 0.1)
    assert clock.rate == pytest.approx(5.0)  # still the rate before it: less than RATE_MIN_SPAN_S since
    boot_s, local[0] = _feed(clock, boot_s, local[0], 5.0, 0.5)
    assert clock.rate == pytest.approx(5.0)  # measured after it
    local[0] += 1.5
    clock.observe(boot_s + 7.5, local[0])  # the receiver starved: 1.5 s of messages at once, in order
    boot_s, local[0] = _feed(clock, boot_s + 7.5, local[0], 5.0, 0.5)
    assert clock.rate == pytest.approx(5.0)


@settings(max_examples=60, derandomize=True)
@given(
    before=st.floats(min_value=0.5, max_value=10.0),
    after=st.floats(min_value=0.5, max_value=10.0),
    before_s=st.floats(min_value=0.3, max_value=120.0),
)
def test_link_clock_rate_is_the_new_speed_one_window_after_a_change(
    before: float, after: float, before_s: float
) -> None:
    local = [0.0]
    clock = LinkClock(lambda: local[0])
    boot_s, local[0] = _feed(clock, 0.0, 0.0, before, before_s)
    boot_s, local[0] = _feed(clock, boot_s, local[0], after, RATE_WINDOW_S + 1 / 30)
    assert clock.rate == pytest.approx(after, rel=1e-6), (before, after, before_s)
    local[0] += 0.5 * EXTRAPOLATION_HORIZON_S / after  # half-way to the horizon at the new speed
    assert clock.now_s() == pytest.approx(boot_s + 0.5 * EXTRAPOLATION_HORIZON_S)


def test_link_clock_sleep_is_scaled(monkeypatch: pytest.MonkeyPatch) -> None:
    clock = LinkClock()
    now = time.monotonic()
    clock.observe(0.0, now - 1.0)
    clock.observe(10.0, now)  # rate 10
    slept_s: list[float] = []
    # the wall time asked of the OS, not the time a busy machine took to give it back
    with monkeypatch.context() as patch:
        patch.setattr(time, "sleep", slept_s.append)
        clock.sleep(0.5)
        clock.sleep(0.0)  # nothing to wait for: no call
    assert slept_s == [pytest.approx(0.05)]
    before = 10.0 + 10 * (time.monotonic() - now)
    link_s = clock.now_s()
    after = 10.0 + 10 * (time.monotonic() - now)
    assert before - 1e-9 <= link_s <= after + 1e-9


def test_estimate_flags() -> None:
    m = mavutil_module().mavlink
    indoor = (
        m.EKF_ATTITUDE | m.EKF_VELOCITY_HORIZ | m.EKF_VELOCITY_VERT | m.EKF_POS_HORIZ_REL | m.EKF_POS_VERT_ABS
    )
    assert estimate_usable(indoor)  # motion capture, no GPS: no absolute horizontal position needed
    assert estimate_usable(indoor | m.EKF_POS_HORIZ_ABS | m.EKF_PRED_POS_HORIZ_REL)
    assert not estimate_usable(indoor | m.EKF_CONST_POS_MODE)
    assert not estimate_usable(indoor | m.EKF_UNINITIALIZED)
    assert not estimate_usable(indoor & ~m.EKF_POS_HORIZ_REL)
    assert not estimate_usable(indoor & ~m.EKF_POS_VERT_ABS)
    assert not estimate_usable(m.ESTIMATOR_ATTITUDE | m.ESTIMATOR_ACCEL_ERROR | indoor, "px4")
    assert not estimate_usable(0)


# -- the link's threads count and log every error they meet (none are dropped) -----------------------------


class _Msg:
    """A received message as pymavlink presents one: ``get_type``, source ids and the fields given."""

    def __init__(self, kind: str, src_system: int = 1, **fields: object) -> None:
        self._kind = kind
        self._src = src_system
        self.__dict__.update(fields)

    def get_type(self) -> str:
        return self._kind

    def get_srcSystem(self) -> int:
        return self._src

    def get_srcComponent(self) -> int:
        return 1


class _Conn:
    """A connection that hands out ``messages`` (then nothing) and fails every send with ``send_error``."""

    def __init__(self, messages: list[_Msg], send_error: Exception | None = None, after: int = 1) -> None:
        self.messages = list(messages)
        self.send_error = send_error
        self.sends = 0
        self.after = after
        self.drained = threading.Event()
        self.sent = threading.Event()
        self.mav = self

    def recv_match(self, blocking: bool = True, timeout: float = 0.05) -> _Msg | None:
        if self.messages:
            return self.messages.pop(0)
        self.drained.set()
        return None

    def _send(self, *args: object) -> None:
        self.sends += 1
        if self.sends >= self.after:
            self.sent.set()
        if self.send_error is not None:
            raise self.send_error

    heartbeat_send = set_position_target_local_ned_send = command_long_send = _send

    def close(self) -> None:
        pass


def _link_on(conn: _Conn) -> MavlinkFlightController:
    fc = MavlinkFlightController("udpin:127.0.0.1:9")
    fc.target_system = fc.target_component = 1
    fc._conn = conn
    return fc


def test_a_message_the_handler_cannot_read_is_counted_and_logged(caplog) -> None:
    fc = _link_on(_Conn([]))
    assert fc.status().errors == 0 and fc.status().last_error is None
    with caplog.at_level(logging.WARNING, logger="masonry.adapters.mavlink_link"):
        fc._receive(_Msg("LOCAL_POSITION_NED", time_boot_ms=10), 1.0)  # no x, y, z: another dialect
        fc._receive(_Msg("SYS_STATUS", battery_remaining="full", voltage_battery=12000), 1.0)  # ill-typed
    status = fc.status()
    assert status.handler_errors == 2 and status.errors == 2
    assert status.last_error is not None and status.last_error.startswith("unhandled message: TypeError")
    assert sum("unhandled message" in r.getMessage() for r in caplog.records) == 2
    fc._receive(_Msg("ATTITUDE", roll=0.1, pitch=0.0, yaw=0.0, time_boot_ms=20), 1.0)  # still listening
    assert fc._state.attitude == (0.1, 0.0, 0.0) and fc.status().handler_errors == 2


def test_the_receiver_thread_counts_bad_messages_and_keeps_listening() -> None:
    bad = [_Msg("LOCAL_POSITION_NED", time_boot_ms=10) for _ in range(5)]
    good = _Msg("ATTITUDE", roll=0.0, pitch=0.2, yaw=0.0, time_boot_ms=30)
    conn = _Conn([*bad, good])
    fc = _link_on(conn)
    thread = threading.Thread(target=fc._receive_loop, daemon=True)
    thread.start()
    try:
        assert conn.drained.wait(timeout=10.0), "the receiver did not drain the connection"
    finally:
        fc._stop.set()
        thread.join(timeout=10.0)
    assert not thread.is_alive()
    assert fc.status().handler_errors == 5
    assert fc._state.attitude == (0.0, 0.2, 0.0)


def test_the_sender_thread_counts_failed_sends_and_keeps_streaming(caplog) -> None:
    conn = _Conn([], send_error=OSError("network is unreachable"), after=4)
    fc = _link_on(conn)
    fc._streaming = fc._state.armed = True  # the setpoint stream runs (20 Hz), each send fails
    thread = threading.Thread(target=fc._send_loop, daemon=True)
    with caplog.at_level(logging.WARNING, logger="masonry.adapters.mavlink_link"):
        thread.start()
        try:
            assert conn.sent.wait(timeout=10.0), "the sender stopped after a failed send"
        finally:
            fc._stop.set()
            thread.join(timeout=10.0)
    assert not thread.is_alive()
    status = fc.status()
    assert status.send_errors >= 3 and status.setpoints_sent == 0
    assert status.last_error == "send error: OSError: network is unreachable"
    assert any("send error" in r.getMessage() for r in caplog.records)


def test_a_text_heard_before_the_autopilots_first_heartbeat_is_kept() -> None:
    # issue 29: a lock-step SITL answers the adapter's first heartbeat with its announcement, which can come before
    # the SITL's own heartbeat; dropped, the client never granted and its SITL sat at 0 s (a GIL-holding thread in
    # the SITL load loop: "timed out after 10.0 s waiting for the SITL's lock-step announcement")
    text = _Msg("STATUSTEXT", severity=6, text=LOCKSTEP_TEXT)
    beat = _Msg("HEARTBEAT", type=2, autopilot=3, base_mode=0, custom_mode=4, system_status=4)
    fc = MavlinkFlightController("udpin:127.0.0.1:9", connect_timeout_s=5.0)
    fc._conn = _Conn([text, beat])
    texts = fc.listen(("STATUSTEXT",))
    fc._await_first_heartbeat()
    assert fc.target_system == 1 and fc.autopilot == "ardupilot"
    assert texts.get_nowait().text == LOCKSTEP_TEXT  # what LockstepClock reads
    assert any(LOCKSTEP_TEXT in line for line in fc.status_texts())
