"""``masonry fly --identify``: the velocity-step identification (issue 19), on synthetic responses and on the
simulated vehicle (a first-order 0.3 s velocity lag) in simulated time."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from masonry.cli import app
from masonry.errors import HardwareError
from masonry.fsm import UavConfig
from masonry.fsm.identify import step_response, suggest

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


def _first_order(tau_s: float, delay_s: float, v0: float, v1: float, dt: float = 0.01):
    t = np.arange(0.0, 4.0, dt)
    v = v0 + (v1 - v0) * np.where(t < delay_s, 0.0, 1.0 - np.exp(-(t - delay_s) / tau_s))
    return list(t), list(v)


@pytest.mark.parametrize(("tau", "delay"), [(0.3, 0.0), (0.4, 0.3), (0.2, 0.1)])
def test_a_first_order_step_with_dead_time_is_measured(tau, delay):
    t, v = _first_order(tau, delay, 0.5, -0.5)
    s = step_response("x", 0.0, 0.5, -0.5, t, v)
    assert s.t63_s == pytest.approx(delay + tau, abs=0.011)
    assert s.t10_s == pytest.approx(delay + tau * math.log(1 / 0.9), abs=0.011)
    assert s.t90_s == pytest.approx(delay + tau * math.log(10), abs=0.011)
    assert s.overshoot == 0.0


def test_the_suggestion_follows_the_lag_and_the_noise():
    defaults = UavConfig("u", "brick", (0.0, 0.0, 0.0))
    steps = [step_response("x", 0.0, 0.0, 0.5, *_first_order(0.4, 0.3, 0.0, 0.5)) for _ in range(3)]
    found = suggest(steps, hover_std_m=0.02, hover_speed_rms_mps=0.01, defaults=defaults)
    assert found.lag_s == pytest.approx(0.7, abs=0.011)
    assert found.kp == round(math.pi / (2 * found.lag_s) / 3, 2) and found.ki == round(0.2 * found.kp, 2)
    assert found.ask_settle_tolerance_m == pytest.approx(0.06)  # 3 sigma of the hover's noise
    assert found.settle_speed_mps == defaults.settle_speed_mps  # never below the default
    assert "pid: {xy: {kp: 0.75, ki: 0.15}}" in found.lines()[-1]
    never = step_response("x", 0.0, 0.0, 0.5, [0.0, 1.0], [0.0, 0.1])
    assert never.t63_s is None
    with pytest.raises(HardwareError, match="no velocity step reached 63 %"):
        suggest([never], 0.0, 0.0, defaults)


def _identify(*vehicle: str) -> dict:
    res = CliRunner().invoke(
        app,
        [
            "fly",
            "--identify",
            "--sim",
            "--uav",
            "brick",
            "--blueprint",
            CASE_STUDY,
            "--format",
            "json",
            *vehicle,
        ],
    )
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout)


def test_identify_on_the_simulated_vehicle_finds_its_lag():
    out = _identify("--vehicle", "ideal")
    assert out["uav"] == "brick-1" and len(out["steps"]) == 8
    # the ideal vehicle's velocity loop is a first-order 0.3 s lag, seen on 0.05 s ticks
    assert 0.25 <= out["lag_s"] <= 0.4
    assert out["hover_position_std_m"] < 0.01
    assert out["suggested"]["velocity_lag_s"] == round(out["lag_s"], 2)


def test_identify_on_the_default_simulated_vehicle_finds_arducopters_lag():
    """The default simulated autopilot is the ``arducopter`` preset, fitted to the SITL's 0.71 s to 63 %."""
    out = _identify()
    assert 0.6 <= out["lag_s"] <= 0.85, out["lag_s"]
    assert out["suggested"]["velocity_lag_s"] == pytest.approx(out["lag_s"], abs=0.006)


def test_identify_excludes_a_task():
    res = CliRunner().invoke(
        app, ["fly", "--identify", "--sim", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B0"]
    )
    assert res.exit_code == 2 and "--identify flies its own steps" in res.stderr
