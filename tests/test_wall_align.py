"""Placement by the wall's own markers (issue 30): the drop-off moves with the bricks of the wall the camera sees,
so that under GNSS wander a brick keeps its designed offsets to its neighbours."""

from __future__ import annotations

import math

import numpy as np
import pytest

from masonry.blueprint_gen import pyramid
from masonry.errors import InputError
from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import PRESETS, uav_settings
from masonry.fsm.wall_align import drift_noise_mps_per_sqrt_s, off_support, wall_offset_m
from masonry.mission.built_truth import neighbour_errors_m
from masonry.mission.simulate import SimulatedMission

WALL = {0: (0.0, 0.0, 0.1), 1: (0.3, 0.0, 0.1), 2: (0.15, 0.0, 0.2)}


def test_the_offset_is_the_mean_over_the_bricks_on_the_wall() -> None:
    seen = {
        0: np.array([0.02, 0.01, 0.1]),  # (+2, +1) cm
        1: np.array([0.34, 0.03, 0.1]),  # (+4, +3) cm
        2: np.array([0.15, 0.0, 0.2]),  # the brick being placed: not a reference
        7: np.array([5.0, 5.0, 0.0]),  # not in the wall
    }
    assert np.allclose(wall_offset_m(seen, WALL, own=2), [0.03, 0.02, 0.0])


def test_a_brick_off_the_wall_is_no_reference_and_none_gives_none() -> None:
    # brick 1 seen on its pallet, 2 m from its place; brick 0 not seen
    assert wall_offset_m({1: np.array([2.3, -2.0, 0.05])}, WALL, own=2) is None
    assert wall_offset_m({}, WALL, own=2) is None


def test_once_a_brick_it_touches_is_seen_a_frame_of_none_of_them_is_no_sighting() -> None:
    # a tower's brick on B3 (it touches B3 alone): a frame of another tower's B0 alone counts only until B3 is seen
    assert off_support(frozenset({3}), {3}, {0}) is True
    assert off_support(frozenset({3}), {3}, {0, 3}) is False
    assert off_support(frozenset({3}), {0}, {0}) is False  # none seen yet: the others are the best there is
    # a course's end on B3 beside B5: either of them in view is a sighting
    assert off_support(frozenset({3, 5}), {3}, {5}) is False
    assert off_support(frozenset(), {0, 1}, {1}) is False  # two supports: every brick in view counts


def test_in_a_wind_the_drift_filter_carries_the_side_looks_descent_only() -> None:
    assert drift_noise_mps_per_sqrt_s(0.015, in_wind=False, side_look=False) == 0.015
    assert drift_noise_mps_per_sqrt_s(0.015, in_wind=True, side_look=True) == 0.015
    assert drift_noise_mps_per_sqrt_s(0.015, in_wind=True, side_look=False) == 0.0
    assert drift_noise_mps_per_sqrt_s(0.0, in_wind=False, side_look=True) == 0.0


def test_only_the_px4_preset_turns_it_on() -> None:
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).align_on_wall is False
    assert PRESETS["px4"]["align_on_wall"] is True
    assert "align_on_wall" not in PRESETS["arducopter"]


def _px4_pyramid(align_on_wall: bool) -> SimulatedMission:
    settings = {**uav_settings("px4"), "align_on_wall": align_on_wall}
    mission = SimulatedMission.from_blueprint(
        pyramid(3, yaw_rad=math.radians(30.0), clearance_m=1.0),
        seed=1,
        vehicle="px4",
        uav_config=UavConfig("template", "brick", (0.0, 0.0, 0.0), **settings),
    )
    # with the wall's markers every brick is placed; without them a brick may land a course too low and, found off
    # its course, is not counted placed (masonry.mission.course_check; tests/test_course_check.py proves that).
    # Which seeds do so on GNSS alone is the wander's draw at the placements' times, which every change of timing
    # moves (issue 27: seed 1 with B3 until the linger, seed 4 until the linger's give-way, seed 3 until the
    # sprayer's shorter first descent, seed 1 again until the px4 descent's window): so it is not asserted here.
    completed = mission.run().completed
    assert completed or not align_on_wall
    done = {a.task_id for a in mission.control.history if a.status == "done"}
    for b in mission.blueprint.bricks:  # no brick counted placed is off its course (the simulator's truth)
        if f"B{b.id}" in done:
            assert mission.world.bricks[b.id].position_m[2] == pytest.approx(b.position_m[2], abs=0.02)
    return mission


@pytest.mark.slow
def test_on_gnss_the_bricks_keep_closer_to_their_neighbours() -> None:
    """The px4 model (GNSS wander +-15 cm), a pyramid turned 30 degrees: with the wall's markers the bricks sit
    less than half as far from where their neighbours say they belong as on the absolute position (1.6 cm
    against 13.4 cm on this seed at main 524230c, every brick placed both ways; docs/performance/as-built.md has
    the benchmark)."""
    on, off = neighbour_errors_m(_px4_pyramid(True)), neighbour_errors_m(_px4_pyramid(False))
    assert np.mean(on) < 0.5 * np.mean(off), (np.mean(on), np.mean(off))


@pytest.mark.slow
def test_a_first_course_brick_whose_neighbour_the_camera_cannot_see_is_placed_turned() -> None:
    """The px4 pyramid's B2 stands beside B1 on the side away from the camera (10 cm beside the rod): no height
    from 0 to 40 cm over its drop-off shows a marker of B1, and on seed 15 its release waited on old sightings
    until three placements failed (issue 30, branch ``pyrseed33``). Placed a half turn round, B1 is in view down
    to the release: the mission completes, every brick within 2 cm of its neighbours; B0 and B1 keep their yaw."""
    mission = SimulatedMission.from_blueprint(
        pyramid(3, yaw_rad=math.radians(30.0), clearance_m=1.0), seed=15, vehicle="px4"
    )
    assert mission.run().completed
    assert max(neighbour_errors_m(mission)) < 0.02
    turned = {
        b.id: abs(math.remainder(mission.world.bricks[b.id].yaw_rad - b.yaw_rad, 2.0 * math.pi))
        > math.pi / 2.0
        for b in mission.blueprint.bricks
        if b.position_m[2] < 0.1
    }
    assert turned == {0: False, 1: False, 2: True}


def test_uav_yaml_may_switch_it_but_not_set_the_wall() -> None:
    assert uav_settings("arducopter", {"align_on_wall": True})["align_on_wall"] is True
    with pytest.raises(InputError, match="control: align_on_wall must be true or false"):
        uav_settings("ideal", {"align_on_wall": 1})
    with pytest.raises(InputError, match="control: unknown setting 'wall'"):
        uav_settings("ideal", {"wall": 3})
