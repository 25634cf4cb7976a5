"""The tuning ``masonry fly`` flies without being told (issue 29): the autopilot's preset, the user's first."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.adapters.mavlink import MavlinkFlightController
from masonry.adapters.sitl import SITL_PRESETS, MavlinkSitl, SitlConfig, free_udp_port
from masonry.adapters.wiring import hardware_config
from masonry.cli import app
from masonry.cli.fly_tuning import tuning_choice, tuning_preset
from masonry.fsm.tuning import uav_settings
from masonry.fsm.tuning_choice import choose_tuning
from masonry.ports import UavPorts

CASE_STUDY = str(Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml")
runner = CliRunner()


@pytest.mark.parametrize(
    ("preset", "autopilot", "setting", "chosen", "reason"),
    [
        (None, "ardupilot", "auto", "arducopter", "ArduPilot autopilot, from its HEARTBEAT"),
        (None, "px4", "auto", "px4", "PX4 autopilot, from its HEARTBEAT"),
        (None, "ardupilot", "ardupilot", "arducopter", "ArduPilot autopilot, `autopilot:` of uav.yaml"),
        (None, None, "auto", "ideal", "the simulated vehicle's (--vehicle ideal)"),
        ("ideal", "ardupilot", "auto", "ideal", "`control_preset:` of uav.yaml"),
        ("arducopter", "px4", "auto", "arducopter", "`control_preset:` of uav.yaml"),
    ],
)
def test_the_users_preset_wins_then_the_autopilots_then_the_vehicles(
    preset: str | None, autopilot: str | None, setting: str, chosen: str, reason: str
) -> None:
    choice = choose_tuning(preset, autopilot=autopilot, autopilot_setting=setting)
    assert (choice.preset, choice.reason) == (chosen, reason)
    assert choice.detail() == f"control preset {chosen} ({reason})"


def test_the_line_names_the_users_settings_laid_over_the_preset() -> None:
    choice = choose_tuning(None, autopilot="ardupilot", overrides=("pid", "velocity_lag_s"))
    assert choice.detail() == (
        "control preset arducopter (ArduPilot autopilot, from its HEARTBEAT); `pid:`, `velocity_lag_s:` of "
        "uav.yaml over it"
    )


@pytest.mark.parametrize(("sitl", "autopilot", "preset"), [("ardupilot", "ardupilot", "arducopter"),
                                                           ("px4", "px4", "px4")])  # fmt: skip
def test_the_autopilot_named_by_a_loopback_heartbeat_picks_its_preset(
    sitl: str, autopilot: str, preset: str
) -> None:
    port = free_udp_port()
    config = SitlConfig(**SITL_PRESETS[sitl]) if sitl == "px4" else SitlConfig()
    peer = MavlinkSitl(port, time_scale=1.0, config=config)
    fc = MavlinkFlightController(f"udpin:127.0.0.1:{port}", connect_timeout_s=5.0)
    peer.start()
    try:
        fc.connect()
        ports = UavPorts(fc=fc, gripper=None, camera=None, sprayer=None, clock=None)  # type: ignore[arg-type]
        assert fc.autopilot == autopilot
        assert tuning_preset("ideal", ports) == preset
        hw = hardware_config({}, {"fc": f"udpin:127.0.0.1:{port}"})
        assert tuning_choice(hw, "ideal", ports).preset == preset
        # what the state machines get: the autopilot's preset's settings
        assert hw.uav_settings(tuning_preset("ideal", ports)) == uav_settings(preset)
        # the user's control_preset: still wins
        mine = hardware_config({}, {"fc": f"udpin:127.0.0.1:{port}", "control_preset": "ideal"})
        assert mine.uav_settings(tuning_preset("ideal", ports)) == uav_settings("ideal") == {}
        assert tuning_choice(mine, "ideal", ports).preset == "ideal"
    finally:
        fc.close()
        peer.stop()


def test_a_simulated_autopilot_flies_its_vehicles_preset() -> None:
    from masonry.blueprint import load_blueprint
    from masonry.cli.fly import select_adapters
    from masonry.sim import Faults

    bp = load_blueprint(CASE_STUDY)
    spec = next(u for u in bp.fleet if u.role == "brick")
    ports = select_adapters(sim=True, blueprint=bp, spec=spec, seed=0, camera="geometric", faults=Faults(),
                            vehicle="arducopter")  # fmt: skip
    try:
        assert tuning_preset("arducopter", ports) == "arducopter"
        assert tuning_preset("ideal", ports) == "ideal"
    finally:
        ports.close()


@pytest.mark.parametrize(
    ("yaml", "line"),
    [
        ("", "[ok  ] tuning: control preset arducopter (ArduPilot autopilot, from its HEARTBEAT)"),
        ("tuning: identify\n",
         "[ok  ] tuning: control preset arducopter (ArduPilot autopilot, from its HEARTBEAT); position gains "
         "identified on the first hover (`tuning: identify` of uav.yaml), the preset's if unusable"),
        ("control_preset: ideal\npid: {xy: {kp: 2.0}}\n",
         "[ok  ] tuning: control preset ideal (`control_preset:` of uav.yaml); `pid:` of uav.yaml over it"),
    ],
)  # fmt: skip
def test_the_pre_flight_says_which_tuning_it_flies_and_why(tmp_path: Path, yaml: str, line: str) -> None:
    port = free_udp_port()
    config = tmp_path / "uav.yaml"
    config.write_text(f"fc: udpin:127.0.0.1:{port}\nestimate_wait_s: 0.3\nname: brick-1\n{yaml}")
    # no motion capture comes: the check refuses to arm, after saying what it would have flown
    sitl = MavlinkSitl(port, time_scale=5.0, config=SitlConfig(position_source="vision"))
    sitl.start()
    try:
        res = runner.invoke(
            app, ["fly", "--uav", "brick", "--blueprint", CASE_STUDY, "--task", "B0", "--config", str(config)]
        )
    finally:
        sitl.stop()
    assert res.exit_code == 1
    assert f"  {line}" in res.stderr.splitlines(), res.stderr
    assert "-> refusing to arm" in res.stderr
