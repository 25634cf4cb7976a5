"""The simulated ``px4`` vehicle refitted to the real PX4 v1.16 SITL as masonry flies it (issue 29): its dead time,
lag, droop and velocity wander, and the position gains it is flown with (docs/performance/autopilots.md, "The px4
model refitted")."""

from __future__ import annotations

import math

import numpy as np
import pytest

from masonry.adapters.wiring import HardwareConfig
from masonry.blueprint import load_blueprint
from masonry.cli.fly import select_adapters
from masonry.cli.fly_tuning import fly_settings
from masonry.errors import InvalidArgument
from masonry.fsm.tuning import OWN_VELOCITY_LOOP_PID, uav_settings
from masonry.sim import Faults
from masonry.sim.shaping import PX4, PX4_BELOW_OWN_LOOP, Shaper, ShapingConfig
from masonry.sim.vehicle import SimVehicle
from masonry.sim.vehicle_config import sitl_vehicle_preset, vehicle_preset
from test_sim_shaping import CASE_STUDY


def test_the_droop_reaches_part_of_a_step_at_once_and_the_rest_over_its_time():
    shaper = Shaper(ShapingConfig(velocity_droop=0.25, velocity_droop_s=4.0))
    first = shaper.shape(0.0, 0.5, 0.0, 0.4, 0.01)
    assert first[0] == pytest.approx(0.375, abs=0.002) and first[2] == 0.4  # horizontal only
    out = first
    for i in range(1, 1600):  # 16 s: four of its time constants
        out = shaper.shape(i * 0.01, 0.5, 0.0, 0.4, 0.01)
    assert out[0] == pytest.approx(0.5 - 0.125 * math.exp(-4.0), abs=0.003)
    with pytest.raises(InvalidArgument, match="velocity_droop must be in"):
        ShapingConfig(velocity_droop=1.0)


def test_the_velocity_wander_has_its_standard_deviation_and_correlation_time():
    shaper = Shaper(ShapingConfig(velocity_wander_mps=0.1, velocity_wander_tau_s=0.1))
    rng = np.random.default_rng(2)
    vs = []
    for i in range(40000):
        shaper.drift(0.01, rng.standard_normal)
        vs.append(shaper.shape(i * 0.01, 0.0, 0.0, 0.0, 0.01)[0])
    v = np.array(vs)
    assert 0.09 < v.std() < 0.11
    assert abs(np.corrcoef(v[:-10], v[10:])[0, 1] - math.exp(-1.0)) < 0.1  # correlated over tau


def test_the_px4_airframe_moves_with_its_wander_behind_its_dead_time():
    vehicle = SimVehicle(vehicle_preset("px4"), rng=np.random.default_rng(3))
    vehicle.arm()
    vehicle.takeoff(1.5)
    for _ in range(1500):
        vehicle.step(0.01)
    assert not vehicle.taking_off
    speeds = []
    for i in range(2000):  # 20 s of zero velocity: the airframe itself moves (not only its telemetry)
        vehicle.command_velocity((0.0, 0.0, 0.0), 0.0, vehicle.time_s)
        vehicle.step(0.01)
        if i % 5 == 0:
            speeds.append(vehicle.velocity_mps[0])
    assert 0.03 < float(np.std(speeds)) < 0.09  # the real PX4: 4.4-5.8 cm/s rms
    x0 = vehicle.position_m[0]
    for _ in range(24):  # a 0.5 m/s step: nothing before the dead time
        vehicle.command_velocity((0.5, 0.0, 0.0), 0.0, vehicle.time_s)
        vehicle.step(0.01)
    assert abs(vehicle.position_m[0] - x0) < 0.05


def test_the_px4_tuning_brings_the_own_loops_gains_in_simulation_as_on_a_real_px4():
    settings = uav_settings("px4")
    assert settings["pid_gains"].x.kp == OWN_VELOCITY_LOOP_PID["xy"]["kp"]
    bp = load_blueprint(CASE_STUDY)
    ports = select_adapters(
        sim=True, blueprint=bp, spec=bp.fleet[0], seed=0, camera="geometric", faults=Faults(), vehicle="px4"
    )
    try:
        assert fly_settings(HardwareConfig(), "px4", ports) == settings
        assert fly_settings(HardwareConfig(), "arducopter", ports) == uav_settings("arducopter")
    finally:
        ports.close()
    # masonry sitl's px4 runs below the adapter's own loop: the model without what stands for it
    below = sitl_vehicle_preset("px4")
    assert below.shaping == PX4_BELOW_OWN_LOOP and below.shaping.velocity_wander_mps == 0.0
    assert PX4.velocity_wander_mps > 0.0 and sitl_vehicle_preset("arducopter") == vehicle_preset("arducopter")
