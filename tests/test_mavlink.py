"""The MAVLink adapter's pure parts: ENU <-> NED frames, type mask, modes, signing keys, construction checks."""

from __future__ import annotations

import math
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

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
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=0.3)
    started = time.monotonic()
    with pytest.raises(DeviceNotFound, match=f"no autopilot heartbeat on udpin:127.0.0.1:{port}"):
        fc.connect()
    assert time.monotonic() - started < 1.5
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
    assert not estimate_usable(m.ESTIMATOR_ATTITUDE | m.ESTIMATOR_ACCEL_ERROR | indoor)
    assert not estimate_usable(0)
