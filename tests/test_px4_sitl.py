"""The real PX4 v1.16 SITL (issue 29): read from its heartbeat, it gets the ``px4`` tuning without being told.

Skipped, with one reason, where ``MASONRY_PX4_SITL`` does not name ``../shared/px4/run.sh`` (tests/px4_sitl.py);
``.ci/run`` sets it. The pre-flight check only: a brick task on it does not complete yet (docs/hardware.md
"Against the real PX4 v1.16 SITL").
"""

from __future__ import annotations

from pathlib import Path

import pytest

from masonry.adapters.wiring import hardware_config
from masonry.blueprint import load_blueprint
from masonry.cli.fly import select_adapters
from masonry.cli.fly_tuning import tuning_preset
from masonry.sim import Faults
from px4_sitl import px4

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
        finally:
            ports.close()
    err = capsys.readouterr().err
    assert "  [ok  ] tuning: control preset px4 (PX4 autopilot, from its HEARTBEAT)" in err.splitlines(), err
    assert "[ok  ] position estimate" in err and "-> ready to arm" in err
