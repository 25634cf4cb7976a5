"""The first hover's identification (issue 29): the gains it derives stay stable, unusable data falls back to the
preset with a reason, the simulated vehicles identify and fly, and the user's preset or gains win."""

from __future__ import annotations

import json
import logging
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from typer.testing import CliRunner

from masonry.adapters.wiring import hardware_config
from masonry.cli import app
from masonry.errors import InputError
from masonry.fsm.first_hover import DURATION_S, EXCURSION_LIMIT_M, fit_lag, reference
from masonry.fsm.hover_gains import (
    KP_MAX_PER_S,
    KP_MIN_PER_S,
    LAG_MAX_S,
    LAG_MIN_S,
    STABLE_FRACTION_MAX,
    HoverFit,
    derive_gains,
    stability_limit_kp,
)
from masonry.fsm.tuning_choice import choose_tuning
from masonry.separation import TRACK_SHARE_M
from test_hw_mission import fly_one_brick_mission

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()


def _fit(**kw: float) -> HoverFit:
    base = {"lag_s": 0.57, "delay_s": 0.2, "gain": 1.0, "fit": 0.9, "hover_noise_mps": 0.03,
            "excursion_m": 0.1, "excursion_limit_m": EXCURSION_LIMIT_M}  # fmt: skip
    return HoverFit(**{**base, **kw})


@given(
    lag=st.floats(min_value=0.0, max_value=LAG_MAX_S),
    fit=st.floats(min_value=0.5, max_value=1.0),
    gain=st.floats(min_value=0.5, max_value=1.5),
)
def test_any_measured_lag_in_range_gives_gains_within_the_stable_limits(
    lag: float, fit: float, gain: float
) -> None:
    tuning = derive_gains(_fit(lag_s=lag, fit=fit, gain=gain))
    assert tuning.kp is not None and tuning.ki is not None and tuning.lag_s is not None
    assert KP_MIN_PER_S <= tuning.kp <= KP_MAX_PER_S
    # never over half the proportional loop's stability limit at the lag the UAV flies with
    assert tuning.kp <= STABLE_FRACTION_MAX * stability_limit_kp(max(LAG_MIN_S, lag)) + 0.005
    assert tuning.ki == pytest.approx(0.2 * tuning.kp, abs=1e-3)
    assert LAG_MIN_S <= tuning.lag_s <= LAG_MAX_S


def test_the_arducopter_lag_gives_about_the_arducopter_preset() -> None:
    tuning = derive_gains(_fit(lag_s=0.57))
    assert (tuning.kp, tuning.ki) == (0.92, 0.184)
    assert tuning.line() == (
        "identified on first hover: lag 0.57 s (fit 90%, 10 cm off the hover at most) -> kp 0.92 /s, ki 0.184 /s^2"
    )


@pytest.mark.parametrize(
    ("changed", "why"),
    [
        ({"fit": 0.3}, "a lag model explains 30% of the measured velocity: too noisy"),
        ({"lag_s": 2.2}, "lag 2.20 s: too slow (over 1.5 s)"),
        ({"excursion_m": 0.41}, "blown 0.41 m off its hover, over 0.30 m: wind?"),
        ({"hover_noise_mps": 0.4}, "the hover swings at 0.40 m/s rms: too noisy (wind?)"),
        ({"gain": 0.2}, "it flew 0.20 of the commanded speed: not following"),
        ({"lag_s": math.nan}, "no measurement"),
    ],
)
def test_unusable_data_falls_back_to_the_preset_with_the_reason(changed: dict[str, float], why: str) -> None:
    tuning = derive_gains(_fit(**changed))
    assert not tuning.usable and tuning.kp is None
    assert tuning.reason == why
    assert tuning.line() == f"first hover's identification unusable ({why}): flies its preset's gains"


def test_the_excitation_stays_within_the_tracking_share_of_the_hovers_column() -> None:
    ts = np.arange(0.0, DURATION_S, 0.01)
    refs = [reference(float(t)) for t in ts]
    assert max(abs(p) for _, _, p in refs) <= TRACK_SHARE_M
    assert {a for a, _, _ in refs} == {-1, 0, 1}
    # each doublet comes back: the reference position integrates the reference velocity back to zero
    assert abs(sum(v for _, v, _ in refs) * 0.01) < 0.01


@pytest.mark.parametrize(("delay", "tau"), [(0.2, 0.37), (0.1, 0.2), (0.25, 0.35), (0.3, 0.9)])
def test_the_fit_finds_the_lag_of_a_delayed_first_order_response_in_a_noisy_hover(
    delay: float, tau: float
) -> None:
    """Within 0.1 s of a first-order lag behind a dead time sampled at 20 Hz with 2 cm/s of noise; a slow one
    (1.2 s: 8 cm doublets barely move it) reads slower still, never faster: lower gains, the stable side."""
    rng = np.random.default_rng(3)
    dt = 0.05
    samples = []
    v = 0.0
    history: list[tuple[float, float]] = []
    for t in np.arange(0.0, DURATION_S, dt):
        axis, v_ref, _ = reference(float(t))
        cmd = v_ref if axis >= 0 else 0.0
        history.append((float(t), cmd))
        late = [c for s, c in history if s <= t - delay + 1e-9]
        v += (dt / tau) * ((late[-1] if late else 0.0) - v)
        if axis >= 0:
            samples.append((float(t), axis, cmd, v + rng.normal(0.0, 0.02)))
    lag, _, gain, share = fit_lag(samples)
    if tau < 0.5:
        assert lag == pytest.approx(delay + tau, abs=0.1)
        assert gain == pytest.approx(1.0, abs=0.15)
        assert share > 0.7
    else:
        assert lag >= delay + tau - 0.1
    assert math.isnan(fit_lag(samples[:5])[0])  # too few: no measurement (derive_gains falls back)


def test_a_users_control_preset_or_pid_wins_over_identify() -> None:
    assert choose_tuning(None, autopilot="ardupilot", tuning="identify").identify
    assert choose_tuning(None, autopilot="px4", tuning="identify").detail() == (
        "control preset px4 (PX4 autopilot, from its HEARTBEAT); position gains identified on the first hover "
        "(`tuning: identify` of uav.yaml), the preset's if unusable"
    )
    preset = choose_tuning("arducopter", autopilot="ardupilot", tuning="identify")
    assert not preset.identify
    assert preset.detail() == (
        "control preset arducopter (`control_preset:` of uav.yaml); `control_preset:` of uav.yaml wins over "
        "`tuning: identify`"
    )
    gains = choose_tuning(None, autopilot="ardupilot", overrides=("pid",), tuning="identify")
    assert not gains.identify and "`pid:` of uav.yaml wins" in gains.detail()
    assert not choose_tuning(None, autopilot="ardupilot").identify  # the default: the preset's gains


def test_uav_yaml_tuning_is_checked() -> None:
    assert hardware_config({"fc": "sim"}, {"tuning": "identify"}).tuning == "identify"
    assert hardware_config({"fc": "sim"}).tuning == "preset"
    with pytest.raises(InputError, match="tuning must be preset or identify, not 'fast'"):
        hardware_config({"fc": "sim"}, {"tuning": "fast"})


def _fly(tmp_path: Path, vehicle: str, yaml: str, caplog: pytest.LogCaptureFixture) -> tuple[int, str, str]:
    """``masonry fly --sim`` of B0: exit code, output, and the log's lines (the machine's warnings)."""
    config = tmp_path / "uav.yaml"
    config.write_text(yaml)
    caplog.clear()
    with caplog.at_level(logging.WARNING, logger="masonry.fsm"):
        res = runner.invoke(app, ["fly", "--sim", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B0",
                                  "--vehicle", vehicle, "--config", str(config)])  # fmt: skip
    return res.exit_code, res.stdout, "\n".join(r.getMessage() for r in caplog.records)


@pytest.mark.parametrize(("vehicle", "lag_s"), [("arducopter", (0.5, 0.8)), ("px4", (0.25, 0.5))])
def test_the_simulated_vehicles_identify_on_the_first_hover_and_fly(
    tmp_path: Path, vehicle: str, lag_s: tuple[float, float], caplog: pytest.LogCaptureFixture
) -> None:
    code, out, err = _fly(tmp_path, vehicle, "tuning: identify\n", caplog)
    assert code == 0, out + err
    line = next(x for x in err.splitlines() if "first hover" in x)
    assert line.startswith("brick-1: identified on first hover: lag "), line
    lag = float(line.split("lag ")[1].split(" s")[0])
    assert lag_s[0] <= lag <= lag_s[1]
    kp = float(line.split("kp ")[1].split(" /s")[0])
    assert KP_MIN_PER_S <= kp <= STABLE_FRACTION_MAX * stability_limit_kp(lag)
    assert "B0: done" in out
    # the hover identifies before the first leg: the take-off lasts the schedule longer than the preset's
    code, plain, err = _fly(tmp_path, vehicle, "tuning: preset\n", caplog)
    assert code == 0 and "first hover" not in err
    takeoff = [_takeoff_s(text) for text in (out, plain)]
    assert takeoff[0] >= takeoff[1] + DURATION_S - 0.5


def _takeoff_s(trace: str) -> float:
    """Seconds in the take-off state, from ``masonry fly``'s printed trace."""
    rows = [line.split(" s  ") for line in trace.splitlines() if line.startswith(" ") and " s  " in line]
    states = [(float(t), name.strip()) for t, name in rows]
    i = next(k for k, (_, name) in enumerate(states) if name == "takeoff")
    return states[i + 1][0] - states[i][0]


def test_the_users_control_preset_wins_in_flight(tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    code, out, err = _fly(tmp_path, "arducopter", "tuning: identify\ncontrol_preset: arducopter\n", caplog)
    assert code == 0, out + err
    assert "first hover" not in err
    code, out, err = _fly(tmp_path, "arducopter", "tuning: identify\npid: {xy: {kp: 1.0, ki: 0.2}}\n", caplog)
    assert code == 0, out + err
    assert "first hover" not in err


@pytest.mark.slow
def test_a_mission_uav_identifies_on_its_first_hover_through_the_mavlink_adapter(tmp_path: Path) -> None:
    """Mission mode on the project's SITL (ArduCopter-like, lock-step): the brick UAV's first hover identifies the
    lag through the MAVLink adapter, then the mission completes; the adhesion UAV (the preset's) does not."""
    config = tmp_path / "uav.yaml"
    config.write_text("tuning: identify\n")
    run = fly_one_brick_mission(tmp_path, "id", "--config", str(config), mc_timeout_s=240.0)
    mc_out, brick_err, glue_err = run.mc_out, run.brick_err, run.glue_err
    assert run.mc_code == 0, mc_out + run.mc_err + brick_err + glue_err
    report = json.loads(mc_out)
    assert report["completed"] is True
    assert report["placement_error_m"]["B0"] < 0.03
    assert "position gains identified on the first hover (`tuning: identify` of uav.yaml)" in brick_err
    line = next(x for x in brick_err.splitlines() if "brick-1: identified on first hover: lag" in x)
    assert KP_MIN_PER_S <= float(line.split("kp ")[1].split(" /s")[0]) <= KP_MAX_PER_S
    assert "first hover" not in glue_err
