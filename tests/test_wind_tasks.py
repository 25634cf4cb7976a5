"""Single tasks in wind (issue 18): a brick placed by the hanging rod, a segment sprayed by the leaning nozzle."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from masonry.blueprint import load_blueprint
from masonry.fsm import UavConfig, fly_task
from masonry.fsm.tuning import uav_settings
from masonry.planner import plan
from masonry.sim import Faults, World
from masonry.sim.vehicle_config import vehicle_preset
from masonry.sim.wind import WindConfig

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _fly(task_id: str, wind: WindConfig, seed: int, vehicle: str) -> tuple[Any, World, Any]:
    bp = load_blueprint(CASE_STUDY)
    the_plan = plan(bp)
    task = the_plan.task(task_id)
    world = World(bp, seed=seed, faults=Faults(wind=wind), vehicle=vehicle_preset(vehicle))
    role = "brick" if task_id.startswith("B") else "adhesion"
    spec = next(u for u in bp.fleet if u.role == role)
    uav = world.add_uav(spec)
    config = UavConfig.from_spec(spec, markers=bp.markers, **uav_settings(vehicle, {}, {}))
    run = fly_task(
        config,
        task,
        fc=uav.fc,
        clock=world.clock,
        gripper=uav.gripper,
        camera=uav.camera,
        sprayer=uav.sprayer,
        advance=world.step,
        timeout_s=600.0,
    )
    return run, world, task


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_brick_is_placed_in_a_steady_6_mps_wind(vehicle: str) -> None:
    """The UAV leans 12 degrees into it; the rod on its free joint hangs plumb, and the descent knows it."""
    run, world, _ = _fly("B0", WindConfig(speed_mps=6.0, direction_deg=270.0), 0, vehicle)
    assert run.result is not None and run.result.status == "done", run.result
    error = world.placement_error_m(0)
    # seeds 0-4 measured: ideal 0.17-0.68 cm, arducopter 0.60-1.63 cm; issue 18's bound is 3 cm at most
    assert error is not None and error <= (0.01 if vehicle == "ideal" else 0.02), error


@pytest.mark.parametrize("vehicle", ["ideal", "arducopter"])
def test_a_segment_is_sprayed_in_4_mps_light_turbulence(vehicle: str) -> None:
    """The pass is measured by the nozzle (masonry.fsm.bead): the body flies the point that puts the nozzle on the
    bead at the tilt of the moment, the valve is open only on the bead, and passes go back over what a gust made
    it miss. Over seeds 0-5 (measured): every segment done, the simulator's coverage 1.0 on both vehicles; the
    UAV's own (2 cm, stricter than the bead's 3 cm) 0.97-1.0, which it reports."""
    for seed in range(6):
        run, world, task = _fly(
            "A0", WindConfig(speed_mps=4.0, direction_deg=270.0, turbulence="light"), seed, vehicle
        )
        assert run.result is not None and run.result.status == "done", (seed, run.result)
        coverage = world.coverage(task)
        assert coverage >= 0.95, (seed, coverage)
        assert run.result.coverage is not None and 0.9 <= run.result.coverage <= 1.0, (seed, run.result)


def test_a_segment_is_sprayed_in_2_mps_moderate_turbulence() -> None:
    """Moderate turbulence (sigma_u 3 m/s) swings the nozzle by 5-10 cm: the passes go on over the gaps until the
    nozzle's track covers the segment. Seeds 0-5 on the simulated ArduCopter (measured): every segment sprayed
    has the simulator's coverage 1.0 (seed 3 fails its descent to the spraying height: a gate that mission
    control retries)."""
    done = 0
    for seed in range(6):
        run, world, task = _fly(
            "A0", WindConfig(speed_mps=2.0, direction_deg=270.0, turbulence="moderate"), seed, "arducopter"
        )
        assert run.result is not None
        if run.result.status != "done":
            assert run.result.reason is not None and "A0" in run.result.reason
            continue
        done += 1
        assert world.coverage(task) >= 0.95, (seed, world.coverage(task))
    assert done >= 5


def test_fly_sim_takes_the_wind_from_the_command_line() -> None:
    from typer.testing import CliRunner

    from masonry.cli import app

    argv = ["fly", "--uav", "brick", "--sim", "--blueprint", str(CASE_STUDY), "--task", "B0"]
    res = CliRunner().invoke(app, [*argv, "--wind", "5@270", "--turbulence", "none", "--format", "json"])
    assert res.exit_code == 0, res.output
    real = [
        "fly",
        "--uav",
        "brick",
        "--blueprint",
        str(CASE_STUDY),
        "--task",
        "B0",
        "--fc",
        "udp:127.0.0.1:1",
    ]
    res = CliRunner().invoke(app, [*real, "--actuators", "sim", "--camera", "sim", "--wind", "5"])
    assert res.exit_code == 2 and "for a simulated UAV" in res.output
