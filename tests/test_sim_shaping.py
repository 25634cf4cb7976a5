"""The simulated ArduCopter (``--vehicle arducopter``, masonry.sim.shaping): ArduPilot's jerk- and
acceleration-limited setpoint shaping, a transport delay, GPS-like noise (issue 19)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.errors import InvalidArgument
from masonry.mission.simulate import simulate
from masonry.sim.shaping import ARDUCOPTER, Shaper, ShapingConfig
from masonry.sim.vehicle import SimVehicle
from masonry.sim.vehicle_config import VEHICLE_PRESETS, VehicleConfig, vehicle_preset

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def test_the_ideal_preset_is_the_plain_vehicle():
    assert vehicle_preset("ideal") == VehicleConfig() and VehicleConfig().shaping is None
    assert VEHICLE_PRESETS["arducopter"].shaping == ARDUCOPTER
    with pytest.raises(InvalidArgument, match="vehicle must be one of ideal, arducopter"):
        vehicle_preset("px5")
    with pytest.raises(InvalidArgument, match="jerk_xy_mps3 must be > 0"):
        ShapingConfig(jerk_xy_mps3=0.0)


def test_shaping_delays_then_follows_within_the_acceleration_and_jerk_limits():
    config = ShapingConfig(
        delay_s=0.15, jerk_xy_mps3=5.0, accel_xy_mps2=2.5, jerk_z_mps3=5.0, accel_z_mps2=2.5
    )
    shaper = Shaper(config)
    dt = 0.01
    vs = []
    for i in range(400):
        vs.append(shaper.shape(i * dt, 2.0, -0.5, 0.0, dt))
    vx = np.array([v[0] for v in vs])
    assert np.all(vx[:15] == 0.0)  # nothing before the delay
    assert vx[16] > 0.0
    ax = np.diff(vx) / dt
    jx = np.diff(ax) / dt
    assert ax.max() <= 2.5 + 1e-9 and np.abs(jx).max() <= 5.0 + 1e-6
    assert vx[-1] == pytest.approx(2.0, abs=0.01) and vs[-1][1] == pytest.approx(-0.5, abs=0.01)
    assert vx.max() <= 2.0 * 1.05  # arrives without a large overshoot


def test_the_gps_error_wanders_with_its_standard_deviation():
    shaper = Shaper(ShapingConfig(gps_noise_m=0.01, gps_noise_tau_s=1.0))
    rng = np.random.default_rng(1)
    xs = []
    for _ in range(40000):
        shaper.drift(0.01, rng.standard_normal)
        xs.append(shaper.gps_error_m[0])
    xs = np.array(xs)
    assert 0.007 < xs.std() < 0.013
    assert abs(np.corrcoef(xs[:-50], xs[50:])[0, 1] - math.exp(-0.5)) < 0.15  # correlated over tau


def test_the_arducopter_vehicle_takes_off_after_its_delay_and_hovers():
    v = SimVehicle(vehicle_preset("arducopter"))
    v.arm()
    v.takeoff(1.5)
    for _ in range(800):
        v.step(0.01)
    assert not v.on_ground and v.position_m[2] == pytest.approx(1.5, abs=0.05)


def test_identify_on_the_arducopter_preset_measures_the_sitls_lag():
    res = CliRunner().invoke(app, [
        "fly", "--identify", "--sim", "--vehicle", "arducopter", "--uav", "brick", "--blueprint",
        str(CASE_STUDY), "--format", "json",
    ])  # fmt: skip
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout)
    # ArduCopter 4.7 SITL (docs/performance/autopilots.md): 63 % after 0.71 s, 10 % after 0.31-0.34 s
    assert 0.71 * 0.85 <= out["lag_s"] <= 0.71 * 1.15
    assert 0.25 <= out["delay_s"] <= 0.45


def test_the_case_study_on_the_arducopter_preset_completes_in_order_with_bricks_within_2_cm():
    # the paper's rule, for Section VI's order
    report = simulate(load_blueprint(CASE_STUDY), vehicle="arducopter", reservation="task")
    assert report.completed and report.conflict_violations == 0 and report.dependency_violations == 0
    assert [a.task_id for a in report.attempts] == ["A0", "B0", "A1", "B1"]
    assert all(e < 0.02 for e in report.placement_error_m.values())


def test_fly_sim_takes_a_vehicle_and_its_tuning_and_names_a_wrong_one():
    ok = CliRunner().invoke(app, [
        "fly", "--sim", "--vehicle", "arducopter", "--uav", "adhesion", "--blueprint", str(CASE_STUDY),
        "--task", "A0", "--format", "json",
    ])  # fmt: skip
    assert ok.exit_code == 0, ok.output
    out = json.loads(ok.stdout)
    assert out["status"] == "done" and out["coverage"] >= 0.9
    bad = CliRunner().invoke(app, [
        "fly", "--sim", "--vehicle", "px5", "--uav", "brick", "--blueprint", str(CASE_STUDY), "--task", "B0",
    ])  # fmt: skip
    assert bad.exit_code == 2 and "--vehicle must be one of ideal, arducopter" in bad.stderr
