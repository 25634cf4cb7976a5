"""The wall alignment's target is the mean of recent frames only (issue 30, branch gust34): a neighbour that drops
in and out of view leaves its last five frames seconds apart, and their mean holds the wander of those seconds
(masonry.fsm.wall_align.frames_span_s, CameraAlign.span_s, WallTrend.mean_span_s)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.fsm.camera_align import CameraAlign
from masonry.fsm.wall_align import frames_span_s
from masonry.fsm.wall_trend import WallTrend

RATE = np.array([0.0, -0.025, 0.0])  # the GNSS wander's rate (m/s) in the traced gusts: 25 mm/s


def test_a_fresh_frame_after_a_gap_is_not_averaged_with_frames_seconds_old() -> None:
    """Rotated bond in 4 m/s, seed 0, B0: three frames at 1.5-1.7 s, the neighbour out of view for 2 s, one frame
    at 3.7 s. The mean of the last five put the target 18 mm behind the wander; within the span, it follows it."""
    span = CameraAlign(span_s=frames_span_s(0.45))
    every = CameraAlign()  # the last five whatever their age (as before)
    for tracker in (span, every):
        tracker.reset(np.zeros(3))
        for t in (1.5, 1.6, 1.7, 3.7):
            tracker.add(RATE * t, t)
    assert span.center_m is not None and every.center_m is not None
    assert np.allclose(span.center_m, RATE * 3.7, atol=1e-12)
    assert span.times_s == (3.7,)
    assert float(np.linalg.norm(every.center_m - RATE * 3.7)) > 0.035


@settings(max_examples=50, deadline=None)
@given(st.lists(st.floats(min_value=0.05, max_value=3.0), min_size=1, max_size=30))
def test_the_mean_is_over_frames_within_the_span_of_the_newest(gaps_s: list[float]) -> None:
    tracker = CameraAlign(span_s=0.45)
    tracker.reset(np.zeros(3))
    t = 0.0
    for gap in gaps_s:
        t += gap
        tracker.add(np.array([t, 0.0, 0.0]), t)
        times = tracker.times_s
        assert times[-1] == t and all(t - s <= 0.45 for s in times) and len(times) <= tracker.size


def test_without_a_span_the_last_five_as_before() -> None:
    tracker = CameraAlign()
    tracker.reset(np.zeros(3))
    assert tracker.add(np.array([0.1, 0.0, 0.0])) is None  # fewer than min_estimates: no move
    assert tracker.add(np.array([0.1, 0.0, 0.0])) is None
    delta = tracker.add(np.array([0.1, 0.0, 0.0]))
    assert delta is not None and np.allclose(delta, [0.1, 0.0, 0.0])
    for _ in range(10):
        tracker.add(np.array([0.2, 0.0, 0.0]))
    assert np.allclose(tracker.center_m, [0.2, 0.0, 0.0])
    assert frames_span_s(0.0) == math.inf


def test_the_trend_carries_the_same_frames_mean() -> None:
    """WallTrend's mean (what the target is, before the trend's shift) leaves out the same frames."""
    trend = WallTrend(1.5)
    trend.reset(5)
    trend.mean_span_s = 0.45
    for t in (1.5, 1.6, 1.7, 3.7):
        trend.add(t, RATE * t, frozenset({1}))
    assert list(trend._mean_times) == [3.7]
    assert np.allclose(trend._mean_offsets[0], RATE * 3.7)
