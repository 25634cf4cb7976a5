"""The real PX4 v1.16 SITL (issue 29): read from its heartbeat, it gets the ``px4`` tuning without being told.

Skipped, with one reason, where ``MASONRY_PX4_SITL`` does not name ``../shared/px4/run.sh`` (tests/px4_sitl.py);
``.ci/run`` sets it. The pre-flight check, masonry's own velocity loop chosen for it, and the velocity the gates
read against the simulator's truth. A brick task on it completes (docs/hardware.md "Against the real PX4 v1.16
SITL") but is not flown here: with the 3 s gate window issue 29's scenario placed the brick in 6 of 6 runs of one
series but 19 of 23 over four (benchmarks/bench_px4_brick.py; the pickup's swing gate, "swinging at 0.20-0.24 m/s
rms", which counts the hover's vertical motion, failed most of the others), SIH runs in real time, and on a loaded
machine PX4's sensors time out.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from masonry.adapters.wiring import hardware_config
from masonry.blueprint import load_blueprint
from masonry.cli.fly import select_adapters
from masonry.cli.fly_tuning import fly_settings, tuning_preset
from masonry.fsm.tuning import uav_settings
from masonry.sim import Faults
from px4_sitl import hover, px4, velocity_errors

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")


@pytest.mark.slow
def test_the_real_px4_is_read_from_its_heartbeat_and_flies_the_px4_tuning(tmp_path: Path, capsys) -> None:
    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "brick")
    with px4(tmp_path / "px4", instance=7) as url:
        # the defaults but the estimate wait (its EKF2 is ready within seconds; a loaded machine slows it)
        hw = hardware_config({"fc": url, "actuators": "sim", "camera": "sim"}, {"estimate_wait_s": 150})
        ports = select_adapters(sim=False, blueprint=bp, spec=spec, seed=0, camera="sim", faults=Faults(),
                                hardware=hw)  # fmt: skip
        try:
            assert ports.fc.autopilot == "px4"  # type: ignore[attr-defined]
            assert tuning_preset("ideal", ports) == "px4"
            # masonry flies its own velocity loop on it (acceleration setpoints once airborne), with its gains
            assert ports.fc.velocity_loop is not None  # type: ignore[attr-defined]
            assert fly_settings(hw, "ideal", ports) == uav_settings("px4", own_velocity_loop=True)
        finally:
            ports.close()
    err = capsys.readouterr().err
    assert "  [ok  ] tuning: control preset px4 (PX4 autopilot, from its HEARTBEAT)" in err.splitlines(), err
    assert "[ok  ] position estimate" in err and "-> ready to arm" in err


@pytest.mark.slow
def test_the_gates_velocity_on_the_real_px4_is_no_farther_from_the_truth_than_ekf2s(tmp_path: Path) -> None:
    """PX4's own hover: EKF2's velocity sits up to 0.5 m/s off the truth; the one the ``px4`` preset's gates read
    (consistent with the position, 2 s) is no farther from it, within a 40 s rms's spread (issue 29). On PX4's clock (SIH runs lock-step)."""
    tau_s = uav_settings("px4")["velocity_from_position_s"]
    with px4(tmp_path / "px4", instance=8) as url:
        flight = hover(url, 40.0)
    kept = tmp_path / "hover.json"  # the flight, for a look at a failure
    kept.write_text(json.dumps({"estimate": flight.estimate, "truth": flight.truth}))
    assert len(flight.estimate) > 600 and len(flight.truth) > 600  # 30 Hz streams over 40 s
    ekf, filtered = velocity_errors(flight, tau_s)
    # measured in 14 hovers (2026-12-03/04; 8 of them beside 2-5 busy loops): EKF2 0.19-0.47 m/s, filtered
    # 0.09-0.53 m/s, the nearer in 13; once (a CI run, EKF2's worst hover, 0.47) 0.06 m/s farther. A 40 s rms varies
    # by about 0.1 m/s from hover to hover, so that is the margin. A hover barely moves: this checks that the filter
    # adds no error to what the gates read on the real PX4, not that it follows motion (tests/test_velocity_filter.py
    # checks that, deterministically, and the recorded hover's margin).
    assert filtered < ekf + 0.1, (ekf, filtered, str(kept))
