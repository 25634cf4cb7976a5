"""PID: proportional/feed-forward, clamping, anti-windup, derivative on measurement, yaw wrapping."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.errors import InputError
from masonry.motion import PID, AxisGains, PIDGains

P_ONLY = PIDGains.uniform(AxisGains(kp=2.0))


def test_proportional_plus_feed_forward() -> None:
    pid = PID(P_ONLY)
    v, w = pid.step(0.0, [0, 0, 1], [0.1, -0.2, 1.3], velocity_ff_mps=(0.05, 0.0, -0.1))
    np.testing.assert_allclose(v, [0.25, -0.4, 0.5])
    assert w == 0.0


def test_output_is_clamped_per_axis() -> None:
    gains = PIDGains(
        x=AxisGains(kp=1.0, output_limit=0.5),
        y=AxisGains(kp=1.0, output_limit=1.0),
        z=AxisGains(kp=1.0, output_limit=0.2),
        yaw=AxisGains(kp=1.0, output_limit=0.3),
    )
    v, w = PID(gains).step(0.0, [0, 0, 0], [10, -10, -10], yaw_rad=0.0, target_yaw_rad=2.0)
    np.testing.assert_allclose(v, [0.5, -1.0, -0.2])
    assert w == pytest.approx(0.3)


def test_first_call_and_target_jumps_have_no_derivative_kick() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=1.0, kd=5.0)))
    v0, _ = pid.step(0.0, [0, 0, 0], [1, 0, 0])
    np.testing.assert_allclose(v0, [1, 0, 0])
    # The vehicle has not moved; the target jumps: only the proportional part changes.
    v1, _ = pid.step(0.1, [0, 0, 0], [3, 0, 0])
    np.testing.assert_allclose(v1, [3, 0, 0])


def test_derivative_acts_on_the_measured_rate() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=0.0, kd=0.5)))
    pid.step(0.0, [0, 0, 0], [0, 0, 0])
    v, _ = pid.step(0.1, [0.02, 0.0, -0.01], [0, 0, 0])
    np.testing.assert_allclose(v, [-0.5 * 0.2, 0.0, 0.5 * 0.1])


def test_derivative_low_pass_filter() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=0.0, kd=1.0), derivative_tau_s=0.1))
    pid.step(0.0, [0, 0, 0], [0, 0, 0])
    v, _ = pid.step(0.1, [0.1, 0, 0], [0, 0, 0])  # raw rate 1 m/s, alpha = 0.1 / 0.2
    assert v[0] == pytest.approx(-0.5)


def test_integral_removes_a_steady_offset() -> None:
    """A velocity-tracking vehicle pushed by a constant wind: P alone leaves an offset, PI removes it."""

    def settle(gains: AxisGains) -> float:
        pid = PID(PIDGains.uniform(gains))
        pos, vel, dt = np.zeros(3), np.zeros(3), 0.02
        for i in range(3000):
            cmd, _ = pid.step(i * dt, pos, [1.0, 0.0, 0.0])
            vel += (cmd - vel) * dt / 0.3  # first-order velocity loop
            pos = pos + (vel + np.array([0.2, 0.0, 0.0])) * dt  # wind drift 0.2 m/s
        return float(pos[0] - 1.0)

    assert abs(settle(AxisGains(kp=1.0))) > 0.1
    assert abs(settle(AxisGains(kp=1.0, ki=0.5, output_limit=2.0))) < 1e-3


def test_anti_windup_lets_the_output_leave_saturation_at_once() -> None:
    gains = PIDGains.uniform(AxisGains(kp=1.0, ki=2.0, output_limit=0.5))
    pid = PID(gains)
    for i in range(500):  # 10 s stuck far from the target (e.g. held on the ground)
        v, _ = pid.step(i * 0.02, [0, 0, 0], [5, 0, 0])
        assert v[0] == pytest.approx(0.5)
    assert abs(pid.integral[0]) <= 0.5 + 1e-12
    # The error changes sign: an unprotected integrator (~+100 m/s worth) would keep pushing forward for seconds.
    v, _ = pid.step(10.0, [5.2, 0, 0], [5, 0, 0])
    assert v[0] < 0.4


@given(
    st.lists(st.tuples(st.floats(-5, 5), st.floats(0.001, 0.2)), min_size=1, max_size=60),
    st.floats(0.1, 3.0),
    st.floats(0.05, 1.0),
)
def test_integral_and_output_stay_bounded(errors_and_dts, limit, i_limit) -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=0.7, ki=3.0, output_limit=limit, integral_limit=i_limit)))
    t = 0.0
    for err, dt in errors_and_dts:
        before = pid.integral[0]
        v, _ = pid.step(t, [0, 0, 0], [err, 0, 0])
        t += dt
        assert abs(v[0]) <= limit + 1e-12
        after = pid.integral[0]
        assert abs(after) <= i_limit + 1e-12
        # Already saturated in the direction the error pushes: the integral is frozen.
        pushed = 0.7 * err + before
        if abs(pushed) > limit and np.sign(pushed) == np.sign(err):
            assert after == before


def test_yaw_takes_the_short_way_round() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=1.0)))
    _, w = pid.step(0.0, [0, 0, 0], [0, 0, 0], yaw_rad=math.pi - 0.1, target_yaw_rad=-math.pi + 0.1)
    assert w == pytest.approx(0.2)
    _, w = pid.step(0.1, [0, 0, 0], [0, 0, 0], yaw_rad=-math.pi + 0.1, target_yaw_rad=math.pi - 0.1)
    assert w == pytest.approx(-0.2)


@given(st.floats(-10, 10), st.floats(-10, 10), st.integers(-3, 3))
def test_yaw_command_depends_only_on_the_wrapped_error(yaw, target, turns) -> None:
    a = PID(PIDGains.uniform(AxisGains(kp=1.3)))
    b = PID(PIDGains.uniform(AxisGains(kp=1.3)))
    _, wa = a.step(0.0, [0, 0, 0], [0, 0, 0], yaw_rad=yaw, target_yaw_rad=target)
    _, wb = b.step(0.0, [0, 0, 0], [0, 0, 0], yaw_rad=yaw + 2 * math.pi * turns, target_yaw_rad=target)
    assert wa == pytest.approx(wb, abs=1e-9)
    assert abs(wa) <= 1.3 * math.pi + 1e-9


def test_yaw_derivative_across_the_wrap_is_small() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=0.0, kd=1.0)))
    pid.step(0.0, [0, 0, 0], [0, 0, 0], yaw_rad=math.pi - 0.01, target_yaw_rad=0.0)
    _, w = pid.step(0.1, [0, 0, 0], [0, 0, 0], yaw_rad=-math.pi + 0.01, target_yaw_rad=0.0)
    assert w == pytest.approx(-0.2)  # rate +0.2 rad/s, not -62 rad/s


def test_no_yaw_target_means_no_yaw_rate_and_no_yaw_integral() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=1.0, ki=1.0)))
    for i in range(10):
        _, w = pid.step(i * 0.1, [0, 0, 0], [0, 0, 0], yaw_rad=1.0)
        assert w == 0.0
    assert pid.integral[3] == 0.0


def test_repeated_timestamp_does_not_integrate_and_reset_forgets() -> None:
    pid = PID(PIDGains.uniform(AxisGains(kp=1.0, ki=1.0)))
    pid.step(0.0, [0, 0, 0], [1, 0, 0])
    a, _ = pid.step(0.5, [0, 0, 0], [1, 0, 0])
    b, _ = pid.step(0.5, [0, 0, 0], [1, 0, 0])
    np.testing.assert_allclose(a, b)
    assert pid.integral[0] == pytest.approx(0.5)
    pid.reset()
    assert not np.any(pid.integral)
    c, _ = pid.step(7.0, [0, 0, 0], [1, 0, 0])
    np.testing.assert_allclose(c, [1, 0, 0])


@pytest.mark.parametrize(
    "kwargs",
    [
        {"kp": -1.0},
        {"kp": float("nan")},
        {"kp": 1.0, "output_limit": 0.0},
        {"kp": 1.0, "integral_limit": -2.0},
    ],
)
def test_bad_gains_raise_input_error(kwargs) -> None:
    with pytest.raises(InputError):
        AxisGains(**kwargs)


def test_bad_measurement_raises_input_error() -> None:
    with pytest.raises(InputError, match="position_m"):
        PID().step(0.0, [0, 0], [0, 0, 0])
