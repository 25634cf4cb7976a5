"""The wall's offset carried past the last sighting (issue 30, masonry.fsm.wall_trend): under the GNSS wander the
drop-off follows the offset's trend through the frames missed and the last leg."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np

from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.fsm.wall_align import WallAlign
from masonry.fsm.wall_trend import MAX_SHIFT_M, MIN_FRAMES, SHIFT_M, WallTrend

RATE = np.array([0.02, -0.01, 0.0])  # the wander's rate (m/s): 20 mm/s east, 10 mm/s south


def _fed(trend: WallTrend, t0_s: float, t1_s: float, key: frozenset[int] = frozenset({3})) -> None:
    """Frames every 0.1 s from t0_s to t1_s of an offset moving at RATE."""
    for t in np.arange(t0_s, t1_s + 1e-9, 0.1):
        trend.add(float(t), np.array([0.05, 0.02, 0.0]) + RATE * t, key)


def test_the_target_follows_the_offsets_trend_past_the_last_frame() -> None:
    trend = WallTrend(1.5)
    trend.reset(5)
    _fed(trend, 0.0, 2.0)  # the last frame at 2.0 s; the mean of the last five is of 1.8 s
    rate = trend.rate_mps(2.0)
    assert rate is not None and np.allclose(rate, RATE, atol=1e-9)
    # the support out of view for 0.4 s: the target moves on by the rate times the mean's age (0.6 s)
    delta = trend.step(2.4)
    assert delta is not None and np.allclose(delta, RATE * 0.6, atol=1e-9)
    # a tick later, only what has moved since
    step = trend.step(2.5)
    assert step is not None and np.allclose(step, RATE * 0.1, atol=1e-9)
    assert np.allclose(trend.shift_m, RATE * 0.7, atol=1e-9)


def test_no_trend_no_move() -> None:
    """A steady offset with the camera's noise (a position source without wander) leaves the target within the
    deadband: nothing moves."""
    rng = np.random.default_rng(7)
    trend = WallTrend(1.5)
    trend.reset(5)
    for t in np.arange(0.0, 2.0, 0.1):
        trend.add(float(t), np.array([0.05, 0.02, 0.0]) + rng.normal(0.0, 0.0005, 3), frozenset({3}))
    assert trend.step(2.3) is None
    assert float(np.linalg.norm(trend.shift_m)) == 0.0
    assert SHIFT_M > 0.0


def test_too_few_frames_or_a_new_set_of_references_no_trend() -> None:
    trend = WallTrend(1.5)
    trend.reset(5)
    _fed(trend, 0.0, 0.1 * (MIN_FRAMES - 2))
    assert trend.rate_mps(0.8) is None and trend.step(1.0) is None
    _fed(trend, 0.8, 2.0)
    assert trend.rate_mps(2.0) is not None
    # another brick comes into view: its mean is another line, the old frames no longer count
    _fed(trend, 2.1, 2.3, key=frozenset({3, 4}))
    assert trend.rate_mps(2.3) is None


def test_the_shift_is_capped_and_off_with_no_span() -> None:
    trend = WallTrend(1.5)
    trend.reset(5)
    for t in np.arange(0.0, 2.01, 0.1):
        trend.add(float(t), np.array([0.1, 0.0, 0.0]) * t, frozenset({3}))  # 10 cm/s
    delta = trend.step(2.4)  # the line says 6 cm since the mean
    assert delta is not None and np.isclose(float(np.linalg.norm(delta)), MAX_SHIFT_M)
    off = WallTrend(0.0)
    off.reset(5)
    _fed(off, 0.0, 2.0)
    assert off.rate_mps(2.0) is None and off.step(2.5) is None


def test_a_wall_long_out_of_view_is_not_extrapolated() -> None:
    """Out of view for over 0.4 of the span, too few of the span's frames are left to carry the line on: the
    shift goes back to none, the last mean stands (a stale release after the looks, masonry.fsm.release_gate)."""
    trend = WallTrend(1.5)
    trend.reset(5)
    _fed(trend, 0.0, 2.0)
    assert trend.step(2.5) is not None
    delta = trend.step(2.0 + 0.7)
    assert delta is not None and np.allclose(trend.shift_m, 0.0)


def test_on_with_the_wall_alignment_only() -> None:
    """The default is on (1.5 s), but it acts only where the wall alignment does: the px4 preset."""
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wall_trend_s == 1.5
    assert uav_settings("px4")["align_on_wall"] is True
    assert "align_on_wall" not in uav_settings("arducopter")
    assert uav_settings("px4", {"wall_trend_s": 0})["wall_trend_s"] == 0.0


class _Nav:
    def __init__(self) -> None:
        self.shifted_m = np.zeros(3)

    def shift(self, delta_m: tuple[float, float, float]) -> None:
        self.shifted_m = self.shifted_m + np.asarray(delta_m)


def _uav(align_on_wall: bool, now_s: float) -> SimpleNamespace:
    config = UavConfig("b", "brick", (0.0, 0.0, 0.0), align_on_wall=align_on_wall)
    attempt = SimpleNamespace(place_effector_target_m=np.array([1.0, 2.0, 0.2]))
    return SimpleNamespace(config=config, on_wall=align_on_wall, _now_s=now_s, nav=_Nav(), attempt=attempt)


def test_the_descent_carries_the_drop_off_and_its_motion_along_the_trend() -> None:
    """WallAlign.carry (each tick of place_descend) moves the navigator's leg and the release's target together,
    with the wall alignment on; without it, nothing (the ideal and arducopter presets fly as before)."""
    for on in (True, False):
        wall = WallAlign()
        wall.reset(np.array([1.0, 2.0, 0.2]))
        wall.trend.span_s = UavConfig("b", "brick", (0.0, 0.0, 0.0)).wall_trend_s
        _fed(wall.trend, 0.0, 2.0)
        uav = _uav(on, 2.4)
        wall.carry(uav)  # type: ignore[arg-type]
        moved = RATE * 0.6 if on else np.zeros(3)
        assert np.allclose(uav.nav.shifted_m, moved, atol=1e-9)
        assert np.allclose(uav.attempt.place_effector_target_m, np.array([1.0, 2.0, 0.2]) + moved, atol=1e-9)
