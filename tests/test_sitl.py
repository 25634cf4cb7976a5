"""The MAVLink adapter against the SITL over UDP on loopback: flight, link loss, rejections, signing, streams.

The SITL runs faster than real time (``TIME_SCALE``); each test stays within a few wall seconds.
"""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pytest

from masonry.adapters.lockstep import LockstepClock
from masonry.adapters.mavlink import (
    HEARTBEAT_MISSING_S,
    MAV_CMD_COMPONENT_ARM_DISARM,
    MavlinkFlightController,
    mavutil_module,
)
from masonry.adapters.sitl import MavlinkSitl, SitlConfig, free_udp_port
from masonry.adapters.sitl_config import EPHEMERAL_PORTS_DEFAULT, FREE_PORTS_FROM
from masonry.errors import CommandRejected, CommandTimeout, DeviceNotFound, LinkLost
from masonry.motion import MinJerk
from sitl_story import HeightTrace, describe_flight
from waiting import HeldClock, step_until, wait_until

TIME_SCALE = 8.0
#: lock-step's wait (wall s) before a SITL held at a grant runs free: far longer than a loaded machine's stall
LOCKSTEP_WAIT_S = 60.0
KEY = bytes(range(32))
OTHER_KEY = bytes(range(1, 33))


@contextmanager
def flight(
    config: SitlConfig | None = None,
    *,
    sitl_key: bytes | None = None,
    fc_key: bytes | None = None,
    home_m=(0.0, 0.0, 0.0),
    time_scale: float = TIME_SCALE,
    lockstep_wait_s: float | None = None,
    **fc_options,
) -> Iterator[tuple[MavlinkSitl, MavlinkFlightController]]:
    port = free_udp_port()
    # heartbeats at 4 Hz (ArduPilot: 1 Hz) so that armed/disarmed shows within a quarter second
    config = replace(config or SitlConfig(), heartbeat_hz=4.0)
    sitl = MavlinkSitl(
        port,
        time_scale=time_scale,
        config=config,
        signing_key=sitl_key,
        home_m=home_m,
        lockstep_wait_s=lockstep_wait_s,  # None: free at time_scale (lock-step: masonry.adapters.sitl_lockstep)
    )
    fc_options.setdefault("connect_timeout_s", 3.0)
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", signing_key=fc_key, **fc_options)
    sitl.start()
    started_wall_s = time.monotonic()
    try:
        yield sitl, fc
    except Exception as exc:
        exc.add_note(describe_flight(sitl, fc, started_wall_s))  # both sides at the failure (sitl_story)
        raise
    finally:
        fc.close()
        sitl.stop()


def take_off(fc: MavlinkFlightController, altitude_m: float = 1.2) -> None:
    fc.arm()
    fc.takeoff(altitude_m)
    take_off_wait(fc, altitude_m)


def take_off_wait(fc: MavlinkFlightController, altitude_m: float) -> None:
    """Wait for the take-off's altitude (within 0.05 m, still within 0.05 m/s); a miss shows the telemetry it saw
    (and ``flight`` adds both sides then)."""
    trace = HeightTrace(fc)
    wait_until(
        lambda: trace.reached(altitude_m),
        30.0,  # a bound on waiting for the evidence (about 0.5 s at x8 when the machine is idle)
        trace.awaited(altitude_m),
        detail=trace.describe,
    )


def test_connect_arm_takeoff_minimum_jerk_descent_land() -> None:
    # In lock-step (docs/sitl-lockstep.md): the SITL's time moves only as the loop below grants it, so its
    # figures are the same whatever the load (on the wall, a stall lagged the loop by the stall times the
    # speed-up: 12.8 cm worst at x4 under load, issue 29; at x1 6.7-6.9 cm)
    with flight(home_m=(1.0, 2.0, 0.0), telemetry_rate_hz=50.0, lockstep_wait_s=LOCKSTEP_WAIT_S) as (
        sitl,
        fc,
    ):
        clock = LockstepClock(fc)  # before connecting: the SITL announces lock-step on the first heartbeat
        fc.connect()
        assert fc.autopilot == "ardupilot" and fc.target_system == 1
        assert fc.warnings == []
        wait_until(lambda: clock.sleep(0.0) or clock.lockstep, 10.0, "the SITL's lock-step announcement")
        # the EKF's convergence (0.5 s), on the SITL's time: granted, not waited for on the wall
        step_until(clock, lambda: fc.telemetry().position_ok, 2.0, "the position estimate")
        wait_until(
            lambda: fc.telemetry().battery_fraction == fc.telemetry().battery_fraction, 2.0, "SYS_STATUS"
        )
        tel = fc.telemetry()
        assert tel.link_ok and tel.position_ok and tel.on_ground and not tel.armed
        assert tel.position_m == pytest.approx(
            (0.0, 0.0, 0.0), abs=0.01
        )  # its local origin is its home (GPS-like)
        assert tel.battery_fraction == pytest.approx(1.0)

        take_off_granted(fc, clock, 1.2)
        tel = fc.telemetry()
        assert tel.armed and tel.mode == "GUIDED" and not tel.on_ground
        assert tel.position_m[2] == pytest.approx(1.2, abs=0.05)

        worst, end = minimum_jerk_descent(fc, clock)
        assert end < 0.025
        assert worst < 0.1  # the autopilot's velocity lag and the telemetry latency

        fc.land()
        step_until(clock, lambda: not fc.telemetry().armed, 5.0, "touchdown and disarm")
        tel = fc.telemetry()
        assert tel.on_ground and tel.mode == "LAND" and tel.position_m[2] == pytest.approx(0.0, abs=0.02)
        assert tel.battery_fraction < 1.0
        assert "Land complete, disarming" in sitl.status_log
        # on the grants' time throughout (a reply later than 2 s of wall, a stall's, is not asserted on: the SITL
        # stays at its grant meanwhile)
        assert sitl.lockstep is not None and sitl.lockstep.free_runs == 0


def take_off_granted(fc: MavlinkFlightController, clock: LockstepClock, altitude_m: float) -> None:
    """``take_off`` on a SITL in lock-step: the climb waits for the SITL's time, granted 0.02 s at a time, for at
    most 10 s of it (the climb takes about 3 s)."""
    fc.arm()
    fc.takeoff(altitude_m)
    trace = HeightTrace(fc)
    step_until(
        clock,
        lambda: trace.reached(altitude_m),
        10.0,
        trace.awaited(altitude_m),
        detail=trace.describe,
    )


def minimum_jerk_descent(fc: MavlinkFlightController, clock: LockstepClock) -> tuple[float, float]:
    """A minimum-jerk descent of 0.6 m in 3 s (the autopilot's time), tracked with feedforward + P every 0.02 s
    of it: the worst distance (m) from the trajectory during it, and the distance from its goal at the end (after
    at most 3 s more to settle within 2 cm)."""
    start = np.array(fc.telemetry().position_m)
    goal = start - np.array([0.0, 0.0, 0.6])
    traj = MinJerk(start, np.zeros(3), np.zeros(3), goal, np.zeros(3), np.zeros(3), 3.0)
    t0 = clock.now_s()
    worst = 0.0
    while (t := clock.now_s() - t0) < traj.duration_s + 3.0:
        p = np.array(fc.telemetry().position_m)
        if t < traj.duration_s:
            ref = traj.position(t)
            worst = max(worst, float(np.linalg.norm(ref - p)))
        elif np.linalg.norm(goal - p) < 0.02:
            break  # settled on the goal
        v = traj.velocity(min(t, traj.duration_s)) + 1.5 * (traj.position(min(t, traj.duration_s)) - p)
        fc.send_velocity(tuple(v), 0.0)
        clock.sleep(0.02)
    return worst, float(np.linalg.norm(np.array(fc.telemetry().position_m) - goal))


def test_a_caller_left_unrun_right_after_the_take_off_ack_does_not_end_the_climb() -> None:
    """Issue 29 (the SITL loop's run 7: "timed out after 30.0 s waiting for the takeoff altitude"). From the arming
    the setpoint stream sent zero velocities, ignored on the ground, until the caller, back from NAV_TAKEOFF's
    ACK, told it a take-off was climbing. A caller left unrun for 0.15 s of the autopilot's time after the ACK (a
    loaded machine; at x1 a stall of 0.15 s of wall) let one arrive with the vehicle 1-2 cm off the ground: it
    ended ArduPilot's climb, and the vehicle hovered where it stopped, 7-8 cm up. The stall is injected here, at x1 (the stream ticks a dozen
    times while the vehicle climbs 0.3 m)."""
    with flight(time_scale=1.0) as (sitl, fc):
        fc.connect()
        fc.arm()
        command = fc.command

        def left_unrun_after_the_ack(name: str, number: int, params: tuple[float, ...] = ()) -> None:
            command(name, number, params)
            if name == "takeoff":  # meanwhile the vehicle lifts off and the stream ticks on
                wait_until(
                    lambda: sitl.vehicle.position_m[2] > 0.3 or not sitl.vehicle.taking_off,
                    10.0,
                    "the climb to pass 0.3 m or to end",
                )

        fc.command = left_unrun_after_the_ack  # type: ignore[method-assign]
        fc.takeoff(1.0)
        assert sitl.vehicle.taking_off, (
            f"the climb ended {sitl.vehicle.position_m[2]:.3f} m up (setpoint {sitl.last_setpoint_mps})"
        )
        take_off_wait(fc, 1.0)


def test_a_refused_take_off_leaves_the_stream_flying_the_callers_setpoint() -> None:
    # the climb is started before NAV_TAKEOFF goes out (issue 29): refused, the stream is as it was before
    with flight() as (sitl, fc):
        fc.connect()
        take_off(fc, 1.0)
        fc.send_velocity((0.2, 0.0, 0.0), 0.0)
        with pytest.raises(CommandRejected, match="takeoff rejected: failed: Takeoff: already flying"):
            fc.takeoff(0.5)
        assert fc._takeoff_target_m is None
        before = sitl.setpoints_received
        wait_until(lambda: sitl.setpoints_received >= before + 2, 5.0, "the stream to go on")
        assert sitl.last_setpoint_mps == pytest.approx((0.2, 0.0, 0.0), abs=1e-6)


def test_setpoints_stream_at_the_configured_rate_and_go_to_zero_when_stale() -> None:
    with flight(setpoint_rate_hz=20.0, setpoint_hold_s=0.3) as (sitl, fc):
        fc.connect()
        take_off(fc, 1.0)
        fc.send_velocity((0.3, 0.0, 0.0), 0.0)
        before, started = sitl.setpoints_received, time.monotonic()
        wait_until(lambda: sitl.setpoints_received >= before + 2, 5.0, "repeated setpoints")
        assert sitl.last_setpoint_mps == pytest.approx((0.3, 0.0, 0.0), abs=1e-6)  # repeated while fresh
        wait_until(
            lambda: sitl.last_setpoint_mps == pytest.approx((0.0, 0.0, 0.0), abs=1e-6),
            5.0,
            "the stale setpoint to go to zero",
        )  # caller silent: hover
        wait_until(lambda: time.monotonic() - started >= 1.0, 5.0, "one second of streaming")
        # the rate over the time that really passed, not over the time a sleep was asked for
        rate_hz = (sitl.setpoints_received - before) / (time.monotonic() - started)
        assert rate_hz >= 15.0  # >= 10 Hz required by the autopilots; configured 20 Hz


def test_link_loss_fires_the_watchdog_and_the_autopilot_failsafe() -> None:
    clock = HeldClock()
    with flight(SitlConfig(gcs_failsafe_s=1.5), heartbeat_timeout_s=1.0, monotonic=clock) as (sitl, fc):
        fc.connect()
        take_off(fc, 1.0)
        sitl.link_down = True  # radio outage: nothing gets through either way
        wait_until(lambda: not fc.telemetry().link_ok, 5.0, "link_ok to drop")
        # nothing arrives any more: the watchdog's window, at its edges, from the last message heard
        last_s = fc._state.last_message_s
        with clock.held_at(last_s + 0.99):
            assert fc.telemetry().link_ok  # not before the watchdog time (1 s)
        with clock.held_at(last_s + 1.01):
            assert not fc.telemetry().link_ok  # and not later
            with pytest.raises(LinkLost, match=r"no message from the autopilot .* for 1\.0 s"):
                fc.send_velocity((0.0, 0.0, 0.0), 0.0)
        with pytest.raises(LinkLost):
            fc.land()
        assert fc.telemetry().position_ok is False
        wait_until(lambda: sitl.mode == "LAND", 2.5, "the SITL's GCS failsafe")
        wait_until(lambda: not sitl.vehicle.armed, 5.0, "the failsafe landing")
        sitl.link_down = False
        wait_until(lambda: fc.telemetry().link_ok, 2.0, "the link to come back")
        assert fc.telemetry().mode == "LAND"


def test_rejected_arming_carries_the_autopilot_reason() -> None:
    with flight(SitlConfig(prearm_failure="Compass not calibrated")) as (_sitl, fc):
        fc.connect()
        with pytest.raises(CommandRejected) as info:
            fc.arm()
        assert info.value.command == "arm"
        assert info.value.reason == "failed: PreArm: Compass not calibrated"
        assert str(info.value) == "arm rejected: failed: PreArm: Compass not calibrated"
        assert not info.value.temporary  # ArduPilot's FAILED is not asked again
        assert not fc.telemetry().armed


def test_arming_is_asked_again_through_px4s_first_seconds() -> None:
    # PX4 answers TEMPORARILY_REJECTED until its arming checks pass (v1.16 SITL: 3 s after its first HEARTBEAT)
    config = SitlConfig(autopilot="px4", ekf2_flags=True, arm_ready_s=16.0)
    with flight(config, arm_retry_s=10.0) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(5.0)
        assert sitl.sim_time_s < 16.0  # the first arming is refused
        fc.arm()
        assert fc.telemetry().armed
        assert sitl.sim_time_s >= 16.0
        # OFFBOARD entered again with each asking: the stream runs armed only, PX4 leaves OFFBOARD without it
        assert fc.telemetry().mode == "OFFBOARD"


def test_a_temporary_refusal_is_asked_through_for_a_bounded_time() -> None:
    with flight(SitlConfig(autopilot="px4", ekf2_flags=True, arm_ready_s=1e6), arm_retry_s=1.0) as (
        _sitl,
        fc,
    ):
        fc.connect()
        with pytest.raises(CommandRejected) as info:
            fc.arm()
        assert info.value.temporary
        assert re.fullmatch(
            r"temporarily rejected for \d\.\d s \(asked \d+ times, for at most 1 s\)", info.value.reason
        )
        assert not fc.telemetry().armed


def test_arming_waits_for_the_position_estimate() -> None:
    with flight(SitlConfig(ekf_converge_s=1000.0), estimate_timeout_s=0.4) as (_sitl, fc):
        fc.connect()
        assert fc.telemetry().position_ok is False
        with pytest.raises(CommandRejected, match=r"no usable position estimate .* after 0\.4 s"):
            fc.arm()


def test_takeoff_before_arming_and_disarm_in_flight_are_refused() -> None:
    with flight() as (_sitl, fc):
        fc.connect()
        fc.wait_for_estimate(2.0)
        fc.set_mode("GUIDED")
        with pytest.raises(CommandRejected, match="takeoff rejected: not armed"):
            fc.takeoff(1.0)
        # the autopilot's own refusal, bypassing the adapter's check
        with pytest.raises(CommandRejected, match="takeoff rejected: failed: Takeoff: not armed"):
            fc.command("takeoff", 22, (0, 0, 0, 0, 0, 0, 1.0))
        take_off(fc, 1.0)
        with pytest.raises(CommandRejected, match="disarm rejected: failed"):
            fc.disarm()
        assert fc.telemetry().armed


def test_a_silent_autopilot_times_out_after_retries() -> None:
    """A peer that sends heartbeats but never answers commands."""
    mavutil = mavutil_module()
    port = free_udp_port()
    peer = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1, source_component=1)
    fc = MavlinkFlightController(
        f"udpin:127.0.0.1:{port}", connect_timeout_s=0.6, command_timeout_s=0.15, command_retries=2
    )
    import threading

    stop = threading.Event()
    heard: list[int] = []  # the confirmation field of each DO_SET_MODE the peer receives

    def beat() -> None:
        while not stop.is_set():
            peer.mav.heartbeat_send(2, 3, 0, 0, 3)
            while (msg := peer.recv_msg()) is not None:
                if msg.get_type() == "COMMAND_LONG" and msg.command == 176:
                    heard.append(int(msg.confirmation))
            stop.wait(0.01)

    thread = threading.Thread(target=beat, daemon=True)
    thread.start()
    try:
        fc.connect()
        started = time.monotonic()
        with pytest.raises(CommandTimeout, match=r"set mode GUIDED: no COMMAND_ACK .* after 3 tries"):
            fc.set_mode("GUIDED")
        assert time.monotonic() - started >= 3 * 0.15  # each try waited its command timeout
        # the first send and two retries, numbered in MAVLink's confirmation field
        wait_until(lambda: len(heard) >= 3, 5.0, "the peer to receive the three tries")
        assert heard == [0, 1, 2]
        assert any("SET_MESSAGE_INTERVAL" in w for w in fc.warnings)  # rates were not acknowledged either
        assert any("no time-stamped telemetry" in w for w in fc.warnings)
    finally:
        stop.set()
        thread.join()
        fc.close()
        peer.close()


def test_message_rates_are_requested() -> None:
    with flight(telemetry_rate_hz=25.0) as (sitl, fc):
        fc.connect()
        wait_until(lambda: sitl._rates_hz[32] == pytest.approx(25.0), 1.0, "the LOCAL_POSITION_NED rate")
        assert sitl._rates_hz[30] == pytest.approx(25.0)
        assert fc.warnings == []


def test_signing_on_both_ends_and_a_wrongly_signed_peer_is_ignored() -> None:
    # The adapter with the wrong key never sees a heartbeat.
    with (
        flight(sitl_key=KEY, fc_key=OTHER_KEY, connect_timeout_s=0.5) as (_sitl, fc),
        pytest.raises(DeviceNotFound, match="signing key"),
    ):
        fc.connect()
    # A wrongly signed (or unsigned) peer's commands do nothing, while the right peer flies.
    mavutil = mavutil_module()
    with flight(sitl_key=KEY, fc_key=KEY) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(2.0)
        for key in (OTHER_KEY, None):
            rogue = mavutil.mavlink_connection(f"udpout:127.0.0.1:{sitl_port(sitl)}", source_system=200)
            if key is not None:
                rogue.setup_signing(key, sign_outgoing=True)
            mav = sitl._conn.mav
            refused_before = mav.total_receive_errors
            rogue.mav.command_long_send(1, 1, 176, 0, 1, 4, 0, 0, 0, 0, 0)  # GUIDED
            rogue.mav.command_long_send(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)  # arm
            # the evidence that both arrived and were dropped unread: the SITL's parser refused them
            wait_until(
                lambda: mav.total_receive_errors >= refused_before + 2,  # noqa: B023
                5.0,
                "the SITL to refuse the rogue's two commands",
            )
            rogue.close()
            assert not sitl.vehicle.armed and sitl.mode == "STABILIZE"
        # the wrong key's two were refused on their signature (the unsigned ones are refused unread)
        assert sitl._conn.mav.signing.badsig_count >= 2
        fc.arm()  # signing on both ends: the right peer's commands go through, and it hears the autopilot
        assert sitl.vehicle.armed
        assert sitl._conn.mav.signing.goodsig_count > 5
        assert fc._conn.mav.signing.goodsig_count > 5 and fc._conn.mav.signing.badsig_count == 0


def test_a_free_port_is_drawn_below_the_kernels_ephemeral_ports() -> None:
    """Issue 29 (the SITL load loop's run 15: "Address already in use" on the adapter's bind): a port the kernel
    hands out to any socket that sends unbound (a SITL's) could be taken between the draw and the bind."""
    ephemeral_from = EPHEMERAL_PORTS_DEFAULT[0]
    with suppress(OSError):
        ephemeral_from = int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    ports = [free_udp_port() for _ in range(20)]
    assert all(FREE_PORTS_FROM <= port < ephemeral_from for port in ports)
    assert len(set(ports)) > 1  # drawn at random, not the same each time


def sitl_port(sitl: MavlinkSitl) -> int:
    """The SITL's own (ephemeral) UDP port, which it receives on."""
    return int(sitl._conn.port.getsockname()[1])


def test_vision_positions_feed_the_estimate() -> None:
    @dataclass(frozen=True)
    class Pose:
        time_s: float
        position_m: tuple[float, float, float]
        attitude_rad: tuple[float, float, float]

    class Source:
        def __init__(self) -> None:
            self.pose: Pose | None = None

        def latest(self) -> Pose | None:
            return self.pose

    source = Source()
    with flight(SitlConfig(position_source="vision"), pose_source=source, estimate_timeout_s=0.5) as (
        sitl,
        fc,
    ):
        fc.connect()
        with pytest.raises(CommandRejected, match="position estimate"):
            fc.arm()  # no motion capture yet

        def fed_and_estimated() -> bool:
            source.pose = Pose(time.monotonic(), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # a new sample each poll
            return fc.telemetry().position_ok

        wait_until(fed_and_estimated, 5.0, "the estimate from the vision positions")
        assert sitl.vision_received > 0 and fc.vision_sent >= sitl.vision_received


def test_px4_offboard_rules() -> None:
    with flight(SitlConfig(autopilot="px4", offboard_loss_s=0.3)) as (sitl, fc):
        fc.connect()
        assert fc.autopilot == "px4" and fc.offboard_mode == "OFFBOARD"
        fc.wait_for_estimate(2.0)
        # as PX4 v1.16 (issue 29): disarmed, OFFBOARD is entered without setpoints, the arming in it is refused
        fc.set_mode("OFFBOARD")
        with pytest.raises(
            CommandRejected, match="arm rejected: temporarily rejected: Arming denied"
        ) as info:
            fc.command("arm", MAV_CMD_COMPONENT_ARM_DISARM, (1.0,))
        assert info.value.temporary and not sitl.vehicle.armed
        take_off(fc, 1.0)  # arm() streams a zero burst first; climbs by the setpoint stream inside OFFBOARD
        assert fc.telemetry().mode == "OFFBOARD"
        fc._stop.set()  # the onboard program hangs: the setpoint stream stops
        fc._threads[1].join(timeout=2.0)
        wait_until(lambda: sitl.mode == "AUTO.LOITER", 2.0, "PX4's offboard-loss failsafe")
        assert "Offboard setpoints lost: holding position" in sitl.status_log


def test_px4_arms_through_a_starved_zero_burst() -> None:
    """Issue 29: the client's zero burst went stale before PX4 looked (a thread starved under load, injected
    here): the arming in OFFBOARD is refused as temporary, the next asking streams the burst again and arms."""
    with flight(SitlConfig(autopilot="px4", starved_answers=2)) as (sitl, fc):
        fc.connect()
        fc.arm()
        assert sitl.vehicle.armed and sitl.mode == "OFFBOARD"
        assert sitl.status_log.count("Arming denied: Resolve system health failures first") == 2
        take_off(fc, 0.8)
        assert fc.telemetry().mode == "OFFBOARD"


def test_px4_refuses_an_armed_switch_to_offboard_without_setpoints_as_temporary() -> None:
    with flight(SitlConfig(autopilot="px4")) as (sitl, fc):
        fc.connect()
        take_off(fc, 0.8)
        fc.set_mode("POSCTL")
        sitl._setpoints.starved_left = 1  # the stream seen stale (as after offboard_loss_s without one)
        with pytest.raises(CommandRejected, match="Switching to Offboard is not possible") as info:
            fc.set_mode("OFFBOARD")
        assert info.value.temporary and sitl.mode == "POSCTL"


def test_a_failing_pose_source_does_not_stop_the_setpoint_stream() -> None:
    class Broken:
        def latest(self):
            raise RuntimeError("tracker SDK crashed")

    with flight(pose_source=Broken()) as (sitl, fc):
        fc.connect()
        take_off(fc, 0.8)
        fc.send_velocity((0.2, 0.0, 0.0), 0.0)
        before = sitl.setpoints_received
        wait_until(
            lambda: sitl.setpoints_received - before >= 4 and fc.pose_errors > 3,
            5.0,
            "setpoints and pose errors",
        )
        assert sitl.setpoints_received - before >= 4
        assert fc.pose_errors > 3 and fc.last_pose_error == "RuntimeError: tracker SDK crashed"


def test_closing_while_flying_lands() -> None:
    with flight() as (sitl, fc):
        fc.connect()
        take_off(fc, 0.8)
        fc.close()  # e.g. Ctrl-C in the middle of a task
        assert sitl.mode == "LAND"
        wait_until(lambda: not sitl.vehicle.armed, 3.0, "the landing")


def test_telemetry_without_heartbeats_is_a_lost_link() -> None:
    clock = HeldClock()
    with flight(monotonic=clock) as (sitl, fc):
        fc.connect()
        fc.wait_for_estimate(2.0)
        sitl.config = replace(sitl.config, heartbeat_hz=0.05)  # streams go on, heartbeats (almost) stop
        wait_until(lambda: not fc.telemetry().link_ok, 5.0, "link_ok to drop")
        # the next heartbeat is 20 s away: the window (HEARTBEAT_MISSING_S) from the last one, at its edges
        beat_s = fc._state.last_heartbeat_s
        with clock.held_at(beat_s + HEARTBEAT_MISSING_S - 0.01):
            assert fc.telemetry().link_ok  # the streams alone keep it up that long
        with clock.held_at(beat_s + HEARTBEAT_MISSING_S + 0.01):
            assert not fc.telemetry().link_ok
            with pytest.raises(LinkLost, match=r"no HEARTBEAT from the autopilot .* for 2\.5 s"):
                fc.send_velocity((0.0, 0.0, 0.0), 0.0)
