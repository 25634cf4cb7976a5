"""The machines fly in the simulated world (masonry.sim): accuracy over seeds, and the world's faults."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from fsm_rig import sim_machine
from masonry.blueprint import load_blueprint
from masonry.fsm import run_single_task
from masonry.planner import plan
from masonry.sim import Faults, World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def _fly(task_id: str, seed: int, faults: Faults | None = None, camera: str = "geometric"):
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task(task_id)
    world = World(bp, seed=seed, faults=faults, camera=camera)  # type: ignore[arg-type]
    spec = next(u for u in bp.fleet if u.role == task.kind)
    sim_uav = world.add_uav(spec)
    uav = sim_machine(bp, world, sim_uav, task)
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


@pytest.mark.parametrize(
    "loaded_state", ["pickup_ascend", "pickup_verify", "transport", "place_align", "place_descend"]
)
def test_a_task_given_up_with_the_brick_on_board_puts_it_back_on_its_pallet(loaded_state: str) -> None:
    """The battery runs low while the brick is on the magnet: the UAV puts it back where it picked it up (so that
    the task's retry finds it there), then reports the task failed and flies home; before, it landed with it."""
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    # a slow drain from 21 %, then 19 % at ``loaded_state``: the drain measured over the task leaves the UAV
    # time to put the brick back (test_fsm_scenarios has the case where it does not)
    world = World(bp, seed=0, faults=Faults(battery_drain_per_s=1e-4))
    spec = next(u for u in bp.fleet if u.role == "brick")
    sim_uav = world.add_uav(spec)
    sim_uav.vehicle.battery_fraction = 0.21
    uav = sim_machine(bp, world, sim_uav, task)
    picked_up_at: list[tuple[float, float, float]] = []

    def advance(dt_s: float) -> None:
        if uav.state == loaded_state and not picked_up_at:
            brick = world.bricks[task.brick]
            assert brick.carrier == "brick-1"  # on the magnet
            estimate = uav.brick_estimate
            assert estimate is not None
            picked_up_at.append(tuple(estimate[0]))
            sim_uav.vehicle.battery_fraction = (
                0.19  # below battery_low_fraction (0.20), above critical (0.10)
            )
        world.step(dt_s)

    run = run_single_task(uav, world.clock, advance=advance, dt_s=0.05, timeout_s=400.0)
    assert run.result is not None and run.result.status == "failed"
    assert run.result.reason == "battery low (19%); brick 0 put back at its pickup"
    states = [s for _, s in uav.trace]
    assert states[states.index(loaded_state) + 1 :].count("putback_release") == 1
    brick = world.bricks[task.brick]
    assert brick.carrier is None
    top = brick.top_center_m
    # where it was picked up (its estimated top face), within the release radius and the conical guide's play
    assert math.dist(top[:2], picked_up_at[0][:2]) < 0.04 and abs(top[2] - picked_up_at[0][2]) < 0.02
    home = spec.home_m
    x, y, _ = sim_uav.vehicle.position_m
    assert uav.state == "halted" and math.hypot(x - home[0], y - home[1]) < 0.2  # no battery service: retired


def test_a_task_given_up_as_the_magnet_takes_the_brick_in_the_descent_puts_it_back() -> None:
    """Found by the chaos campaign (seed 192): mission control fell silent just as the magnet took the brick, still
    in ``pickup_descend``; the abort there flew the brick home, and the retry found no brick on the pallet."""
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    world = World(bp, seed=0)
    spec = next(u for u in bp.fleet if u.role == "brick")
    sim_uav = world.add_uav(spec)
    uav = sim_machine(bp, world, sim_uav, task)
    on_pallet = world.bricks[task.brick].top_center_m
    aborted: list[str] = []

    def advance(dt_s: float) -> None:
        if not aborted and uav.state == "pickup_descend" and world.bricks[task.brick].carrier == "brick-1":
            aborted.append(uav.state)
            assert uav.may_abort()
            uav.abort(reason="mission control lost (3.0 s silent)")
        world.step(dt_s)

    run = run_single_task(uav, world.clock, advance=advance, dt_s=0.05, timeout_s=400.0)
    assert aborted == ["pickup_descend"]
    assert run.result is not None and run.result.status == "failed"
    assert run.result.reason.startswith("mission control lost (3.0 s silent); brick 0 put back")
    brick = world.bricks[task.brick]
    assert brick.carrier is None  # released where it was picked up, for the retry
    assert (
        math.dist(brick.top_center_m[:2], on_pallet[:2]) < 0.04
        and abs(brick.top_center_m[2] - on_pallet[2]) < 0.02
    )
    assert "putback_release" in [s for _, s in uav.trace]


def test_a_brick_put_back_is_picked_up_again_by_the_retry() -> None:
    """The retry (here by the same UAV after a pack swap) finds the brick on its pallet and places it."""
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    world = World(bp, seed=0, faults=Faults(battery_drain_per_s=1e-4))
    spec = next(u for u in bp.fleet if u.role == "brick")
    sim_uav = world.add_uav(spec)
    sim_uav.vehicle.battery_fraction = 0.21

    first = sim_machine(bp, world, sim_uav, task)

    def low_in_transport(dt_s: float) -> None:
        if first.state == "transport" and sim_uav.vehicle.battery_fraction > 0.2:
            sim_uav.vehicle.battery_fraction = 0.19
        world.step(dt_s)

    run = run_single_task(first, world.clock, advance=low_in_transport, dt_s=0.05, timeout_s=400.0)
    assert run.result is not None and "put back" in (run.result.reason or "")
    sim_uav.vehicle.swap_battery()
    second = sim_machine(bp, world, sim_uav, task)
    run = run_single_task(second, world.clock, advance=world.step, dt_s=0.05, timeout_s=400.0)
    assert run.result is not None and run.result.status == "done", run.result
    assert world.placement_error_m(task.brick) <= 0.03
