"""The release's test on a noisy position source (issue 29, masonry.fsm.dropoff_reach)."""

from __future__ import annotations

import math
import random
from collections.abc import Callable

import pytest

from masonry.blueprint_gen import running_bond
from masonry.fsm.config import UavConfig
from masonry.fsm.dropoff_reach import (
    HELD_WINDOW_S,
    SWING_WINDOW_S,
    DropoffReach,
    resting_error_m,
    swing_margin_m,
)
from masonry.fsm.noise_gate import HoverNoise
from masonry.mission.simulate import simulate
from masonry.sim import Faults
from masonry.sim.wind import WindConfig

R_PL = 0.015  # the paper's r_pl (UavConfig.placement_radius_m)


def _hover(reach: DropoffReach, seed: int, *, mean_dz_m: float, duration_s: float = 4.0):
    """A hover at the bottom of a descent (the reference at the target, 10 Hz): the height ``mean_dz_m`` off it
    with +-4 cm of wander, the horizontal error swinging through the target at 5 cm (what PX4 v1.16 SITL did)."""
    rng = random.Random(seed)
    for i in range(int(duration_s * 10)):
        t = i * 0.1
        dz = mean_dz_m + 0.04 * math.sin(2.0 * math.pi * t / 1.7) + rng.gauss(0.0, 0.005)
        error = (0.05 * math.sin(2.0 * math.pi * t / 2.3), 0.03 * math.cos(2.0 * math.pi * t / 1.9), dz)
        yield t, error, reach.reached(t, error, dz, R_PL)


def test_a_hover_on_the_drop_off_is_reached_at_a_tick_within_r_pl_horizontally() -> None:
    # below the drop-off on average (the descent overshot 6 cm down, as on PX4) and moving: one tick within 1.5 cm
    # in three dimensions never comes, but the brick is down and a tick over the drop-off does
    for seed in range(5):
        ticks = list(_hover(DropoffReach(1.5), seed, mean_dz_m=-0.06))
        assert not any(math.dist(e, (0, 0, 0)) <= R_PL for _, e, _ in ticks)  # the paper's single tick
        reached = [(t, e) for t, e, ok in ticks if ok]
        assert reached, seed
        t, e = reached[0]
        assert t >= 1.5 and math.hypot(e[0], e[1]) <= R_PL  # a window seen; the brick lands within r_pl


def test_a_hover_above_the_drop_off_is_not_reached_even_on_ticks_that_dip_to_it() -> None:
    for seed in range(5):
        ticks = list(_hover(DropoffReach(1.5), seed, mean_dz_m=0.035, duration_s=10.0))
        assert any(math.dist(e, (0, 0, 0)) <= R_PL for _, e, _ in ticks)  # the paper's single tick would
        assert not any(ok for _, _, ok in ticks)


def test_a_brick_resting_on_its_support_is_reached_though_its_bounce_is_one_sided() -> None:
    # issue 30: set down on the ground, the brick holds the effector up: its height bounces up to 5 cm above the
    # drop-off and never below it (with the descent's last centimetre of lag fading), so the 3 s window's mean sits
    # ~1 cm high by itself and two standard errors over it put it past r_pl for the whole release window; the brick
    # is down at its height all the same
    for seed in range(5):
        rng = random.Random(seed)
        reach, margined, reached_s = DropoffReach(3.0), HoverNoise(3.0), None
        for i in range(70):  # the descent's last 3 s, then the release's 4 s
            t = i * 0.1
            bounce = 0.05 * max(0.0, math.sin(2.0 * math.pi * t / 1.7)) ** 2 + abs(rng.gauss(0.0, 0.002))
            dz = bounce + 0.01 * math.exp(-t)
            margined.add(t, (dz, 0.0), (0.0, 0.0))
            if t >= 3.0:  # the rule with the margin at every tick never lets go
                assert margined.mean_m[0] + 2.0 * margined.standard_error_m > R_PL, seed
            if reach.reached(t, (0.004, -0.003, dz), dz, R_PL) and reached_s is None:
                reached_s = t
                assert dz <= R_PL  # at a tick level with the drop-off, not at the top of a bounce
        assert reached_s is not None and reached_s < 4.0, seed


def test_the_descent_itself_is_not_spread_the_window_averages_about_its_reference() -> None:
    reach = DropoffReach(1.5)
    reached = []
    for i in range(90):  # a 7 s descent from 0.7 m (minimum jerk), then 2 s at the bottom, 1 cm behind it
        t = i * 0.1
        s = min(1.0, t / 7.0)
        ref_dz = 0.7 * (1.0 - (10 * s**3 - 15 * s**4 + 6 * s**5))
        error = (0.0, 0.0, ref_dz + 0.01)
        reached.append(reach.reached(t, error, 0.01, R_PL))
    first = reached.index(True) * 0.1
    assert 6.0 < first <= 7.0  # once the reference is 5 mm from the end, not a window after the descent
    reach.reset()
    assert not reach.reached(0.0, (0.0, 0.0, 0.0), 0.0, R_PL)  # a new descent: a window first


def test_the_error_at_rest_is_the_horizontal_one_the_brick_rests_on_its_support() -> None:
    # below the drop-off it stands on its support; above it, it falls onto it: either way at its support's height
    assert resting_error_m((0.003, 0.004, -0.05)) == pytest.approx(0.005)
    assert resting_error_m((0.003, 0.004, 0.012)) == pytest.approx(0.005)
    # the case study's B0 on a real PX4 (issue 29): released on a tick 2.9 cm above the drop-off, 15.0 mm to the
    # side; the brick came to rest 14.7 mm off its place (the simulated world's measure), not 32.7 mm
    assert resting_error_m((-0.01496, -0.0001, 0.02909)) == pytest.approx(0.01496, abs=1e-5)


def test_the_swing_is_the_fastest_horizontal_speed_about_the_reference_over_the_last_second() -> None:
    reach = DropoffReach(1.0)
    assert reach.swing(0.0, (0.10, 0.0, -0.3), (0.0, 0.0, -0.3)) == pytest.approx(
        0.10
    )  # the height is the leg's
    # a leg's own motion is no swing: 0.3 m/s along its reference, 0.03 m/s off it
    assert reach.swing(0.1, (0.3, 0.03, 0.0), (0.3, 0.0, 0.0)) == pytest.approx(
        0.10
    )  # the 0.10 still in view
    assert reach.swing(0.2 + SWING_WINDOW_S, (0.02, 0.0, 0.0), (0.0, 0.0, 0.0)) == pytest.approx(
        0.02
    )  # forgotten
    reach.reset()
    assert reach.swing(3.0, (0.0, 0.01, 0.0), (0.0, 0.0, 0.0)) == pytest.approx(0.01)


def test_the_release_radius_shrinks_with_the_swing_to_its_floor_for_the_patience_only() -> None:
    cfg = UavConfig("b", "brick", (0.0, 0.0, 0.0))  # the defaults (ideal's)
    # calm air at the drop-off (ideal: under 12 mm/s) keeps the paper's r_pl
    assert swing_margin_m(cfg, 0.012, 0.0) == 0.0
    assert swing_margin_m(cfg, cfg.release_still_mps, 0.0) == 0.0
    assert swing_margin_m(cfg, 0.06, 0.0) == pytest.approx(
        cfg.release_lead_s * (0.06 - cfg.release_still_mps)
    )
    floor_m = cfg.placement_radius_m - cfg.release_floor_m  # a gust's 0.15 m/s: down to the floor, no lower
    assert swing_margin_m(cfg, 0.15, -3.0) == pytest.approx(floor_m)
    assert swing_margin_m(cfg, 0.50, cfg.release_patience_s) == pytest.approx(floor_m)
    # past the patience, the paper's r_pl again: a descent fails no more often than before
    assert swing_margin_m(cfg, 0.50, cfg.release_patience_s + 0.1) == 0.0
    assert swing_margin_m(UavConfig("b", "brick", (0.0, 0.0, 0.0), release_lead_s=0.0), 0.5, 0.0) == 0.0


def test_in_4_m_s_wind_the_bricks_land_nearer_their_place_than_on_the_one_tick_test() -> None:
    # the motion-capture vehicle (exact position) in 4 m/s, light turbulence, a course of four: on the paper's
    # one-tick test (release_lead_s 0) the bricks were let go at the 1.5 cm disc's edge. Both flown from the same
    # template (default settings but the lead), over four seeds: one seed alone is one worst brick either way (seed
    # 0 was this test's only one until the blueprint's zone slack came into the default path, which the template
    # path does not take; the worst bricks of seeds 0-3 on 2026-12-05: 13.1 / 14.5 / 18.3 / 7.2 mm with the lead
    # against 19.2 / 14.5 / 22.1 / 9.9 without)
    bp = running_bond(1, 4, yaw_rad=math.radians(30.0), clearance_m=1.0, brick_uavs=1, adhesion_uavs=1)
    wind = Faults(wind=WindConfig(speed_mps=4.0, turbulence="light"))
    worst_mm: dict[bool, list[float]] = {True: [], False: []}
    for seed in range(4):
        for lead in (True, False):
            config = UavConfig(
                "template", "brick", (0.0, 0.0, 0.0), **({} if lead else {"release_lead_s": 0.0})
            )
            report = simulate(bp, seed=seed, faults=wind, uav_config=config)
            assert report.completed, (seed, lead)
            worst_mm[lead].append(round(max(report.placement_error_m.values()) * 1000.0, 1))
    print(worst_mm)
    assert all(a <= b for a, b in zip(worst_mm[True], worst_mm[False], strict=True)), worst_mm
    assert sum(worst_mm[True]) < sum(worst_mm[False]), worst_mm


def test_a_tick_below_the_drop_off_needs_no_margin_on_the_mean() -> None:
    # issue 29, the real PX4 (branch px4flaky31): within 1 cm horizontally, 2 cm below the drop-off (pressing the
    # brick onto its support), the window's mean 1 cm above with its +-4 cm wander: two standard errors put it past
    # r_pl, so the margin refused it (and the descent failed); the mean alone is within r_pl, the tick below it
    def window(final_dz_m: float) -> tuple[bool, HoverNoise]:
        reach, seen = DropoffReach(3.0), HoverNoise(3.0)
        for i in range(40):
            t = i * 0.1
            dz = 0.01 + 0.04 * math.sin(2.0 * math.pi * t / 1.7)
            seen.add(t, (dz, 0.0), (0.0, 0.0))
            assert not reach.reached(t, (0.05, 0.0, dz), dz, R_PL)  # 5 cm off horizontally: no release
        seen.add(4.0, (final_dz_m, 0.0), (0.0, 0.0))
        return reach.reached(4.0, (0.005, 0.0, final_dz_m), final_dz_m, R_PL), seen

    below, seen = window(-0.02)
    assert seen.mean_m[0] <= R_PL < seen.mean_m[0] + 2.0 * seen.standard_error_m  # the margin's refusal
    assert below
    above, _ = window(0.025)  # the same window, the tick 2.5 cm above: in the air, the margin stands
    assert not above


def _held_run(
    reach: DropoffReach, heights: Callable[[float], float], *, end_s: float = 0.0, brick_m: float = 0.10
) -> list[float]:
    """The times (s) at which ``heights`` (time s -> height above the reference, m; 10 Hz over 4 s past the
    descent's end at ``end_s``) count as held, the effector 5 mm off horizontally (the height judged alone)."""
    out = []
    for i in range(41):
        t = end_s + i * 0.1
        dz = heights(t)
        held = reach.held(t, t - end_s, dz, R_PL, brick_m)
        if reach.reached(t, (0.003, -0.004, dz), dz, R_PL, held):
            out.append(t)
    return out


def test_a_brick_held_on_the_ground_above_its_target_is_reached() -> None:
    # issue 30 (px4 rotated bond in 4 m/s, seed 8, B4): the wall's first brick, its target the GNSS's, 4-7 cm under
    # the ground; set down, the UAV is held up there and its height about the reference drifts with the wander
    # (up to 2-3 cm/s): the window's mean never comes within r_pl, the held rule lets go once it has lasted a second
    for seed in range(5):
        rng = random.Random(seed)
        drift = rng.uniform(-0.02, 0.02)
        times = _held_run(DropoffReach(3.0), lambda t, d=drift, r=rng: 0.06 + d * t + r.gauss(0.0, 0.0015))
        assert times, seed
        assert HELD_WINDOW_S <= times[0] <= HELD_WINDOW_S + 0.15, seed
        # without the rule: never (the mean is the held height)
        assert not _held_run(DropoffReach(3.0), lambda t, d=drift: 0.06 + d * t, brick_m=0.0), seed


def test_a_hover_swinging_above_its_reference_is_not_held() -> None:
    # in the air the hover swings about its reference by centimetres within a second (the px4 model's 4-5 cm over
    # its ~2 s period): never on a straight line for a second, though every tick may be above r_pl
    for seed in range(5):
        rng = random.Random(seed)
        times = _held_run(
            DropoffReach(3.0),
            lambda t, s=seed, r=rng: (
                0.045 + 0.025 * math.sin(2.0 * math.pi * t / 1.9 + s) + r.gauss(0.0, 0.0015)
            ),
        )
        assert not times, seed


def test_held_is_counted_only_a_window_past_the_end_and_under_a_brick() -> None:
    reach = DropoffReach(3.0)
    # the first second past the end: not yet (the descent's own lag is in it)
    assert not any(reach.held(t * 0.1, t * 0.1, 0.05, R_PL, 0.10) for t in range(10))
    assert reach.held(1.0, 1.0, 0.05, R_PL, 0.10)
    reach.reset()
    # held more than a brick's height up: resting on something else, not the ground under its drop-off
    assert not any(reach.held(t * 0.1, t * 0.1, 0.12, R_PL, 0.10) for t in range(20))
    reach.reset()
    # level with the drop-off (the window's mean decides there), never held
    assert not any(reach.held(t * 0.1, t * 0.1, 0.01, R_PL, 0.10) for t in range(20))
