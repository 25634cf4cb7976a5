"""The site wind (masonry.sim.wind): mean, profile, Dryden statistics, determinism; and a UAV holding in it."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.cli.wind_options import parse_turbulence, parse_wind
from masonry.errors import InputError
from masonry.sim.vehicle import SimVehicle
from masonry.sim.wind import WindConfig, WindField, dryden_low_altitude

GRID_S = 0.05


def _series(config: WindConfig, seed: int, n: int, z_m: float = 2.0) -> np.ndarray:
    field = WindField(config, np.random.default_rng(seed))
    return np.array([field.at(k * GRID_S, z_m) for k in range(n)])


def _autocorr(x: np.ndarray, lag: int) -> float:
    x = x - x.mean()
    return float(np.dot(x[:-lag], x[lag:]) / np.dot(x, x))


def test_mean_wind_blows_from_its_direction_and_grows_with_height() -> None:
    cfg = WindConfig(speed_mps=4.0, direction_deg=270.0)  # from the west: the air goes east (+x)
    wx, wy = cfg.mean_mps(0.0, 10.0)
    assert wx == pytest.approx(4.0) and wy == pytest.approx(0.0, abs=1e-12)
    low, high = math.hypot(*cfg.mean_mps(0.0, 1.0)), math.hypot(*cfg.mean_mps(0.0, 3.0))
    assert low == pytest.approx(4.0 * 0.1 ** (1 / 7)) and low < high < 4.0
    north = WindConfig(speed_mps=3.0, direction_deg=0.0).mean_mps(0.0, 10.0)
    assert north == pytest.approx((0.0, -3.0), abs=1e-12)


def test_dryden_low_altitude_follows_mil_f_8785c() -> None:
    sigma_u, sigma_w, l_u, l_w, _ = dryden_low_altitude(WindConfig(turbulence="light"), 2.0)
    # at the standard's 10 ft floor: sigma_w = 0.1 W20 (15 kt), sigma_u = sigma_w / 0.1852 ** 0.4
    assert sigma_w == pytest.approx(0.1 * 15 * 0.514444)
    assert sigma_u == pytest.approx(sigma_w / (0.177 + 0.00823) ** 0.4)
    assert l_w == pytest.approx(3.048) and l_u == pytest.approx(3.048 / (0.177 + 0.00823) ** 1.2)
    moderate = dryden_low_altitude(WindConfig(turbulence="moderate"), 2.0)[0]
    assert moderate == pytest.approx(2.0 * sigma_u)


@settings(max_examples=6, deadline=None)
@given(
    seed=st.integers(0, 2**16),
    speed=st.sampled_from([0.0, 2.0, 4.0, 6.0]),
    level=st.sampled_from(["light", "moderate"]),
)
def test_turbulence_statistics(seed: int, speed: float, level: str) -> None:
    """Mean, variance and the u component's correlation time within sampling tolerance."""
    cfg = WindConfig(speed_mps=speed, direction_deg=90.0, turbulence=level)
    z = 2.0
    sigma_u, sigma_w, l_u, _, _ = dryden_low_altitude(cfg, z)
    convect = max(speed * cfg.profile(z), cfg.min_convection_mps)
    tau_u = l_u / convect
    n = int(400 * tau_u / GRID_S)  # 400 correlation times: ~10 % on the variance
    w = _series(cfg, seed, n, z)
    mean = np.array(cfg.mean_mps(0.0, z))
    u = -(w[:, 0] - mean[0])  # direction 90: from the east, the air goes -x; u along it
    v = w[:, 1] - mean[1]
    assert abs(u.mean()) < 0.25 * sigma_u and abs(v.mean()) < 0.25 * sigma_u
    assert u.std() == pytest.approx(sigma_u, rel=0.25)
    assert v.std() == pytest.approx(sigma_u, rel=0.25)
    assert w[:, 2].std() == pytest.approx(sigma_w, rel=0.25)
    lag = max(1, round(tau_u / GRID_S))
    assert _autocorr(u, lag) == pytest.approx(math.exp(-1.0), abs=0.12)


def test_the_wind_is_a_function_of_simulated_time_not_of_the_steps() -> None:
    cfg = WindConfig(speed_mps=3.0, turbulence="moderate")
    coarse = WindField(cfg, np.random.default_rng(7))
    fine = WindField(cfg, np.random.default_rng(7))
    seen = {}
    for k in range(1, 401):
        sample = fine.at(k * 0.01, 2.0)
        if k % 100 == 0:
            seen[k // 100] = sample
    for t in (1, 2, 3, 4):
        assert coarse.at(float(t), 2.0) == pytest.approx(seen[t], abs=1e-9)
    assert WindField(cfg, np.random.default_rng(8)).at(4.0, 2.0) != pytest.approx(coarse.at(4.0, 2.0))


def test_a_schedule_changes_the_mean_over_time() -> None:
    cfg = WindConfig(schedule=((0.0, 2.0), (100.0, 10.0), (200.0, 2.0)))
    assert [cfg.speed_at(t) for t in (0.0, 50.0, 100.0, 150.0, 300.0)] == pytest.approx([2, 6, 10, 6, 2])


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("x", "SPEED"),
        ("4@", "direction"),
        ("-1", "from 0 to 30"),
        ("4@400", "-360 to 360"),
        ("nan", "from 0"),
    ],
)
def test_bad_wind_option(text: str, message: str) -> None:
    with pytest.raises(InputError, match=message):
        parse_wind(text)


def test_turbulence_option() -> None:
    assert parse_turbulence("Light") == ("light", 0.0)
    assert parse_turbulence("1.5") == ("custom", 1.5)
    for bad in ("strong", "-1", "99"):
        with pytest.raises(InputError, match="--turbulence"):
            parse_turbulence(bad)


def _hover(speed_mps: float, kp: float = 1.0, seconds: float = 60.0) -> tuple[float, float]:
    """A P-only position hold at 2 m in steady wind: the mean horizontal error and tilt over the last 20 s."""
    field = WindField(WindConfig(speed_mps=speed_mps, direction_deg=270.0), np.random.default_rng(1))
    v = SimVehicle(rng=np.random.default_rng(0), wind=field)
    v.arm()
    v.takeoff(2.0)
    dt = 0.05
    for _ in range(int(15 / dt)):
        v.step(dt)
    errors, tilts = [], []
    for i in range(int(seconds / dt)):
        x, y, z = v.position_m
        v.command_velocity((-kp * x, -kp * y, kp * (2.0 - z)), 0.0, v.time_s)
        v.step(dt)
        if i * dt > seconds - 20.0:
            errors.append(math.hypot(x, y))
            tilts.append(math.hypot(*v.attitude_rad[:2]))
    return float(np.mean(errors)), math.degrees(float(np.mean(tilts)))


def test_the_autopilot_holds_a_point_in_steady_wind_until_its_tilt_runs_out() -> None:
    """Integral action: no steady error with a P-only outer loop; beyond the 30 deg tilt limit, blown away."""
    for speed in (2.0, 6.0, 10.0):
        error, tilt = _hover(speed)
        assert error < 0.005, f"{speed} m/s: {error:.3f} m off"
        assert 0.0 < tilt < 30.0
    error, tilt = _hover(13.0)
    assert error > 1.0 and tilt > 28.0


def test_still_air_is_the_old_loop() -> None:
    """No wind: the world builds no wind at all (the old loop, exactly); a calm field flies the same to rounding."""
    from pathlib import Path

    from masonry.blueprint import load_blueprint
    from masonry.sim import Faults, World

    bp = load_blueprint(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
    world = World(bp, seed=0, faults=Faults(wind=WindConfig(direction_deg=90.0)))
    assert all(u.vehicle.wind is None for u in world.add_fleet())
    calm = SimVehicle(rng=np.random.default_rng(3))
    windless = SimVehicle(
        rng=np.random.default_rng(3), wind=WindField(WindConfig(), np.random.default_rng(0))
    )
    for v in (calm, windless):
        v.arm()
        v.takeoff(1.5)
    for k in range(400):
        for v in (calm, windless):
            if k > 100:
                v.command_velocity((1.0, -0.5, 0.0), 0.1, v.time_s)
            v.step(0.05)
    assert calm.position_m == pytest.approx(windless.position_m, abs=1e-12)
    assert calm.attitude_rad == pytest.approx(windless.attitude_rad, abs=1e-12)


def test_a_uav_at_its_tilt_limit_does_not_run_away() -> None:
    """At the tilt limit the autopilot's wind estimate stops winding up but still unwinds. Left stale (a 10 m/s
    gust that turned), it kept the thrust saturated along the motion: in moderate turbulence at 2 m/s (the
    running bond, seed 15) the brick UAV flew off at 17 m/s, 200 m from its pickup (issue 18); now its fastest
    is 4.1 m/s (the gust blows it a few metres off, it flies back)."""
    from masonry.blueprint_gen import running_bond
    from masonry.mission.simulate import SimulatedMission
    from masonry.sim import Faults

    faults = Faults(wind=WindConfig(speed_mps=2.0, direction_deg=270.0, turbulence="moderate"))
    fastest = [0.0]
    with SimulatedMission.from_blueprint(
        running_bond(2, 5), seed=15, faults=faults, vehicle="arducopter", max_time_s=200.0
    ) as mission:
        vehicle = mission.world.uavs["brick-1"].vehicle

        def watch(now_s: float) -> None:
            fastest[0] = max(fastest[0], math.hypot(*vehicle.velocity_mps[:2]))

        mission.tick_hooks.append(watch)
        mission.run()
    assert 2.0 < fastest[0] < 6.0, fastest[0]
