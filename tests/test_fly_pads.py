"""``masonry fly`` gives a real UAV the side look's keep-off from the other UAVs' pads, as the simulator does.

Issue 27: the brick machine keeps the way to its side look's hover ``pad_keep_off_m`` from the other UAVs' pads
(``UavConfig.pads_m``). ``build_machine`` set them in simulation only; ``masonry fly`` (mission mode, through
:func:`masonry.mission.remote.remote_config`, and single-task mode) left them empty. Both now take them from
:func:`masonry.fsm.config.blueprint_settings`.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.fsm.tuning import uav_settings
from masonry.mission.remote import RemoteRun, remote_config
from masonry.mission.simulate import SimulatedMission
from masonry.mission.uav_stack import build_machine
from masonry.separation import pad_site_distance_m
from masonry.sim.vehicle_config import DEFAULT_VEHICLE

TOWERS = Path(__file__).resolve().parents[1] / "blueprints" / "towers.yaml"  # four pads
runner = CliRunner()


class _Stop(Exception):
    """Ends a captured single-task flight before it flies."""


def _others_pads(bp: Any, name: str) -> tuple[tuple[float, float], ...]:
    return tuple((u.home_m[0], u.home_m[1]) for u in bp.fleet if u.name != name)


def test_fly_mission_flies_the_other_uavs_pads(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    """``masonry fly --mission`` with a uav.yaml: the config its UAV flies holds the three other pads, not its
    own, the blueprint's keep-off, and the uav.yaml's tuning."""
    seen: dict[str, Any] = {}

    def fake_run(blueprint: Any, spec: Any, **kw: Any) -> RemoteRun:
        seen["config"] = remote_config(blueprint, spec, kw["uav_settings"])
        return RemoteRun((), True, True, "idle", 0.0)

    monkeypatch.setattr("masonry.mission.remote.run_remote_uav", fake_run)
    uav_yaml = tmp_path / "uav.yaml"
    uav_yaml.write_text("control:\n  settle_speed_mps: 0.15\n")
    res = runner.invoke(
        app,
        ["fly", "--sim", "--mission", "tcp/127.0.0.1:7447", "--blueprint", str(TOWERS), "--uav", "brick",
         "--name", "brick-2", "--config", str(uav_yaml), "--format", "json"],
    )  # fmt: skip
    assert res.exit_code == 0, res.output
    bp = load_blueprint(TOWERS)
    config = seen["config"]
    assert config.name == "brick-2"
    assert config.pads_m == ((-3.0, -5.075), (1.0, -5.075), (3.0, -5.075)) == _others_pads(bp, "brick-2")
    assert (config.home_m[0], config.home_m[1]) not in config.pads_m
    assert config.pad_keep_off_m == pad_site_distance_m(bp.clearance_m) > 0.0
    assert config.settle_speed_mps == 0.15  # the uav.yaml's tuning still over the derived fields


def test_fly_one_task_flies_the_other_uavs_pads(monkeypatch: pytest.MonkeyPatch) -> None:
    """``masonry fly --task``: the config handed to the flight holds the other UAVs' pads too."""
    seen: dict[str, Any] = {}

    def capture(config: Any, *args: Any, **kw: Any) -> None:
        seen["config"] = config
        raise _Stop

    monkeypatch.setattr("masonry.fsm.fly_task", capture)
    bp = load_blueprint(TOWERS)
    task = next(f"B{b.id}" for b in bp.bricks if not b.placed)
    res = runner.invoke(
        app,
        ["fly", "--sim", "--blueprint", str(TOWERS), "--uav", "brick", "--name", "brick-1", "--task", task],
    )
    assert isinstance(res.exception, _Stop), res.output
    config = seen["config"]
    assert config.pads_m == _others_pads(bp, "brick-1") and len(config.pads_m) == 3
    assert config.pad_keep_off_m == pad_site_distance_m(bp.clearance_m)


def test_the_simulator_and_masonry_fly_configure_a_uav_alike() -> None:
    """Every UAV of a four-pad fleet: the simulator's machine and ``masonry fly --mission``'s, on the same tuning
    (the simulated vehicle's preset), fly the same configuration, pads, keep-off and all."""
    bp = load_blueprint(TOWERS)
    simulated: dict[str, Any] = {}

    def capture(spec: Any, *args: Any) -> object:
        machine = build_machine(spec, *args)
        simulated[spec.name] = machine.config  # type: ignore[attr-defined]
        return machine

    SimulatedMission.from_blueprint(bp, uav_machine=capture)
    assert sorted(simulated) == sorted(u.name for u in bp.fleet)
    for spec in bp.fleet:
        flown = remote_config(bp, spec, uav_settings(DEFAULT_VEHICLE))
        assert flown.pads_m == _others_pads(bp, spec.name)
        assert flown == simulated[spec.name], spec.name
