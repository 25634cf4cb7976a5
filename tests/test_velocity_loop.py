"""masonry.motion.velocity_loop: velocity setpoints -> acceleration setpoints on a position-derived velocity (issue 29)."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.errors import InputError
from masonry.motion.velocity_loop import VelocityLoop, VelocityLoopGains


def _fly(loop: VelocityLoop, setpoint: tuple[float, float, float], *, seconds: float, bias: float = 0.0,
         lag_s: float = 0.1, noise: tuple[float, ...] = ()) -> tuple[list[float], list[float]]:  # fmt: skip
    """A point mass that realises the commanded acceleration over ``lag_s`` (plus ``bias`` on every axis),
    observed at 30 Hz with ``noise`` added in turn to its reported position; returns its true position and
    velocity."""
    dt = 1.0 / 30.0
    p, v, a_real = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0]
    for k in range(int(seconds / dt)):
        n = noise[k % len(noise)] if noise else 0.0
        loop.observe(k * dt, (p[0] + n, p[1] - n, p[2]))
        a_cmd = loop.acceleration(setpoint)
        for i in range(3):
            a_real[i] += (a_cmd[i] + bias - a_real[i]) * dt / lag_s
            v[i] += a_real[i] * dt
            p[i] += v[i] * dt
    return p, v


def test_it_drives_the_velocity_to_the_setpoint_and_its_observer_follows() -> None:
    loop = VelocityLoop()
    _, v = _fly(loop, (0.5, -0.3, 0.2), seconds=10.0)
    assert v == pytest.approx([0.5, -0.3, 0.2], abs=0.01)
    assert loop.velocity_mps == pytest.approx(v, abs=0.02)


def test_its_integral_takes_out_what_the_autopilot_realises_differently() -> None:
    """PX4 maps a zero acceleration to its hover-thrust estimate, and tilts on its attitude estimate: a steady
    0.4 m/s^2 off the command. The hover stays still anyway."""
    loop = VelocityLoop()
    _, v = _fly(loop, (0.0, 0.0, 0.0), seconds=15.0, bias=0.4)
    assert max(abs(c) for c in v) < 0.01


def test_the_observer_ignores_repeated_and_non_finite_positions() -> None:
    loop = VelocityLoop()
    assert not loop.ready
    loop.observe(0.0, (0.0, 0.0, 0.0))
    loop.observe(0.1, (0.1, 0.0, 0.0))
    before = loop.velocity_mps
    loop.observe(0.1, (5.0, 5.0, 5.0))  # the same sample read twice
    loop.observe(0.05, (5.0, 5.0, 5.0))  # an older one
    loop.observe(0.2, (math.nan, 0.0, 0.0))
    assert loop.ready and loop.velocity_mps == before


def test_release_forgets_the_setpoint_and_the_integral() -> None:
    loop = VelocityLoop()
    _fly(loop, (0.0, 0.0, 0.0), seconds=5.0, bias=0.4)
    assert loop.acceleration((0.0, 0.0, 0.0))[0] < -0.2  # the integral holds the bias
    loop.release()
    assert loop.acceleration(loop.velocity_mps) == pytest.approx((0.0, 0.0, 0.0), abs=1e-9)


@settings(derandomize=True, max_examples=60, deadline=None)
@given(
    vx=st.floats(-20.0, 20.0), vy=st.floats(-20.0, 20.0), vz=st.floats(-20.0, 20.0),
    noise=st.lists(st.floats(-0.3, 0.3), min_size=1, max_size=8),
)  # fmt: skip
def test_the_acceleration_is_finite_and_within_its_limits(
    vx: float, vy: float, vz: float, noise: list[float]
) -> None:
    loop = VelocityLoop()
    g = loop.gains
    for k in range(40):
        loop.observe(k / 30.0, (noise[k % len(noise)], 0.0, -noise[k % len(noise)]))
        ax, ay, az = loop.acceleration((vx, vy, vz))
        assert all(math.isfinite(c) for c in (ax, ay, az)), (vx, vy, vz, noise)
        assert math.hypot(ax, ay) <= g.accel_limit_mps2 + 1e-9
        assert abs(az) <= g.accel_limit_z_mps2 + 1e-9


@pytest.mark.parametrize(
    "field", ["kv_per_s", "ki_z_per_s2", "accel_limit_mps2", "observer_position_rate_per_s"]
)
@pytest.mark.parametrize("value", [0.0, -1.0, math.inf, math.nan])
def test_bad_gains_are_refused_by_name(field: str, value: float) -> None:
    with pytest.raises(InputError, match=field):
        VelocityLoopGains(**{field: value})
