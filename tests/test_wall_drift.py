"""The wall's offset as a drifting state (issue 30, masonry.fsm.wall_drift): a Kalman filter on the GNSS wander
predicts the offset past the last sighting better than the straight line, on the px4 model's own wander."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from masonry.fsm.config import UavConfig
from masonry.fsm.tuning import uav_settings
from masonry.fsm.wall_drift import FRAME_NOISE_M, DriftFilter
from masonry.fsm.wall_trend import MIN_FRAMES, WallTrend
from masonry.sim.shaping import PX4

#: the px4 model's rate noise (m/s per sqrt s): sigma * sqrt(2 / tau) / smoothing
PX4_DRIFT = PX4.gps_noise_m * math.sqrt(2.0 / PX4.gps_noise_tau_s) / PX4.gps_noise_smooth_s


def _wander(seed: int, duration_s: float, dt_s: float = 0.02) -> np.ndarray:
    """The px4 model's GNSS wander (horizontal), as masonry.sim.shaping.Shaper.drift moves it: rows (x, y)."""
    rng = np.random.default_rng(seed)
    a = dt_s / PX4.gps_noise_tau_s
    b = PX4.gps_noise_m * math.sqrt(2.0 * a)
    k = dt_s / PX4.gps_noise_smooth_s
    raw, out = rng.normal(0.0, PX4.gps_noise_m, 2), np.zeros(2)
    out[:] = raw
    rows = []
    for _ in range(int(duration_s / dt_s)):
        raw += -raw * a + b * rng.normal(size=2)
        out += k * (raw - out)
        rows.append(out.copy())
    return np.array(rows)


def test_the_px4_preset_derives_its_rate_noise_from_the_models_wander() -> None:
    assert math.isclose(PX4_DRIFT, 0.015)
    assert uav_settings("px4")["wall_drift_mps_per_sqrt_s"] == pytest.approx(PX4_DRIFT)
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wall_drift_tau_s == PX4.gps_noise_smooth_s
    for other in ("ideal", "arducopter"):  # the straight line as before
        assert uav_settings(other).get("wall_drift_mps_per_sqrt_s", 0.0) == 0.0
    assert UavConfig("b", "brick", (0.0, 0.0, 0.0)).wall_drift_mps_per_sqrt_s == 0.0


def test_it_predicts_the_px4_wander_past_the_last_frame_better_than_the_line() -> None:
    """Frames at 10 Hz of the model's wander plus the camera's white noise; from 2 s of them, the offset 0.4 s
    past the last: the filter's error against the straight line's (WallTrend without the filter; 6.9 against
    8.3 mm rms), over 200
    cuts of two seeded wanders."""
    rng = np.random.default_rng(3)
    errors: dict[str, list[float]] = {"drift": [], "line": []}
    for seed in (1, 2):
        wander = _wander(seed, 420.0)  # 0.02 s a row
        for start in range(0, len(wander) - 200, 200):
            trends = {"drift": WallTrend(1.5), "line": WallTrend(1.5)}
            trends["drift"].drift_mps_per_sqrt_s = PX4_DRIFT
            for trend in trends.values():
                trend.reset(5)
            frames = []
            for row in range(start, start + 100, 5):  # 2 s of frames
                frames.append(wander[row] + rng.normal(0.0, FRAME_NOISE_M, 2))
                for trend in trends.values():
                    trend.add(row * 0.02, np.array([*frames[-1], 0.0]), frozenset({3}))
            last = start + 95
            truth = wander[last + 20]  # 0.4 s on
            mean = np.mean(frames[-5:], axis=0)  # the wall alignment's target: the last five frames' mean
            for name, trend in trends.items():
                trend.step((last + 20) * 0.02)
                err = mean + trend.shift_m[:2] - truth
                errors[name].append(float(np.hypot(*err)))
    rms = {name: math.sqrt(float(np.mean(np.square(v)))) for name, v in errors.items()}
    assert rms["drift"] < 0.9 * rms["line"], rms


def test_a_steady_rate_is_learnt_and_a_steady_offset_stays() -> None:
    filt = DriftFilter(PX4_DRIFT, 2.0)
    for t in np.arange(0.0, 3.0, 0.1):
        filt.add(float(t), np.array([0.05 + 0.02 * t, -0.01 * t, 0.7]))
    t_last = 2.9
    want = np.array([0.05 + 0.02 * t_last, -0.01 * t_last]) + np.array([0.02, -0.01]) * 2.0 * (
        1.0 - math.exp(-0.4 / 2.0)
    )
    assert np.allclose(filt.predict_m(t_last + 0.4), want, atol=0.002)
    still = DriftFilter(PX4_DRIFT, 2.0)
    for t in np.arange(0.0, 2.0, 0.1):
        still.add(float(t), np.array([0.05, 0.02, 0.0]))
    assert np.allclose(still.predict_m(3.0), [0.05, 0.02], atol=1e-9)


@settings(max_examples=50, deadline=None, derandomize=True)
@given(
    st.lists(
        st.tuples(
            st.floats(0.01, 0.5), st.floats(-0.3, 0.3), st.floats(-0.3, 0.3)
        ),  # (gap to the frame, x, y)
        min_size=1,
        max_size=40,
    ),
    st.floats(0.0, 3.0),
)
def test_nothing_nan_and_a_bounded_step(frames: list[tuple[float, float, float]], ahead_s: float) -> None:
    filt = DriftFilter(PX4_DRIFT, 2.0)
    t = 0.0
    for gap, x, y in frames:
        t += gap
        filt.add(t, np.array([x, y, 0.0]))
    p = filt.predict_m(t + ahead_s)
    assert np.all(np.isfinite(p)), frames
    # the rate's reach is bounded by its relaxation: no farther than the frames' spread allows, with room
    assert float(np.max(np.abs(p))) < 10.0, frames


def test_the_trend_starts_over_on_a_new_set_of_references_and_is_off_with_no_span() -> None:
    trend = WallTrend(1.5)
    trend.drift_mps_per_sqrt_s = PX4_DRIFT
    trend.reset(5)
    for t in np.arange(0.0, 2.0, 0.1):
        trend.add(float(t), np.array([0.05 + 0.03 * t, 0.0, 0.0]), frozenset({3}))
    assert trend.step(2.3) is not None
    for t in 2.0 + 0.1 * np.arange(MIN_FRAMES - 1):  # another brick in view: too few frames yet
        trend.add(float(t), np.array([0.05 + 0.03 * t, 0.0, 0.0]), frozenset({3, 4}))
    trend.step(2.8)
    assert np.allclose(trend.shift_m, 0.0)
    off = WallTrend(0.0)
    off.drift_mps_per_sqrt_s = PX4_DRIFT
    off.reset(5)
    for t in np.arange(0.0, 2.0, 0.1):
        off.add(float(t), np.array([0.03 * t, 0.0, 0.0]), frozenset({3}))
    assert off.step(2.5) is None


def test_bad_settings_are_refused() -> None:
    for args in ((0.0, 2.0), (0.015, 0.0), (0.015, 2.0, 0.0)):
        with pytest.raises(ValueError):
            DriftFilter(*args)
