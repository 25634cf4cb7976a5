"""Wind gusts: brick tasks succeed in moderate gusts with the default controller.

The simulated wind (``gusts=S``: an Ornstein-Uhlenbeck horizontal wind of standard deviation S m/s) pushes the
airframe; the autopilot's velocity loop only partly rejects it, so the position PID needs integral action and
the alignment before a descent needs some patience. Figures per gust strength: docs/performance.md.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.fakes import QueueMissionLink
from masonry.fsm import UavConfig, build_uav, run_single_task
from masonry.motion import PIDGains
from masonry.planner import plan
from masonry.sim import Faults, World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _fly_brick(seed: int, gusts_mps: float, **config: object):
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    world = World(bp, seed=seed, faults=Faults(gusts_mps=gusts_mps))
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


def test_the_old_soft_gains_could_not_hold_alignment_in_1_mps_gusts() -> None:
    """The test above is not trivially passing: kp 1.2, ki 0.1 and a strict alignment fail in the same wind."""
    from masonry.motion import AxisGains

    soft = AxisGains(kp=1.2, ki=0.1, kd=0.0, output_limit=1.0, integral_limit=0.3)
    gains = PIDGains(x=soft, y=soft)
    failures = 0
    for seed in range(2):
        run, _ = _fly_brick(seed, 1.0, pid_gains=gains, align_patience_s=1e9)
        failures += run.result is None or run.result.status != "done"
    assert failures == 2
