"""A put-back given up on the way (its pickup's column kept it waiting until the battery only affords the way
home): the UAV flies home with the brick, and the task is reported failed only once it has landed and handed the
brick over. With a ground crew (the battery swap's), the crew lays the brick back where it was picked up, so the
task's retry finds it there; without one, the brick waits on the UAV's pad (docs/state-machines.md, "Putting a
brick back")."""

from __future__ import annotations

import math
from pathlib import Path

from masonry.blueprint import load_blueprint
from masonry.fakes import ScriptedClearanceLink
from masonry.fakes.link import FakeClearance
from masonry.fsm import UavConfig, build_uav, run_single_task
from masonry.mission.uav_stack import GroundCrew
from masonry.planner import plan
from masonry.sim import Faults, World

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


class _PickupColumnTaken(ScriptedClearanceLink):
    """Grants every column at once, except the brick's pickup column once the brick is being put back: another
    UAV hovers there (the case the 6-UAV retire test met)."""

    def __init__(self, *args, **kwargs) -> None:
        super().__init__(*args, **kwargs)
        self.state = lambda: ""
        self.reported_in: list[str] = []  # the machine's state as each result went out

    def report_result(self, result):
        self.reported_in.append(self.state())
        super().report_result(result)

    def request_clearance(self, site_m, top_m=None, to_m=None):
        if self.state() == "putback_goto":
            return FakeClearance(False, self.layer_m)
        return super().request_clearance(site_m, top_m, to_m)


def _fly_home_with_the_brick(ground_crew: bool):
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("B0")
    world = World(bp, seed=0, faults=Faults(battery_drain_per_s=1e-5))
    spec = next(u for u in bp.fleet if u.role == "brick")
    sim_uav = world.add_uav(spec)
    sim_uav.vehicle.battery_fraction = 0.21
    crew = GroundCrew(sim_uav.vehicle, world.clock, sim_uav)
    link = _PickupColumnTaken(
        [task],
        world.clock,
        layer_m=None,
        swaps_batteries=ground_crew,
        return_brick=crew.return_brick if ground_crew else None,
    )
    uav = build_uav(
        UavConfig.from_spec(spec, markers=bp.markers),
        fc=sim_uav.fc,
        link=link,
        clock=world.clock,
        gripper=sim_uav.gripper,
        camera=sim_uav.camera,
        sprayer=sim_uav.sprayer,
    )
    link.state = lambda: str(uav.state)
    picked_from: list[tuple[tuple[float, float, float], float]] = []

    def advance(dt_s: float) -> None:
        brick = world.bricks[task.brick]
        if uav.state == "transport" and sim_uav.vehicle.battery_fraction > 0.2:
            assert brick.carrier == spec.name and brick.picked_from is not None
            picked_from.append(brick.picked_from)
            sim_uav.vehicle.battery_fraction = 0.19  # battery low with the brick on board: put it back
        if uav.state == "putback_goto" and uav._waiting_since_s is not None:
            # waiting for the pickup's column: only the way home is left above critical (0.10)
            sim_uav.vehicle.battery_fraction = min(sim_uav.vehicle.battery_fraction, 0.1004)
        world.step(dt_s)

    run = run_single_task(uav, world.clock, advance=advance, dt_s=0.05, timeout_s=400.0)
    return bp, world, task, spec, sim_uav, uav, run, picked_from, link.reported_in, link


def test_a_brick_kept_on_board_is_returned_to_its_pickup_by_the_ground_crew_and_picked_up_again() -> None:
    bp, world, task, spec, sim_uav, uav, run, picked_from, reported_in, link = _fly_home_with_the_brick(True)
    assert run.result is not None and run.result.status == "failed"
    reason = run.result.reason or ""
    assert "brick 0 kept on board; ground crew returned brick 0 to its pickup" in reason, reason
    states = [s for _, s in uav.trace]
    assert "putback_goto" in states and "putback_release" not in states  # it never let go at the pallet
    # the task stayed in hand (no UAV sent for the brick) until the UAV had landed and the crew had the brick
    assert reported_in and reported_in == ["land"], reported_in
    assert link.returned == [0]
    brick = world.bricks[task.brick]
    assert brick.carrier is None and brick.state == "pickup" and sim_uav.carried_brick is None
    (at, yaw), *_ = picked_from
    assert brick.position_m == at and brick.yaw_rad == yaw  # laid back where it was picked up
    assert uav.state == "idle"  # a ground crew: the battery is swapped, the UAV not retired
    # the retry (here the same UAV after its pack swap) finds the brick at its pickup and places it
    sim_uav.vehicle.swap_battery()
    retry = build_uav(
        UavConfig.from_spec(spec, markers=bp.markers),
        fc=sim_uav.fc,
        link=ScriptedClearanceLink([task], world.clock, layer_m=None),
        clock=world.clock,
        gripper=sim_uav.gripper,
        camera=sim_uav.camera,
        sprayer=sim_uav.sprayer,
    )
    again = run_single_task(retry, world.clock, advance=world.step, dt_s=0.05, timeout_s=400.0)
    assert again.result is not None and again.result.status == "done", again.result
    assert world.placement_error_m(task.brick) <= 0.03


def test_without_a_ground_crew_a_brick_kept_on_board_waits_on_the_pad_and_the_report_says_so() -> None:
    _, world, task, spec, _, uav, run, _, reported_in, link = _fly_home_with_the_brick(False)
    assert run.result is not None and run.result.status == "failed"
    reason = run.result.reason or ""
    assert reason.endswith(
        "brick 0 kept on board; no ground crew: brick 0 waits on brick-1's pad for a person"
    )
    assert reported_in and reported_in == ["land"], reported_in
    assert link.returned == [] and uav.state == "halted"  # no ground crew: a low battery retires the UAV
    brick = world.bricks[task.brick]
    home = spec.home_m
    assert (
        brick.carrier is None
        and math.hypot(brick.position_m[0] - home[0], brick.position_m[1] - home[1]) < 0.5
    )
