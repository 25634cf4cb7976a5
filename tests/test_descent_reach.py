"""The spray descent's arrival on a noisy position source (issue 29, masonry.fsm.descent_reach)."""

from __future__ import annotations

import dataclasses
import math
import random

from fsm_rig import Rig
from masonry.fakes import FakeFlightController
from masonry.fsm.descent_reach import DescentReach
from masonry.fsm.tuning import uav_settings
from masonry.ports import Telemetry

TOLERANCE_M = 0.03  # the px4 preset's spray_tolerance_m (the valve's radius)
PATIENCE_S = 4.0  # the px4 preset's align_patience_s: the tolerances double after it
GIVE_UP_S = 8.0  # max(release_timeout_s, 2 x align_patience_s): the descent fails this long after its end


def _swing(t_s: float, phase: float) -> tuple[float, float, float]:
    """PX4 v1.16 SITL's hover at the bottom of the descent (recorded: 5.5 cm rms sideways, a ~2 s oscillation, a
    1.8 cm mean offset; 2.7 cm rms vertically), scripted: a 6 cm orbit about a point 2 cm off the target, the
    height swinging by 3.5 cm; the body never comes within 3 cm of the target."""
    w = 2.0 * math.pi * t_s / 2.0 + phase
    return (0.02 + 0.06 * math.cos(w), 0.06 * math.sin(w), 0.035 * math.sin(1.3 * w))


def _single_tick(late_s: float, error_m: tuple[float, float, float]) -> bool:
    """The old gate: one tick within 1.5 cm in three dimensions, 3 cm after the patience."""
    return math.dist(error_m, (0.0, 0.0, 0.0)) <= 0.015 * (2.0 if late_s > PATIENCE_S else 1.0)


def _hover(reach: DescentReach, seed: int, centre_m=(0.0, 0.0, 0.0)):
    """10 Hz ticks of the hover after the descent's planned end (the reference at the target), its window filled
    by the 6 s before; yields (time after the end, the tick's error, the new gate)."""
    rng = random.Random(seed)
    phase = rng.uniform(0.0, 2.0 * math.pi)
    for i in range(-60, int(GIVE_UP_S * 10) + 1):
        t = i * 0.1
        error = tuple(c + s + rng.gauss(0.0, 0.003) for c, s in zip(centre_m, _swing(t, phase), strict=True))
        reach.add(t, error)
        if t >= 0.0:
            yield t, error, reach.reached((0.0, 0.0, 0.0), TOLERANCE_M * (2.0 if t > PATIENCE_S else 1.0))


def test_a_noisy_hover_at_the_spraying_point_arrives_where_the_single_tick_gate_gives_up() -> None:
    for seed in range(6):
        ticks = list(_hover(DescentReach(3.0), seed))
        assert not any(_single_tick(t, e) for t, e, _ in ticks), seed  # 8 s without one tick within reach
        arrived = [t for t, _, ok in ticks if ok]
        assert arrived and arrived[0] <= 2.0, seed  # its window was seen during the descent


def test_a_hover_centred_off_the_spraying_point_does_not_arrive_on_ticks_that_swing_near_it() -> None:
    for seed in range(6):
        # centred 5 cm off (past the valve's radius), the swing passes within 3 cm of the point
        ticks = list(_hover(DescentReach(3.0), seed, centre_m=(-0.07, 0.0, 0.0)))
        before = [(t, e, ok) for t, e, ok in ticks if t <= PATIENCE_S]
        assert any(math.dist(e, (0.0, 0.0, 0.0)) <= TOLERANCE_M for _, e, _ in before), seed  # a tick would
        assert not any(ok for _, _, ok in before), seed


def test_the_descent_itself_is_not_spread_the_window_averages_about_its_reference() -> None:
    reach = DescentReach(3.0)
    first = None
    for i in range(
        90
    ):  # a 7 s descent of 0.5 m (minimum jerk), the body 1 cm behind its reference, 2 s after
        t = i * 0.1
        s = min(1.0, t / 7.0)
        ref_dz = 0.5 * (1.0 - (10 * s**3 - 15 * s**4 + 6 * s**5))
        reach.add(t, (0.0, 0.0, 0.01))
        if first is None and reach.reached((0.0, 0.0, ref_dz), 0.015):
            first = t
    assert first is not None and 6.0 < first <= 7.0  # once the reference is near its end, not a window later
    reach.reset()
    reach.add(0.0, (0.0, 0.0, 0.0))
    assert reach.mean_error_m((0.0, 0.0, 0.0)) is None  # a new descent: a window first


def test_a_chained_segments_short_descent_is_judged_on_what_it_saw_not_held_for_a_window() -> None:
    reach = DescentReach(3.0)
    reach.reset(0.5)  # chain_descent_s: the UAV is at the spraying height already
    for i in range(6):
        reach.add(i * 0.1, (0.01, -0.005, 0.004))
    assert reach.reached((0.0, 0.0, 0.0), TOLERANCE_M)  # at its end, 0.5 s seen
    reach.reset(4.0)  # a full descent: a whole window first
    for i in range(6):
        reach.add(i * 0.1, (0.01, -0.005, 0.004))
    assert not reach.reached((0.0, 0.0, 0.0), TOLERANCE_M)


class _SwingingFc(FakeFlightController):
    """The fake autopilot, its reported position swinging as PX4 v1.16 SITL's does (:func:`_swing`) while
    ``swinging``."""

    swinging = False

    def telemetry(self) -> Telemetry:
        tel = super().telemetry()
        if not self.swinging:
            return tel
        dx, dy, dz = _swing(tel.time_s, 0.7)
        x, y, z = tel.position_m
        return dataclasses.replace(tel, position_m=(x + dx, y + dy, z + dz))


def _glue_swinging_in_its_descent(preset: str) -> Rig:
    """Task A0 on the fake autopilot, its position swinging in the spray descent (only there: the hover before is
    another gate's)."""
    rig = Rig("adhesion", config=dict(uav_settings(preset)))
    fc = _SwingingFc(rig.clock, position_m=rig.fc.position_m)
    rig.fc = rig.uav.fc = fc

    def swing(r: Rig) -> None:
        fc.swinging = r.uav.state == "descend"

    return rig.run(max_s=300.0, on_tick=swing)


def test_the_px4_preset_sprays_a0_through_a_swinging_descent() -> None:
    rig = _glue_swinging_in_its_descent("px4")
    result = rig.link.results[0]
    assert result.status == "done", result
    assert result.coverage >= 0.9
    assert rig.followed("descend", "spray")


def test_the_single_tick_gate_gives_up_on_the_same_swing() -> None:
    # the default preset (motion capture: no window) keeps the paper's single tick, which this swing never meets
    rig = _glue_swinging_in_its_descent("ideal")
    result = rig.link.results[0]
    assert result.status == "failed" and "spraying height" in (result.reason or ""), result


def test_a_spray_descent_not_reached_by_its_timeout_is_flown_again_before_the_attempt_fails() -> None:
    # the default preset's single tick never meets the swing: the first descent times out; the second, from where
    # the UAV is, swings no more (EKF2's height running off for seconds, then settling) and sprays: the task is done
    # in the same attempt (issue 29: a failed attempt costs a mission a flight away and back)
    rig = Rig("adhesion", config=dict(uav_settings("ideal")))
    fc = _SwingingFc(rig.clock, position_m=rig.fc.position_m)
    rig.fc = rig.uav.fc = fc
    descents: list[int] = []

    def swing(r: Rig) -> None:
        first = r.uav.state == "descend" and r.uav.attempt.spray_descents == 0
        fc.swinging = first
        if r.uav.state == "descend" and r.uav.attempt.spray_descents not in descents:
            descents.append(r.uav.attempt.spray_descents)

    rig.run(max_s=300.0, on_tick=swing)
    result = rig.link.results[0]
    assert result.status == "done", result
    assert descents == [0, 1]
    assert rig.followed("descend", "spray")


def test_the_spray_descents_give_up_after_max_spray_descents_with_the_count_said() -> None:
    rig = _glue_swinging_in_its_descent("ideal")
    result = rig.link.results[0]
    assert result.status == "failed", result
    assert result.reason is not None and result.reason.endswith("after 2 descents"), result
