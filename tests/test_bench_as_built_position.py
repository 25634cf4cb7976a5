"""benchmarks/bench_as_built.py's ``--position-error`` columns: the UAV's own position error at each as-built look
(the telemetry less the simulated vehicle's truth, over the frames the look's window took) and how much of the
estimate's error it explains."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from benchmark_module import benchmark
from masonry.blueprint_gen import towers
from masonry.fsm.as_built import AsBuiltLook
from masonry.mission.simulate import SimulatedMission
from masonry.sim.vehicle_model import sim_vehicle


def _bench():
    return benchmark("bench_as_built")


def _exact(spec, config, **kwargs):
    """The ideal vehicle with telemetry that is the truth (no motion-capture noise)."""
    return sim_vehicle(spec, dataclasses.replace(config, mocap_noise_m=0.0), **kwargs)


def test_explained_subtracts_each_position_error_and_correlates_the_components():
    bench = _bench()
    position = [np.array([0.003, -0.001]), np.array([-0.004, 0.002]), np.array([0.001, 0.006])]
    offsets = [np.array([0.0003, 0.0004]), np.zeros(2), np.array([0.0, -0.001])]
    corr, left = bench.explained(position, [p + d for p, d in zip(position, offsets)])
    assert np.allclose(left, [0.0005, 0.0, 0.001], atol=1e-12)
    assert 0.95 < corr <= 1.0
    corr, left = bench.explained(
        [np.zeros(2)] * 3, position
    )  # no position error: all of it left, nothing to tie
    assert math.isnan(corr) and np.allclose(left, [float(np.linalg.norm(p)) for p in position])


def test_a_look_on_exact_telemetry_has_no_position_error_and_a_noisy_one_its_own():
    bench = _bench()
    bp = towers(1, 2, spacing_m=1.0, brick_uavs=1, adhesion_uavs=1)
    original = (AsBuiltLook.begin, AsBuiltLook.look, AsBuiltLook.pose)
    exact = bench.PositionErrors()
    mission = SimulatedMission.from_blueprint(bp, seed=0, vehicle="ideal", vehicle_model=_exact)
    with exact.watching():
        report = mission.run()
    assert (AsBuiltLook.begin, AsBuiltLook.look, AsBuiltLook.pose) == original  # put back as it was
    assert report.completed and set(exact.by_brick) == {int(b[1:]) for b in report.as_built} == {0, 1}
    assert all(np.array_equal(err, np.zeros(3)) for err in exact.by_brick.values())
    noisy = bench.PositionErrors()
    mission = SimulatedMission.from_blueprint(bp, seed=0, vehicle="arducopter")
    with noisy.watching():
        report = mission.run()
    for bid, err in noisy.by_brick.items():
        # the arducopter model's 3 mm wander and 2 mm white noise, averaged over 2-3 s: millimetres, not zero
        assert 0.0 < float(np.linalg.norm(err[:2])) < 0.02
        pose = report.as_built[f"B{bid}"]
        look = np.subtract(pose.world_position_m or pose.position_m, mission.world.bricks[bid].position_m)
        # a brick seen alone: its look is off by the position error and the camera's few millimetres
        assert float(np.linalg.norm(look[:2] - err[:2])) < 0.003
