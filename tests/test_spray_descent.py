"""The adhesion UAV's first descent over a segment's start lasts what its drop needs (issue 27), not a fixed 4 s.

Before, every first descent took ``spray_descent_s`` (4 s), a drop of 0.30-0.75 m flown at a 0.14-0.35 m/s
peak; it lay on the 1 + 1 pyramid's critical path (the brick UAV holds at its site while the sprayer lays the
beads its next brick needs). It is now a minimum-jerk leg at the climb's peak speed ``vertical_speed_mps``, at
most ``spray_descent_s``: the vehicle's own limits (1 m/s, 2 m/s^2) are far above it, and the nozzle still comes
to rest at its spraying height, no lower.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from fsm_rig import sim_machine
from masonry.blueprint import load_blueprint
from masonry.fsm import run_single_task
from masonry.planner import plan
from masonry.sim import World
from masonry.timing import DEFAULT_TIMING, MIN_LEG_S, spray_descent_leg_s

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"


def test_the_descent_is_a_leg_at_the_climb_speed_capped_by_spray_descent_s() -> None:
    t = DEFAULT_TIMING
    # the clearance alone: 1.875 x 0.30 / 0.4 = 1.41 s
    assert spray_descent_leg_s(0.30, t.vertical_speed_mps, t.spray_descent_s) == pytest.approx(1.40625)
    # a drop of a few centimetres still takes a minimum leg
    assert spray_descent_leg_s(0.06, t.vertical_speed_mps, t.spray_descent_s) == MIN_LEG_S
    # a long drop takes at most spray_descent_s (the paper's figure)
    assert spray_descent_leg_s(1.5, t.vertical_speed_mps, t.spray_descent_s) == t.spray_descent_s


def test_a_first_descent_in_the_simulated_world_is_shorter_and_stops_at_the_spraying_height() -> None:
    """Case study A0 (surface at 0.20 m): the body comes down from the 1.2 m cruise altitude to 0.65 m, a
    0.55 m drop: 2.6 s, where it was 4 s; the nozzle never dips more than the spray tolerance below its
    spraying height (0.10 m above the surface), and the segment is covered."""
    bp = load_blueprint(CASE_STUDY)
    task = plan(bp).task("A0")
    world = World(bp, seed=1)
    spec = next(u for u in bp.fleet if u.role == "adhesion")
    sim_uav = world.add_uav(spec)
    uav = sim_machine(bp, world, sim_uav, task)
    cfg = uav.config
    lowest_m: list[float] = []

    def advance(dt_s: float) -> None:
        world.step(dt_s)
        if uav.state in ("descend", "spray"):
            lowest_m.append(sim_uav.vehicle.position_m[2])

    run = run_single_task(uav, world.clock, advance=advance, dt_s=0.05, timeout_s=400.0)
    assert run.result is not None and run.result.status == "done"
    assert world.coverage(task) >= 0.95
    entered = {s: t for t, s in reversed(uav.trace)}  # the first time each state was entered
    descent_s = entered["spray"] - entered["descend"]
    body_z_m = task.start_m[2] + cfg.airframe.spray_height_m - cfg.airframe.nozzle_offset_m[2]
    expected_s = spray_descent_leg_s(
        cfg.cruise_altitude_m - body_z_m, cfg.vertical_speed_mps, cfg.spray_descent_s
    )
    assert expected_s < cfg.spray_descent_s - 1.0
    assert descent_s < cfg.spray_descent_s - 1.0
    assert descent_s == pytest.approx(expected_s, abs=0.5)
    assert min(lowest_m) >= body_z_m - cfg.spray_tolerance_m
