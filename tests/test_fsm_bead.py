"""The nozzle-measured spray pass (masonry.fsm.bead): reference, valve, coverage, passes."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, seed, settings
from hypothesis import strategies as st

from masonry.fsm.bead import BeadPass, BeadSettings

A = (0.0, 0.0, 0.2)
B = (0.3, 0.0, 0.2)
DT = 0.1


def _follow(bead: BeadPass, offset_m=lambda t: (0.0, 0.0), lag_ticks: int = 0, max_ticks: int = 400):
    """Fly a nozzle that sits on the reference (``lag_ticks`` late, plus ``offset_m(t)``) until a pass ends."""
    refs = [bead.point_m(0.0)]
    for i in range(max_ticks):
        ref = refs[max(0, len(refs) - 1 - lag_ticks)]
        dx, dy = offset_m(i * DT)
        step = bead.step(DT, (ref[0] + dx, ref[1] + dy, ref[2] + 0.1), in_reach=True)
        refs.append(np.array(step.nozzle_ref_m))
        if step.pass_over:
            return i + 1, step
    raise AssertionError("the pass never ended")


def test_a_nozzle_on_the_reference_covers_the_segment_in_one_pass_at_the_spray_speed() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15))
    ticks, step = _follow(bead)
    assert bead.coverage() == 1.0 and bead.passes == 1
    assert ticks == pytest.approx(0.3 / 0.15 / DT, abs=2)  # 2 s, as the old constant-speed line
    assert step.nozzle_ref_m == pytest.approx(B)


def test_the_reference_moves_at_the_spray_speed_with_its_velocity_feed_forward() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15))
    step = bead.step(DT, A, in_reach=True)
    assert bead.progress_m == pytest.approx(0.015)
    assert step.velocity_mps == pytest.approx((0.15, 0.0, 0.0))
    assert step.valve_open


def test_the_valve_closes_off_the_bead_and_out_of_reach() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15, valve_radius_m=0.03))
    assert bead.step(DT, (0.1, 0.025, 0.3), in_reach=True).valve_open
    assert not bead.step(DT, (0.1, 0.035, 0.3), in_reach=True).valve_open
    assert not bead.step(DT, (0.1, 0.0, 0.5), in_reach=False).valve_open
    assert not bead.step(DT, (0.4, 0.0, 0.3), in_reach=True).valve_open  # past the end
    assert bead.coverage() < 0.2  # only what it passed over with the valve open


def test_the_reference_waits_for_a_nozzle_held_back() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15, lead_m=0.05))
    for _ in range(20):
        bead.step(DT, (0.0, 0.0, 0.3), in_reach=True)  # a head gust holds the nozzle at the start
    assert bead.progress_m == pytest.approx(0.05, abs=0.016)


def test_a_gust_that_pushes_the_nozzle_off_leaves_a_gap_that_the_next_pass_goes_back_over() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15))
    # pushed 6 cm sideways for 0.5 s in the middle of the first pass
    _, _ = _follow(bead, offset_m=lambda t: (0.0, 0.06) if 0.8 <= t < 1.3 else (0.0, 0.0))
    assert bead.passes == 1 and 0.6 < bead.coverage() < 0.85
    assert bead.gaps_ahead() is False
    bead.turn()
    assert bead.direction == -1 and bead.gaps_ahead()
    start_m = bead.progress_m
    refs = [bead.point_m(start_m)]
    for _ in range(400):
        ref = refs[-1]
        step = bead.step(DT, (ref[0], ref[1], ref[2] + 0.1), in_reach=True)
        refs.append(np.array(step.nozzle_ref_m))
        if step.pass_over:
            break
    assert bead.coverage() == 1.0
    # the second pass ended past the gap, not at the start of the segment
    assert 0.0 < bead.progress_m < start_m


def test_a_pass_ends_when_the_nozzle_is_carried_past_the_end() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15))
    for _ in range(30):
        bead.step(DT, (bead.progress_m, 0.05, 0.3), in_reach=True)  # off the bead all along
    step = bead.step(DT, (0.34, 0.0, 0.3), in_reach=True)  # the reference at its end, the nozzle beyond it
    assert step.pass_over and bead.coverage() < 0.2


def test_a_pass_held_at_its_end_is_over_after_end_wait() -> None:
    bead = BeadPass(A, B, BeadSettings(speed_mps=0.15, end_wait_s=1.0, lead_m=1.0))
    overs = [bead.step(DT, (0.28, 0.05, 0.3), in_reach=True).pass_over for _ in range(40)]
    # 2 s to reach the end, then 1 s there
    assert not any(overs[:25]) and overs[-1]


@seed(18)
@settings(max_examples=60, deadline=None)
@given(
    st.floats(0.05, 2.0),
    st.floats(-math.pi, math.pi),
    st.floats(0.02, 0.15),
    st.floats(0.0, 0.013),
)
def test_any_segment_flown_on_its_reference_is_covered(
    length_m: float, heading_rad: float, speed_mps: float, across_m: float
) -> None:
    # (the valve's first tick is not counted: the start is covered from a tick's travel on, 1.5 cm at most, and
    # across_m: both within the 2 cm check radius)
    b = (length_m * math.cos(heading_rad), length_m * math.sin(heading_rad), 0.35)
    bead = BeadPass((0.0, 0.0, 0.35), b, BeadSettings(speed_mps=speed_mps))
    n = (-math.sin(heading_rad) * across_m, math.cos(heading_rad) * across_m)
    ticks, _ = _follow(bead, offset_m=lambda t: n, max_ticks=10_000)
    assert bead.coverage() == 1.0 and bead.passes == 1
    assert ticks <= math.ceil(length_m / speed_mps / DT) + 2
    assert all(math.isfinite(v) for v in bead.point_m(bead.progress_m))
