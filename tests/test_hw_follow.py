"""SimVehicle.follow: the simulated world moving with a real autopilot's telemetry (``--fc URL --camera sim``)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from masonry.sim import SimVehicle

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def test_follow_takes_the_measured_state() -> None:
    v = SimVehicle(position_m=(1.0, 2.0, 0.0), rng=np.random.default_rng(0))
    v.follow((1.0, 2.0, 1.5), (0.1, -0.2, 0.3), (0.05, -0.1, 2.0), on_ground=False, armed=True, mode="GUIDED",
             battery_fraction=0.8, dt_s=0.5)  # fmt: skip
    assert v.position_m == (1.0, 2.0, 1.5) and v.velocity_mps == (0.1, -0.2, 0.3)
    assert v.attitude_rad == pytest.approx((0.05, -0.1, 2.0), abs=1e-12)
    assert v.armed and not v.on_ground and v.airborne and v.mode == "GUIDED" and v.battery_fraction == 0.8
    assert v.time_s == 0.5 and v.airborne_s == 0.5 and v.distance_m == pytest.approx(1.5)
    tel = v.telemetry()
    assert tel.position_m == pytest.approx((1.0, 2.0, 1.5), abs=0.01) and tel.armed and tel.mode == "GUIDED"
    # no battery monitor (NaN) and no mode: both kept; landed time does not count as airborne
    v.follow((1.0, 2.0, 0.0), (0, 0, 0), (0, 0, 2.0), on_ground=True, armed=False, battery_fraction=math.nan,
             dt_s=1.0)  # fmt: skip
    assert v.battery_fraction == 0.8 and v.mode == "GUIDED" and v.on_ground and not v.armed
    assert v.time_s == 1.5 and v.airborne_s == 0.5 and v.distance_m == pytest.approx(3.0)


def test_follow_refuses_non_finite_state() -> None:
    v = SimVehicle()
    with pytest.raises(ValueError, match="finite"):
        v.follow((math.nan, 0, 0), (0, 0, 0), (0, 0, 0), on_ground=True, armed=False)
    with pytest.raises(ValueError, match="dt_s"):
        v.follow((0, 0, 0), (0, 0, 0), (0, 0, 0), on_ground=True, armed=False, dt_s=-1.0)


@given(
    st.floats(-1.2, 1.2), st.floats(-1.2, 1.2), st.floats(-math.pi, math.pi),
)  # fmt: skip
def test_follow_reads_back_roll_pitch_yaw(roll: float, pitch: float, yaw: float) -> None:
    v = SimVehicle()
    v.follow((0, 0, 1), (0, 0, 0), (roll, pitch, yaw), on_ground=False, armed=True)
    got = v.attitude_rad
    assert got[0] == pytest.approx(roll, abs=1e-9) and got[1] == pytest.approx(pitch, abs=1e-9)
    assert math.isclose(math.remainder(got[2] - yaw, 2 * math.pi), 0.0, abs_tol=1e-9)


def test_world_follows_the_flight_controller_and_the_camera_sees_from_there() -> None:
    """The wiring for ``--fc URL --camera sim``: the world's UAV is wherever the (here: fake) autopilot says."""
    from masonry.adapters.wiring import _follow_autopilot
    from masonry.blueprint import load_blueprint
    from masonry.fakes import FakeFlightController
    from masonry.sim import World

    bp = load_blueprint(CASE_STUDY)
    spec = bp.uavs("brick")[0]
    world = World(bp, seed=0)
    uav = world.add_uav(spec)
    fc = FakeFlightController(world.clock, position_m=spec.home_m)
    _follow_autopilot(uav, fc)
    fc.arm()
    fc.takeoff(1.2)
    for _ in range(100):
        world.step(0.05)
    for _ in range(60):  # 3 s east at 0.5 m/s
        fc.send_velocity((0.5, 0.0, 0.0), 0.0)
        world.step(0.05)
    tel = fc.telemetry()
    world.step(0.05)  # the world's UAV takes the telemetry of the tick's start
    assert uav.vehicle.position_m == pytest.approx(tel.position_m, abs=1e-12)
    assert tel.position_m[0] > spec.home_m[0] + 1.0 and tel.position_m[2] > 1.0
    assert uav.vehicle.armed and not uav.vehicle.on_ground
    assert world.distance_flown_m(spec.name) > 2.0
    frame = uav.camera.read()
    assert frame is not None and frame.time_s == pytest.approx(world.clock.now_s())


def test_sim_telemetry_carries_every_field_and_the_landing_flag() -> None:
    from dataclasses import fields

    from masonry.ports import Telemetry

    v = SimVehicle(rng=np.random.default_rng(0))
    v.arm()
    v.takeoff(1.0)
    for _ in range(60):
        v.step(0.05)
    tel = v.telemetry()
    assert set(vars(tel)) == {f.name for f in fields(Telemetry)} and not tel.landing
    v.land()
    assert v.telemetry().landing and v.telemetry().mode == "LAND"
