"""The machines fly in the simulated world (masonry.sim): accuracy over seeds, and the world's faults."""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.fakes import QueueMissionLink
from masonry.fsm import UavConfig, build_uav, run_single_task
from masonry.planner import plan
from masonry.sim import Faults, World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _fly(task_id: str, seed: int, faults: Faults | None = None, camera: str = "geometric"):
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task(task_id)
    world = World(bp, seed=seed, faults=faults, camera=camera)  # type: ignore[arg-type]
    spec = next(u for u in bp.fleet if u.role == task.kind)
    sim_uav = world.add_uav(spec)
    link = QueueMissionLink([task])
    uav = build_uav(
        UavConfig.from_spec(spec, markers=bp.markers),
        fc=sim_uav.fc,
        link=link,
        clock=world.clock,
        gripper=sim_uav.gripper,
        camera=sim_uav.camera,
        sprayer=sim_uav.sprayer,
    )
    run = run_single_task(uav, world.clock, advance=world.step, dt_s=0.05, timeout_s=400.0)
    return run, world, task, uav


@pytest.mark.parametrize("seed", range(12))
def test_brick_lands_within_3_cm_of_its_blueprint_pose(seed: int) -> None:
    """Default noise (mocap, camera, pickup scatter of 5 cm and any yaw): the grasp tolerance is 3 cm."""
    run, world, task, _ = _fly("B0" if seed % 2 else "B1", seed)
    assert run.result is not None and run.result.status == "done", run.result
    error = world.placement_error_m(task.brick)
    assert error is not None and error <= 0.03, f"seed {seed}: placement error {error:.4f} m"
    assert world.placement_yaw_error_rad(task.brick) <= 0.05
    assert run.final_state == "idle"


@pytest.mark.parametrize("seed", range(8))
def test_adhesion_covers_the_segment(seed: int) -> None:
    run, world, task, _ = _fly("A0" if seed % 2 else "A1", seed)
    assert run.result is not None and run.result.status == "done"
    assert world.coverage(task) >= 0.95, f"seed {seed}: coverage {world.coverage(task):.3f}"


def test_grasp_failures_in_the_world_are_retried() -> None:
    for seed in range(10):
        run, world, task, uav = _fly("B0", seed, Faults(grasp_failure=0.5))
        if uav.grasp_attempts >= 1 and run.result is not None and run.result.status == "done":
            assert world.placement_error_m(task.brick) <= 0.03
            return
    pytest.fail("no seed in 0..9 had a failed grasp followed by a success")


def test_detection_dropout_and_occlusion_still_place_the_brick() -> None:
    run, world, task, _ = _fly("B0", 3, Faults(dropout=0.5, occlusion=0.5))
    assert run.result is not None and run.result.status == "done"
    assert world.placement_error_m(task.brick) <= 0.03


def test_link_loss_in_the_world_fails_the_task_and_the_uav_lands() -> None:
    run, world, _, uav = _fly("B0", 0, Faults(link_loss_at_s={"brick-1": 15.0}))
    assert (
        run.result is not None and run.result.status == "failed" and "link lost" in (run.result.reason or "")
    )
    assert uav.state == "halted"
    world.run(20.0)  # the autopilot's own failsafe: hover, then land
    assert world.uavs["brick-1"].vehicle.on_ground


def test_uav_loss_in_the_world() -> None:
    run, world, _, uav = _fly("A0", 0, Faults(uav_loss_at_s={"glue-1": 10.0}))
    assert run.result is not None and run.result.status == "failed"
    assert uav.state == "halted" and not world.uavs["glue-1"].valve_open


def test_low_battery_in_the_world_aborts_and_lands_at_home() -> None:
    bp = load_blueprint(CASE_STUDY)
    run, world, _, uav = _fly("B0", 0, Faults(battery_drain_per_s=0.03))
    assert run.result is not None and run.result.status == "failed" and "battery" in (run.result.reason or "")
    assert uav.state == "halted"
    x, y, _ = world.uavs["brick-1"].vehicle.position_m
    home = bp.uavs("brick")[0].home_m
    assert abs(x - home[0]) < 0.2 and abs(y - home[1]) < 0.2


def test_rendered_camera_with_the_real_aruco_pipeline() -> None:
    run, world, task, _ = _fly("B1", 5, camera="render")
    assert run.result is not None and run.result.status == "done", run.result
    assert world.placement_error_m(task.brick) <= 0.03
