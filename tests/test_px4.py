"""Issue 20, what PX4 v1.16 does to ``masonry fly``: estimator flags, the take-off, the ground offset, GNSS noise.

Each behaviour is replayed on loopback: the exact flag sequences through a scripted MAVLink peer, the rest
through the project's SITL with ``--vehicle px4`` (EKF2's at-rest flags, the ground 0.5 m up in its frame, the
thrust ramp on take-off, GNSS-grade wander), and a brick task flown against it.
"""

from __future__ import annotations

import json
import math
import random
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from masonry.adapters.estimator_status import ARDUPILOT_EKF, PX4_EKF2, describe_flags, flags_usable
from masonry.adapters.mavlink import FrameTransform, MavlinkFlightController, mavutil_module
from masonry.adapters.sitl import SITL_PRESETS, MavlinkSitl, SitlConfig, free_udp_port
from masonry.adapters.takeoff import ClimbConfig, ClimbMonitor
from masonry.cli import app
from masonry.cli.hardware import build_sitl
from masonry.errors import CommandRejected
from masonry.fsm.camera_align import CameraAlign
from masonry.fsm.noise_gate import HoverNoise, noise_aligned
from masonry.fsm.tuning import uav_settings
from masonry.sim import SimVehicle
from masonry.sim.vehicle_config import vehicle_preset
from own_sitl_flight import lockstep_brick_flight
from waiting import wait_until

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()

PX4_GROUND, PX4_FLYING = 0x3FF, (895, 831)  # PX4 v1.16 SITL (SIH, GNSS): disarmed on the ground; in flight
ARDUPILOT_CONVERGING, ARDUPILOT_READY = 0xA7, 0x33F


# -- the flags, per autopilot ---------------------------------------------------------------------------------


def test_px4_constant_position_mode_at_rest_is_not_a_bad_estimate() -> None:
    assert PX4_GROUND & 128  # EKF2 sets CONST_POS_MODE whenever the vehicle is at rest
    assert flags_usable(PX4_GROUND, "px4", on_ground=True)
    assert describe_flags(PX4_GROUND, "px4") == "EKF flags 0x03ff: usable"
    for flags in PX4_FLYING:
        assert not flags & 128 and flags_usable(flags, "px4", on_ground=False)
    # in flight the same bit means EKF2 flies on a fake position: not usable, and said so
    assert not flags_usable(PX4_GROUND, "px4", on_ground=False)
    assert "constant-position mode in flight" in describe_flags(PX4_GROUND, "px4", on_ground=False)
    assert not flags_usable(PX4_FLYING[0] | 2048, "px4", on_ground=False)  # accelerometer error


def test_ardupilot_constant_position_mode_is_a_bad_estimate_even_at_rest() -> None:
    assert not flags_usable(ARDUPILOT_CONVERGING, "ardupilot", on_ground=True)
    assert describe_flags(ARDUPILOT_CONVERGING, "ardupilot") == (
        "EKF flags 0x00a7: missing relative horizontal position; constant-position mode"
    )
    assert flags_usable(ARDUPILOT_READY, "ardupilot", on_ground=True)
    assert flags_usable(ARDUPILOT_READY, "ardupilot", on_ground=False)
    assert not flags_usable(ARDUPILOT_READY | 1024, "ardupilot")  # EKF_UNINITIALIZED
    # the same 0x3FF from ArduPilot would be an EKF in constant-position mode
    assert not flags_usable(PX4_GROUND, "ardupilot")


def test_the_flag_tables_match_the_mavlink_definitions() -> None:
    m = mavutil_module().mavlink
    assert PX4_EKF2.bad == m.ESTIMATOR_GPS_GLITCH | m.ESTIMATOR_ACCEL_ERROR
    assert PX4_EKF2.bad_in_flight == m.ESTIMATOR_CONST_POS_MODE
    assert ARDUPILOT_EKF.bad == m.EKF_CONST_POS_MODE | m.EKF_UNINITIALIZED | m.EKF_GPS_GLITCHING
    required = m.EKF_ATTITUDE | m.EKF_VELOCITY_HORIZ | m.EKF_VELOCITY_VERT | m.EKF_POS_HORIZ_REL
    assert ARDUPILOT_EKF.required == PX4_EKF2.required == required | m.EKF_POS_VERT_ABS


@dataclass
class _Peer:
    """A scripted autopilot on loopback: heartbeats, a position at rest, and the estimator flags set in ``flags``."""

    port: int
    autopilot: int  # MAV_AUTOPILOT_PX4 (12) or MAV_AUTOPILOT_ARDUPILOTMEGA (3)
    flags: int
    armed: bool = False
    landed_state: int = 1  # MAV_LANDED_STATE_ON_GROUND
    stop: threading.Event = field(default_factory=threading.Event)

    def run(self) -> None:
        mav = mavutil_module().mavlink_connection(
            f"udpout:127.0.0.1:{self.port}", source_system=1, source_component=1
        )
        t0, next_beat = time.monotonic(), 0.0
        try:
            while not self.stop.is_set():
                now = time.monotonic()
                boot_ms = int((now - t0) * 1000)
                if now >= next_beat:
                    next_beat = now + 0.2
                    mav.mav.heartbeat_send(2, self.autopilot, 1 | (128 if self.armed else 0), 0, 4)
                mav.mav.local_position_ned_send(boot_ms, 0.0, 0.0, -0.5, 0.0, 0.0, 0.0)
                if self.autopilot == 12:
                    mav.mav.estimator_status_send(boot_ms * 1000, self.flags, 0, 0, 0, 0, 0, 0, 0, 0)
                else:
                    mav.mav.ekf_status_report_send(self.flags, 0.1, 0.1, 0.1, 0.1, 0.0)
                mav.mav.extended_sys_state_send(0, self.landed_state)
                while (msg := mav.recv_msg()) is not None:
                    if msg.get_type() == "COMMAND_LONG":
                        mav.mav.command_ack_send(msg.command, 0)
                self.stop.wait(0.02)
        finally:
            mav.close()


@contextmanager
def scripted(autopilot: int, flags: int) -> Iterator[tuple[_Peer, MavlinkFlightController]]:
    peer = _Peer(free_udp_port(), autopilot, flags)
    thread = threading.Thread(target=peer.run, daemon=True)
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{peer.port}", connect_timeout_s=5.0)
    thread.start()
    try:
        fc.connect()
        yield peer, fc
    finally:
        fc.close()
        peer.stop.set()
        thread.join(timeout=5.0)


def test_px4_flag_sequence_through_a_scripted_peer() -> None:
    with scripted(12, PX4_GROUND) as (peer, fc):
        assert fc.autopilot == "px4"
        fc.wait_for_estimate(3.0)  # 0x3FF on the ground: usable (it was "no usable estimate after 150 s")
        assert fc.estimate_status() == "EKF flags 0x03ff: usable"
        peer.armed, peer.landed_state = True, 2  # airborne (IN_AIR), EKF2 no longer at rest
        for flags in PX4_FLYING:
            peer.flags = flags
            wait_until(
                lambda f=flags: fc._state.estimate_flags == f and fc._state.armed, 3.0, f"flags {flags}"
            )
            assert fc.telemetry().position_ok
        peer.flags = PX4_GROUND  # constant-position mode in flight: a fake position
        wait_until(lambda: not fc.telemetry().position_ok, 3.0, "the estimate refused in flight")
        assert "constant-position mode in flight" in fc.estimate_status()


def test_ardupilot_flag_sequence_through_a_scripted_peer() -> None:
    with scripted(3, ARDUPILOT_CONVERGING) as (peer, fc):
        assert fc.autopilot == "ardupilot"
        with pytest.raises(
            CommandRejected, match=r"0x00a7: missing relative horizontal position; constant-pos"
        ):
            fc.wait_for_estimate(0.5)
        peer.flags = ARDUPILOT_READY
        fc.wait_for_estimate(3.0)
        assert fc.estimate_status() == "EKF flags 0x033f: usable"


# -- the take-off climb ---------------------------------------------------------------------------------------


def _climb(monitor: ClimbMonitor, ramp_s: float, lift: float = 1.0, dt: float = 0.05) -> list[float]:
    """Fly ``monitor`` on a vehicle whose climb follows the command with a 0.3 s lag, within a climb speed that
    a thrust ramp of ``ramp_s`` lets grow from a tenth of 0.5 m/s x ``lift`` (0: it cannot leave the ground)."""
    z = vz = 0.0
    t = monitor.start_s
    heights = []
    while not monitor.done and t < monitor.start_s + 60.0:
        cmd = monitor.step(t, z, vz)
        cap = 0.5 * lift * (0.1 + 0.9 * min(1.0, (t - monitor.start_s) / ramp_s))
        vz += ((min(cmd, cap) if cmd > 0.0 else cmd) - vz) * dt / 0.3
        z = max(0.0, z + vz * dt)
        t += dt
        heights.append(z)
    return heights


def test_the_climb_ends_reached_and_steady_behind_a_slow_thrust_ramp() -> None:
    monitor = ClimbMonitor(10.0, 1.54)
    heights = _climb(monitor, ramp_s=6.0)
    assert monitor.state == "reached" and monitor.reason is None
    assert abs(heights[-1] - 1.54) <= monitor.config.tolerance_m
    assert max(heights) < 1.54 + 0.15  # no big overshoot
    # never less than min_speed_mps while short of the target: the last 20 cm are climbed at 0.12 m/s or more
    near = [h for h in heights if 1.54 - 0.2 < h < 1.54 - 0.06]
    assert len(near) * 0.05 < 0.14 / 0.12 + 0.5


def test_a_stalled_climb_and_a_slow_one_say_why() -> None:
    stalled = ClimbMonitor(0.0, 1.2)
    _climb(stalled, ramp_s=3.0, lift=0.0)  # it cannot leave the ground
    assert stalled.state == "stalled"
    assert stalled.reason is not None and stalled.reason.startswith("take-off stalled at 0.00 m of 1.20 m")
    slow = ClimbMonitor(0.0, 1.2, ClimbConfig(timeout_s=3.0))
    _climb(slow, ramp_s=3.0)
    assert slow.state == "timeout"
    assert slow.reason is not None and slow.reason.startswith("take-off not steady at 1.20 m within 3 s")
    assert slow.step(99.0, 0.0, 0.0) == 0.0  # over: nothing more is commanded


def _climb_on_a_biased_velocity(monitor: ClimbMonitor, bias_mps: float, dt: float = 0.05) -> list[float]:
    """Fly ``monitor`` on PX4's velocity loop closing on an EKF2 vertical velocity ``bias_mps`` above the truth (it
    realises the command less the bias) until the monitor hands the climb to masonry's own loop (which closes on the
    position: the command realised); a 0.3 s lag either way, a 3 s thrust ramp."""
    z = vz = 0.0
    t = monitor.start_s
    heights = []
    while not monitor.done and t < monitor.start_s + 60.0:
        cmd = monitor.step(t, z, vz)
        realised = cmd if monitor.own_loop else cmd - bias_mps
        cap = 0.5 * (0.1 + 0.9 * min(1.0, (t - monitor.start_s) / 3.0))
        vz += (min(realised, cap) - vz) * dt / 0.3
        z = max(0.0, z + vz * dt)
        t += dt
        heights.append(z)
    return heights


def test_a_stall_once_airborne_hands_the_climb_to_the_own_velocity_loop() -> None:
    """Issue 29 on the real PX4 under load: "take-off stalled at 0.99 m of 1.09 m" (+0.05 m in 4 s at 0.12 m/s
    asked). Where the adapter flies its own velocity loop the stall hands the rest of the climb to it, with a fresh
    progress window, and the climb ends reached; without one, or stalled again, it fails as before."""
    heights = _climb_on_a_biased_velocity(without := ClimbMonitor(0.0, 1.09), bias_mps=0.125)
    assert without.state == "stalled" and not without.own_loop
    assert 0.9 < heights[-1] < 1.09 - 2 * without.config.tolerance_m + 0.01  # stuck short of the target
    with_loop = ClimbMonitor(0.0, 1.09, ClimbConfig(own_loop=True))
    heights = _climb_on_a_biased_velocity(with_loop, bias_mps=0.125)
    assert with_loop.own_loop and with_loop.state == "reached" and with_loop.reason is None
    assert abs(heights[-1] - 1.09) <= with_loop.config.tolerance_m
    # on the ground it is no stall of a climb in the air: a vehicle that cannot lift still fails, loop or not
    grounded = ClimbMonitor(0.0, 1.2, ClimbConfig(own_loop=True))
    _climb(grounded, ramp_s=3.0, lift=0.0)
    assert grounded.state == "stalled" and not grounded.lifted and not grounded.own_loop
    # a second stall, on the loop, fails it
    stuck = ClimbMonitor(0.0, 1.09, ClimbConfig(own_loop=True))
    t, z = 0.0, 0.0
    while not stuck.done and t < 60.0:  # climbs to 0.95 m and stays there whatever is asked
        stuck.step(t, z, 0.0)
        z = min(0.95, z + 0.5 * 0.05)
        t += 0.05
    assert stuck.own_loop and stuck.state == "stalled"
    assert stuck.reason is not None and stuck.reason.startswith("take-off stalled at 0.95 m of 1.09 m")


def test_a_velocity_setpoint_takes_over_only_near_the_altitude() -> None:
    monitor = ClimbMonitor(0.0, 1.2)
    assert not monitor.hand_over(0.9, 0.3) and monitor.state == "climbing"  # still climbing: keep on
    assert not monitor.hand_over(1.15, 0.3)  # near, but not slow yet
    assert monitor.hand_over(1.15, 0.05) and monitor.state == "reached" and monitor.reason is None


# -- the gates that follow the measured noise, the camera's relative estimate --------------------------------


def test_the_windowed_gate_passes_noisy_hover_around_the_target_and_not_beside_it() -> None:
    rng = random.Random(3)
    for offset_m, expect in ((0.0, True), (0.03, False)):
        noise = HoverNoise(1.5)
        passes = []
        for i in range(60):  # 6 s at 10 Hz: 2 mm position noise, 0.1 m/s velocity noise (single ticks > 0.08)
            noise.add(i * 0.1, (offset_m + rng.gauss(0, 0.002), rng.gauss(0, 0.002)),
                      (rng.gauss(0, 0.1), rng.gauss(0, 0.1)))  # fmt: skip
            passes.append(noise_aligned(noise, 0.015, 0.08))
        assert not any(passes[:14])  # a window first
        assert all(passes[20:]) is expect and any(passes) is expect
    noise = HoverNoise(1.5)
    for i in range(30):  # +-5 cm white noise: the mean's own uncertainty keeps it from passing at 1.5 cm
        noise.add(i * 0.1, (rng.gauss(0, 0.05), rng.gauss(0, 0.05)), (0.0, 0.0))
    assert noise.spread_m > 0.04 and not noise_aligned(noise, 0.015, 0.08)


def test_the_camera_tracker_follows_the_brick_past_its_deadband() -> None:
    tracker = CameraAlign(size=5, min_estimates=3, shift_m=0.002)
    tracker.reset(np.array([1.0, 0.0, 0.1]))
    assert tracker.add(np.array([1.001, 0.0, 0.1])) is None  # too few
    assert tracker.add(np.array([1.0, 0.001, 0.1])) is None
    assert tracker.add(np.array([0.999, 0.0, 0.1])) is None  # within the deadband
    moves = [tracker.add(np.array([1.03, 0.0, 0.1])) for _ in range(5)]  # the GNSS error moved by 3 cm
    total = sum((m for m in moves if m is not None), np.zeros(3))
    assert total == pytest.approx([0.03, 0.0, 0.0], abs=2e-3)
    assert tracker.center_m == pytest.approx([1.03, 0.0, 0.1], abs=1e-9)


def test_the_px4_tuning_preset() -> None:
    settings = uav_settings("px4")
    # issue 29: 3 s, longer than the real PX4's ~2 s hover oscillation (the gates' mean no longer follows it)
    assert settings["align_on_camera"] is True and settings["gate_window_s"] == 3.0
    assert (
        settings["velocity_from_position_s"] == 2.0
    )  # issue 29: the gates read a velocity the position follows
    from masonry.errors import InputError

    with pytest.raises(InputError, match="align_on_camera must be true or false"):
        uav_settings("ideal", {"align_on_camera": 1})


# -- the px4 vehicle and SITL presets -------------------------------------------------------------------------


def test_the_px4_vehicle_ramps_its_thrust_on_take_off() -> None:
    climbed = {}
    for name in ("ideal", "px4"):
        v = SimVehicle(vehicle_preset(name), rng=np.random.default_rng(0))
        v.arm()
        v.takeoff(1.0)
        for _ in range(100):  # 1 s
            v.step(0.01)
        climbed[name] = v.position_m[2]
    assert climbed["px4"] < 0.5 * climbed["ideal"]


@contextmanager
def px4_sitl(
    home_m=(1.0, 2.0, 0.0), time_scale: float = 5.0
) -> Iterator[tuple[MavlinkSitl, MavlinkFlightController]]:
    port = free_udp_port()
    sitl = MavlinkSitl(port, time_scale=time_scale, home_m=home_m,
                       config=SitlConfig(**SITL_PRESETS["px4"], heartbeat_hz=4.0), seed=1)  # fmt: skip
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=3.0, frame=FrameTransform(home_m),
                                 ground_m=home_m)  # fmt: skip
    sitl.start()
    try:
        fc.connect()
        yield sitl, fc
    finally:
        fc.close()
        sitl.stop()


def test_px4_sitl_ground_offset_take_off_and_gnss_noise() -> None:
    with px4_sitl() as (sitl, fc):
        assert fc.autopilot == "px4"
        fc.wait_for_estimate(3.0)
        # (a streaming position is enough for the pre-flight; the estimator's report may come a moment after it)
        wait_until(lambda: fc._state.estimate_flags is not None, 5.0, "the estimator's status report")
        assert fc._state.estimate_flags == PX4_GROUND  # EKF2 at rest: usable all the same
        assert fc._state.position_ned[2] == pytest.approx(-0.5, abs=0.02)  # the ground 0.5 m up in its frame
        assert fc.telemetry().position_m[2] == pytest.approx(0.5, abs=0.02)  # before the measurement
        fc.arm()  # measures the ground: it now reads as the home's z
        assert fc.ground_offset_m == pytest.approx(0.5, abs=0.02)
        assert fc.telemetry().position_m[2] == pytest.approx(0.0, abs=0.02)
        fc.takeoff(1.2)
        wait_until(lambda: fc._takeoff_target_m is None, 15.0, "the end of the take-off climb")
        assert fc.takeoff_problem is None  # reached and steady
        tel = fc.telemetry()
        assert tel.position_m[2] == pytest.approx(1.2, abs=0.08) and not tel.on_ground and tel.position_ok
        assert sitl.vehicle.position_m[2] == pytest.approx(1.2, abs=0.3)  # the true height, within GNSS error
        wait_until(lambda: fc._state.estimate_flags in PX4_FLYING, 3.0, "EKF2's in-flight flags")
        # GNSS-grade noise: the reported position wanders off the true one by centimetres
        offsets = []
        for _ in range(40):
            fc.send_velocity((0.0, 0.0, 0.0), 0.0)
            offsets.append(math.dist(fc.telemetry().position_m[:2], sitl.vehicle.position_m[:2]))
            fc.clock.sleep(0.25)
        assert max(offsets) > 0.01
        fc.land()
        wait_until(lambda: not sitl.vehicle.armed, 15.0, "the landing")


def test_sitl_vehicle_option_is_checked() -> None:
    sitl, description = build_sitl(port=free_udp_port(), vehicle="px4")
    assert sitl.px4 and sitl.config.ekf2_flags and description.endswith("vehicle px4")
    res = runner.invoke(app, ["sitl", "--vehicle", "betaflight"])
    assert res.exit_code == 2 and "--vehicle must be one of ideal, arducopter, px4" in res.stderr


@pytest.mark.slow
def test_a_brick_task_against_the_px4_sitl_places_within_2_cm() -> None:
    res, sitl = lockstep_brick_flight(seed=1)
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    assert out["status"] == "done", (out["reason"], [(round(e["t_s"], 1), e["state"]) for e in out["trace"]])
    assert out["placement_error_m"] is not None and out["placement_error_m"] < 0.02
    assert "[ok  ] ground: the EKF reads the ground +0.50 m up" in res.stderr
    # the fly loop paced the SITL (masonry.adapters.sitl_lockstep): its 4x is what the machine gives it
    assert sitl.lockstep.grants > 100, sitl.lockstep.grants


def test_the_frame_model_is_the_same_for_every_mode(tmp_path) -> None:
    from masonry.adapters.wiring import HardwareConfig, hardware_config, load_uav_config
    from masonry.errors import InputError

    home = (2.0, -2.5, 0.0)
    assert HardwareConfig().ground_for(home) == home  # the autopilot positions itself: measure at arming
    assert HardwareConfig(origin_m=(0.0, 0.0, 0.0)).ground_for(home) is None  # the origin is given
    assert HardwareConfig(mocap_port=5005).ground_for(home) is None  # fed world-frame poses
    assert HardwareConfig(mocap_port=5005, measure_ground=True).ground_for(home) == home
    assert HardwareConfig(measure_ground=False).ground_for(home) is None
    config = tmp_path / "uav.yaml"
    config.write_text("measure_ground: false\n")
    assert hardware_config({}, load_uav_config(config)).ground_for(home) is None
    config.write_text("measure_ground: sometimes\n")
    with pytest.raises(InputError, match="measure_ground must be true or false"):
        load_uav_config(config)
