"""SimVehicle: velocity lag and limits, takeoff/land, ground contact, timeouts, failsafes, noise, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.errors import CommandRejected
from masonry.sim import SimClock, SimVehicle, VehicleConfig

DT = 0.05


def flying(config: VehicleConfig | None = None, **kwargs: object) -> SimVehicle:
    v = SimVehicle(config, rng=np.random.default_rng(1), **kwargs)  # type: ignore[arg-type]
    v.arm()
    v.takeoff(1.0)
    for _ in range(200):
        v.step(DT)
        if not v.taking_off:
            break
    assert not v.taking_off and not v.on_ground
    return v


def hold_velocity(
    v: SimVehicle, vel: tuple[float, float, float], duration_s: float, yaw_rate: float = 0.0
) -> None:
    for _ in range(round(duration_s / DT)):
        v.command_velocity(vel, yaw_rate, v.time_s)
        v.step(DT)


def test_clock_advances_only_when_told() -> None:
    c = SimClock(5.0)
    assert c.now_s() == 5.0
    c.sleep(1.5)
    c.advance(0.5)
    assert c.now_s() == pytest.approx(7.0)
    with pytest.raises(ValueError):
        c.advance(-1.0)


def test_velocity_follows_setpoint_with_first_order_lag() -> None:
    v = flying(VehicleConfig(max_accel_xy_mps2=100.0))
    hold_velocity(v, (0.5, 0.0, 0.0), 0.3)  # one time constant
    assert v.velocity_mps[0] == pytest.approx(0.5 * (1 - math.exp(-1)), abs=0.03)
    hold_velocity(v, (0.5, 0.0, 0.0), 2.0)
    assert v.velocity_mps[0] == pytest.approx(0.5, abs=0.005)


def test_speed_and_acceleration_limits() -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    prev = v.velocity_mps
    peak_acc = 0.0
    for _ in range(100):
        v.command_velocity((10.0, 10.0, 5.0), 0.0, v.time_s)
        v.step(DT)
        vel = v.velocity_mps
        peak_acc = max(peak_acc, math.hypot(vel[0] - prev[0], vel[1] - prev[1]) / DT)
        prev = vel
    assert math.hypot(*v.velocity_mps[:2]) == pytest.approx(cfg.max_speed_xy_mps, abs=1e-3)
    assert v.velocity_mps[2] == pytest.approx(cfg.max_climb_mps, abs=1e-3)
    assert peak_acc <= cfg.max_accel_xy_mps2 + 1e-9
    assert peak_acc == pytest.approx(cfg.max_accel_xy_mps2)


def test_yaw_rate_follows_with_limit() -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    hold_velocity(v, (0.0, 0.0, 0.0), 2.0, yaw_rate=5.0)
    assert v.yaw_rate_radps == pytest.approx(cfg.max_yaw_rate_radps, abs=1e-3)
    assert -math.pi <= v.yaw_rad < math.pi


def test_takeoff_climbs_to_altitude_and_land_disarms() -> None:
    v = SimVehicle(position_m=(1.0, 2.0, 0.0))
    assert v.on_ground and not v.armed
    with pytest.raises(CommandRejected):
        v.takeoff(1.0)  # not armed
    v.arm()
    v.takeoff(1.5)
    for _ in range(200):
        v.step(DT)
    assert v.position_m[2] == pytest.approx(1.5, abs=0.03)
    assert v.position_m[:2] == pytest.approx((1.0, 2.0), abs=1e-9)
    assert not v.on_ground and not v.taking_off
    with pytest.raises(CommandRejected, match="airborne"):
        v.disarm()
    v.land()
    assert v.mode == "LAND"
    for _ in range(200):
        v.step(DT)
    assert v.on_ground and not v.armed and v.position_m[2] == 0.0


def test_arming_and_a_pack_swap_keep_the_instants_telemetry_sample() -> None:
    # the take-off reads the ground once armed (issue 29): on the simulator the same instant's sample, with the new
    # flags (or the full pack), not a fresh noise draw that would shift every later one
    v = SimVehicle(rng=np.random.default_rng(3))
    v.battery_fraction = 0.4
    before = v.telemetry()
    v.swap_battery()
    swapped = v.telemetry()
    assert swapped.position_m == before.position_m and swapped.battery_fraction == 1.0
    v.arm()
    armed = v.telemetry()
    assert armed.position_m == before.position_m and armed.armed and armed.mode == "GUIDED"
    v.takeoff(1.0)  # a command that moves it: a fresh sample
    assert v.telemetry().position_m != before.position_m


def test_takeoff_refused_in_the_air_and_arming_refused_on_low_battery() -> None:
    v = flying()
    with pytest.raises(CommandRejected, match="already flying"):
        v.takeoff(2.0)
    w = SimVehicle()
    w.battery_fraction = 0.1
    with pytest.raises(CommandRejected, match="battery"):
        w.arm()


def test_setpoint_timeout_brakes_to_hover() -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    hold_velocity(v, (1.0, 0.0, 0.0), 2.0)
    x_at_last_setpoint = v.position_m[0]
    for _ in range(round(cfg.setpoint_timeout_s / DT) - 1):  # the last setpoint was sent one step ago
        v.step(DT)
    assert v.velocity_mps[0] == pytest.approx(1.0, abs=0.01)  # still valid for the timeout
    v.step(DT)
    v.step(DT)
    assert v.velocity_mps[0] < 0.9  # then it brakes
    for _ in range(100):
        v.step(DT)
    assert abs(v.velocity_mps[0]) < 0.02
    x_stop = v.position_m[0]
    for _ in range(100):
        v.step(DT)
    assert v.position_m[0] == pytest.approx(x_stop, abs=0.02)
    assert x_stop > x_at_last_setpoint + 0.5


def test_setpoint_during_takeoff_takes_over_and_ground_ignores_setpoints() -> None:
    v = SimVehicle()
    v.arm()
    v.command_velocity((1.0, 0.0, 0.0), 0.0, v.time_s)
    v.step(DT)
    assert v.position_m == (0.0, 0.0, 0.0)  # on the ground only takeoff moves it
    v.takeoff(2.0)
    for _ in range(20):
        v.step(DT)
    assert v.taking_off
    v.command_velocity((0.0, 0.0, 0.0), 0.0, v.time_s)
    assert not v.taking_off


def test_ground_contact_under_velocity_command() -> None:
    v = flying()
    hold_velocity(v, (0.0, 0.0, -1.0), 3.0)
    assert v.position_m[2] == 0.0 and v.on_ground and v.armed


def test_battery_drains_while_airborne_and_failsafe_lands() -> None:
    v = flying(battery_drain_per_s=0.01)
    start = v.battery_fraction
    hold_velocity(v, (0.0, 0.0, 0.0), 10.0)
    assert start - v.battery_fraction == pytest.approx(0.1, abs=1e-6)
    hold_velocity(v, (0.0, 0.0, 0.0), 85.0)
    assert v.mode == "LAND"
    ground = SimVehicle(battery_drain_per_s=0.01)
    ground.arm()
    for _ in range(100):
        ground.step(DT)
    assert ground.battery_fraction == 1.0


def test_link_loss_hovers_then_lands() -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    v.lose_link()
    hold_velocity(v, (1.0, 0.0, 0.0), cfg.link_failsafe_s - 0.5)
    assert v.position_m[0] == pytest.approx(0.0, abs=0.01)  # setpoints no longer count
    for _ in range(400):
        v.step(DT)
    assert v.on_ground and not v.armed
    assert not v.telemetry().link_ok


def test_failure_falls_and_forced_disarm_falls() -> None:
    v = flying()
    v.fail()
    for _ in range(10):
        v.step(DT)
    assert v.velocity_mps[2] < -2.0 or v.on_ground
    for _ in range(40):
        v.step(DT)
    assert v.on_ground and v.failed and not v.armed
    with pytest.raises(CommandRejected):
        v.arm()
    w = flying()
    w.disarm(force=True)
    for _ in range(40):
        w.step(DT)
    assert w.on_ground


def test_hold_above_stops_descent_and_land_detects_it() -> None:
    v = flying()
    v.land()
    for _ in range(200):
        v.step(DT)
        v.hold_above(0.6)
    assert v.position_m[2] == pytest.approx(0.6)
    assert not v.armed and v.on_ground


def test_telemetry_carries_millimetre_mocap_noise() -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    errors = []
    for _ in range(2000):
        tel = v.telemetry()
        assert v.telemetry() is tel  # one sample per instant
        errors.append(np.subtract(tel.position_m, v.position_m))
        v.step(DT)
    err = np.array(errors)
    assert np.all(np.abs(err.mean(axis=0)) < 2e-4)
    assert err.std(axis=0) == pytest.approx([cfg.mocap_noise_m] * 3, rel=0.1)


def test_gusts_push_a_hovering_vehicle() -> None:
    still = flying()
    windy = flying(gusts_mps=2.0)
    hold_velocity(still, (0.0, 0.0, 0.0), 30.0)
    drift = []
    for _ in range(600):
        windy.command_velocity((0.0, 0.0, 0.0), 0.0, windy.time_s)
        windy.step(DT)
        drift.append(math.hypot(*windy.velocity_mps[:2]))
    assert math.hypot(*still.velocity_mps[:2]) < 1e-9
    assert max(drift) > 0.05
    assert max(abs(a) for a in windy.attitude_rad[:2]) > 0.0


def test_same_seed_same_motion_and_noise() -> None:
    def run(seed: int) -> list[tuple[float, ...]]:
        v = SimVehicle(rng=np.random.default_rng(seed), gusts_mps=1.0)
        v.arm()
        v.takeoff(1.0)
        out = []
        for i in range(200):
            v.command_velocity((math.sin(i / 20), 0.2, 0.0), 0.1, v.time_s)
            v.step(DT)
            out.append(v.telemetry().position_m)
        return out

    assert run(3) == run(3)
    assert run(3) != run(4)


@settings(max_examples=40)
@given(
    st.lists(
        st.tuples(
            st.floats(-20, 20), st.floats(-20, 20), st.floats(-20, 20), st.floats(-5, 5), st.integers(1, 40)
        ),
        min_size=1,
        max_size=8,
    )
)
def test_any_setpoints_keep_limits_and_stay_above_ground(
    plan: list[tuple[float, float, float, float, int]],
) -> None:
    cfg = VehicleConfig()
    v = flying(cfg)
    for vx, vy, vz, r, steps in plan:
        for _ in range(steps):
            v.command_velocity((vx, vy, vz), r, v.time_s)
            v.step(DT)
            vel = v.velocity_mps
            assert all(math.isfinite(c) for c in (*v.position_m, *vel, v.yaw_rad))
            assert math.hypot(vel[0], vel[1]) <= cfg.max_speed_xy_mps + 1e-6
            assert -cfg.max_descent_mps - 1e-6 <= vel[2] <= cfg.max_climb_mps + 1e-6
            assert v.position_m[2] >= 0.0
            assert abs(v.yaw_rate_radps) <= cfg.max_yaw_rate_radps + 1e-9


def test_non_finite_setpoint_is_rejected() -> None:
    v = flying()
    with pytest.raises(CommandRejected):
        v.command_velocity((math.nan, 0.0, 0.0), 0.0, v.time_s)


def test_bad_values_raise_the_error_tree_and_stay_value_errors() -> None:
    from masonry.errors import InvalidArgument, MasonryError

    with pytest.raises(InvalidArgument, match="velocity_tau_s") as info:
        VehicleConfig(velocity_tau_s=0.0)
    assert isinstance(info.value, MasonryError) and isinstance(info.value, ValueError)
    with pytest.raises(InvalidArgument, match="finite"):
        SimVehicle().follow(
            (math.inf, 0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0), on_ground=True, armed=False
        )
