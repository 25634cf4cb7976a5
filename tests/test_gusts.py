"""Wind gusts: brick tasks succeed in moderate gusts with the default controller.

The simulated wind (``gusts=S``: Dryden turbulence of horizontal intensity S m/s, masonry.sim.wind) pushes the
airframe; the autopilot's velocity loop takes the push out with its integral action (as ArduCopter's does), the
position PID's integral the rest, and the alignment before a descent needs some patience. Figures:
docs/performance/wind.md (the earlier gusts model: docs/performance/history.md, "Issue 5: gusts").
"""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.fakes import QueueMissionLink
from masonry.fsm import UavConfig, build_uav, run_single_task
from masonry.motion import PIDGains
from masonry.planner import plan
from masonry.sim import Faults, VehicleConfig, World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _fly_brick(seed: int, gusts_mps: float, vehicle: VehicleConfig | None = None, **config: object):
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    world = World(bp, seed=seed, faults=Faults(gusts_mps=gusts_mps), vehicle=vehicle)
    spec = next(u for u in bp.fleet if u.role == "brick")
    sim_uav = world.add_uav(spec)
    uav = build_uav(
        UavConfig.from_spec(spec, markers=bp.markers, **config),  # type: ignore[arg-type]
        fc=sim_uav.fc,
        link=QueueMissionLink([task]),
        clock=world.clock,
        gripper=sim_uav.gripper,
        camera=sim_uav.camera,
    )
    run = run_single_task(uav, world.clock, advance=world.step, dt_s=0.05, timeout_s=600.0)
    return run, world.placement_error_m(task.brick)


@pytest.mark.parametrize("seed", range(4))
def test_brick_task_succeeds_in_1_mps_gusts(seed: int) -> None:
    run, error = _fly_brick(seed, 1.0)
    assert run.result is not None and run.result.status == "done", run.result
    assert error is not None and error <= 0.04, f"seed {seed}: placement error {error:.4f} m"


def test_soft_gains_fail_without_the_autopilots_integral_action() -> None:
    """The test above is not trivially passing: kp 1.2, ki 0.1 and a strict alignment hold in these gusts only
    because the autopilot rejects the wind's push; on a velocity loop without integral action (the simulator
    before the wind model) they cannot align."""
    from masonry.motion import AxisGains

    soft = AxisGains(kp=1.2, ki=0.1, kd=0.0, output_limit=1.0, integral_limit=0.3)
    gains = PIDGains(x=soft, y=soft)
    no_integral = VehicleConfig(wind_reject_tau_s=1e6)
    outcomes = {}
    for label, vehicle in (("autopilot", None), ("no integral", no_integral)):
        runs = [_fly_brick(seed, 1.0, vehicle, pid_gains=gains, align_patience_s=1e9)[0] for seed in range(2)]
        outcomes[label] = sum(r.result is not None and r.result.status == "done" for r in runs)
    assert outcomes == {"autopilot": 2, "no integral": 0}, outcomes
