"""``masonry fly``: one UAV flies one task of a blueprint, here in the simulated world (``--sim``).

The command is thin: parse, pick the UAV and the task, wire the adapters (:func:`select_adapters`, the one
place that decides what drives the flight controller, the actuators and the camera), run
:func:`masonry.fsm.fly_task`, print the trace and the result.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from masonry.cli.app import command
from masonry.cli.fly_adapters import Adapters as Adapters
from masonry.cli.fly_adapters import _a as _a
from masonry.cli.fly_adapters import _check_vehicle as _check_vehicle
from masonry.cli.fly_adapters import _describe as _describe
from masonry.cli.fly_adapters import _pick_uav
from masonry.cli.fly_adapters import _prerequisites as _prerequisites
from masonry.cli.fly_adapters import select_adapters as select_adapters
from masonry.cli.fly_mission import _fly_mission
from masonry.cli.fly_task import _fly_one_task, _identify
from masonry.cli.fly_task import _pick_task as _pick_task
from masonry.cli.fly_task import _task_outcome as _task_outcome
from masonry.cli.options import check_all, help_text
from masonry.cli.wind_options import TURBULENCE_OPTION, WIND_OPTION, site_faults
from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.adapters.wiring import HardwareConfig


@dataclass(frozen=True)
class _Hardware:
    hw: HardwareConfig
    name: str | None
    mission: str | None


def _hardware_options(
    *,
    sim: bool,
    fc: str | None,
    actuators: str | None,
    camera: str | None,
    calibration: Path | None,
    config: Path | None,
    estimate_wait: float | None = None,
) -> _Hardware:
    """--fc/--actuators/--camera/--calibration over --config uav.yaml over "sim" (the adapter wiring's defaults)."""
    from masonry.adapters.wiring import hardware_config, load_uav_config

    if sim and camera is not None and camera not in ("sim", "geometric", "render"):
        raise InputError(
            f"--camera {camera}: with --sim the camera must be geometric, render or sim (for a real "
            f"camera drop --sim and give a device INDEX or a video FILE with --calibration)"
        )
    if calibration is not None and not calibration.is_file():
        raise InputError(f"--calibration {calibration}: no such file")
    if sim and calibration is not None:
        raise InputError(
            "--calibration is for a real camera: the simulated camera has its own intrinsics (drop "
            "--calibration, or drop --sim to fly a real camera)"
        )
    settings = load_uav_config(config) if config is not None else {}
    cli = {
        "fc": fc,
        "actuators": actuators,
        "camera": camera,
        "calibration": str(calibration) if calibration is not None else None,
        "estimate_wait_s": estimate_wait,
    }
    hw = hardware_config(cli, settings)
    if sim and not hw.all_sim:
        raise InputError(
            "--sim simulates every adapter: drop --sim to use --fc / --actuators / a real --camera"
        )
    return _Hardware(hw, settings.get("name"), settings.get("mission"))


@command("fly")
def fly(
    uav: str = typer.Option(..., "--uav", help="brick | adhesion: the kind of UAV to fly."),
    sim: bool = typer.Option(False, "--sim", help="Fly in the simulated world (all adapters simulated)."),
    blueprint: Path = typer.Option(..., "--blueprint", help="Wall blueprint (YAML or JSON)."),
    task: str | None = typer.Option(
        None, "--task", help="Task id, as `masonry plan` lists them (B3, A0, ...); not with --mission."
    ),
    name: str | None = typer.Option(
        None, "--name", help="The UAV of the fleet (default: the first of its role)."
    ),
    seed: int = typer.Option(0, "--seed", help=help_text("fly", "--seed", "Seed of the simulated world.")),
    camera: str | None = typer.Option(
        None,
        "--camera",
        help="Simulated: geometric (default) | render (images + "
        "ArUco, slower) | sim; real: a device INDEX, a video FILE or a GStreamer "
        "pipeline (needs --calibration).",
    ),
    fc: str | None = typer.Option(
        None,
        "--fc",
        help="Flight controller: sim, or a MAVLink connection "
        "(udpin:0.0.0.0:14550, /dev/ttyACM0, tcp:HOST:5760).",
    ),
    actuators: str | None = typer.Option(
        None, "--actuators", help="Gripper/valve: sim, or the actuator Arduino's serial port (/dev/ttyACM0)."
    ),
    calibration: Path | None = typer.Option(
        None, "--calibration", help="Camera calibration from `masonry calibrate` (for a real camera)."
    ),
    config: Path | None = typer.Option(
        None,
        "--config",
        help="UAV settings file (uav.yaml: fc, actuators, "
        "camera, calibration, signing_key, mocap_port, ...); flags override it.",
    ),
    fault: list[str] = typer.Option(
        [],
        "--fault",
        metavar="KEY=VALUE",
        help="KEY=VALUE, repeatable, as for `masonry sim` "
        "(grasp=0.3, dropout=0.5, occlusion=0.3, gusts=2.0, link-loss=brick-1@30).",
    ),
    wind: str | None = WIND_OPTION,
    turbulence: str | None = TURBULENCE_OPTION,
    fmt: str = typer.Option("text", "--format", help="text | json."),
    dt: float = typer.Option(0.05, "--dt", help=help_text("fly", "--dt", "Control tick, seconds.")),
    timeout: float = typer.Option(
        900.0,
        "--timeout",
        help=help_text("fly", "--timeout", "Give up after this much flight time, seconds."),
    ),
    estimate_wait: float | None = typer.Option(
        None,
        "--estimate-wait",
        help=help_text(
            "fly",
            "--estimate-wait",
            "With --fc: how long the pre-flight check waits for the autopilot's position "
            "estimate, seconds (default 90: ArduPilot SITL needs about 40 s, a cold Pixhawk about as long).",
        ),
    ),
    mission: str | None = typer.Option(
        None,
        "--mission",
        help="Mission mode: take tasks from mission control "
        "at this Zenoh endpoint (tcp/HOST:7447) until it ends the mission.",
    ),
    listen: list[str] = typer.Option(
        ["tcp/127.0.0.1:0"], "--listen", help="Mission mode: this UAV's own Zenoh listen endpoint(s)."
    ),
    mission_name: str = typer.Option("default", "--mission-name", help="Mission mode: Zenoh key prefix."),
    time_scale: float = typer.Option(
        1.0,
        "--time-scale",
        help=help_text("fly", "--time-scale", "Mission mode: simulated seconds per wall second."),
    ),
    wait: float = typer.Option(
        60.0,
        "--wait",
        help=help_text("fly", "--wait", "Mission mode: wall seconds to wait for mission control."),
    ),
    heartbeat_timeout: float = typer.Option(
        5.0,
        "--heartbeat-timeout",
        help=help_text(
            "fly",
            "--heartbeat-timeout",
            "Mission mode: wall seconds of mission control's silence after which it counts as lost (the UAV "
            "abandons its task two heartbeats before); give mission control's --heartbeat-timeout.",
        ),
    ),
    key_file: Path | None = typer.Option(
        None,
        "--key-file",
        help="Mission mode: the mission key (masonry keygen -o FILE), the same file as mission control's.",
    ),
    insecure: bool = typer.Option(
        False,
        "--insecure",
        help="Mission mode: allow a non-loopback mission control or --listen without a key.",
    ),
    vehicle: str | None = typer.Option(
        None,
        "--vehicle",
        help="With --sim: the simulated autopilot, arducopter (default: ArduCopter's setpoint shaping, delay and "
        "GPS-like noise, fitted to its SITL) | ideal (a 0.3 s first-order velocity lag).",
    ),
    identify: bool = typer.Option(
        False,
        "--identify",
        help="Measure the autopilot's velocity response instead of flying a task: take off, velocity steps "
        "in a safe hover, land; print the lag and the tuning it suggests (docs/hardware.md).",
    ),
    zenoh_config: Path | None = typer.Option(
        None,
        "--zenoh-config",
        help="Mission mode: Zenoh configuration file (JSON5): TLS, access control (docs/security.md).",
    ),
    log: Path | None = typer.Option(
        None,
        "--log",
        metavar="FILE.mcap",
        help="Mission mode: write this UAV's log (its tasks, state, pose, battery) to this MCAP file "
        "(docs/logging.md).",
    ),
) -> None:
    """Fly one UAV: one task (--task ID: state trace, then the result; exit 1 if it failed), or a mission's tasks
    from mission control (--mission tcp/HOST:7447; exit 1 if mission control did not end the mission)."""
    from masonry.blueprint import load_blueprint

    if uav not in ("brick", "adhesion"):
        raise InputError(f"--uav must be brick or adhesion, got {uav!r}")
    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    vehicle = _check_vehicle(vehicle, sim)
    check_all(
        "fly",
        {
            "--seed": seed,
            "--dt": dt,
            "--timeout": timeout,
            "--time-scale": time_scale,
            "--wait": wait,
            "--heartbeat-timeout": heartbeat_timeout,
            "--estimate-wait": estimate_wait,
        },
    )
    hardware = _hardware_options(
        sim=sim,
        fc=fc,
        actuators=actuators,
        camera=camera,
        calibration=calibration,
        config=config,
        estimate_wait=estimate_wait,
    )
    if name is None and hardware.name is not None:
        name = hardware.name
    if mission is None and hardware.mission is not None and task is None:
        mission = hardware.mission
    camera = "render" if hardware.hw.camera == "render" else "geometric"
    if (wind is not None or turbulence is not None) and not hardware.hw.sim_fc:
        raise InputError("--wind and --turbulence are for a simulated UAV (--sim): the real sky has its own")
    faults = site_faults(fault, wind, turbulence)
    if not dt > 0.0 or not timeout > 0.0:
        raise InputError("--dt and --timeout must be > 0")
    bp = load_blueprint(blueprint)
    _check_log(log, mission)
    if identify:
        if task is not None or mission is not None:
            raise InputError("--identify flies its own steps: drop --task and --mission")
        _identify(
            bp, _pick_uav(bp, uav, name), sim=sim, seed=seed, camera=camera, dt=dt, fmt=fmt, hardware=hardware.hw,
            vehicle=vehicle,
        )  # fmt: skip
        return
    if mission is not None:
        if task is not None:
            raise InputError(
                "--task and --mission exclude each other: in mission mode tasks come from mission control"
            )
        if not (time_scale > 0.0):
            raise InputError(f"--time-scale must be > 0, got {time_scale}")
        if not hardware.hw.sim_fc and time_scale != 1.0:
            raise InputError(
                "--time-scale is for a simulated UAV: with --fc URL the autopilot's clock sets the "
                "pace (give `masonry sitl --time-scale` and `masonry mission-control --time-scale` "
                "the same factor instead)"
            )
        from masonry.cli.mission import network_options

        key = network_options(key_file, insecure, [mission, *listen], "--mission/--listen")
        _fly_mission(
            bp,
            _pick_uav(bp, uav, name),
            mission,
            listen=listen,
            mission_name=mission_name,
            seed=seed,
            camera=camera,
            faults=faults,
            dt=dt,
            time_scale=time_scale,
            wait=wait,
            heartbeat_timeout=heartbeat_timeout,
            fmt=fmt,
            sim=sim,
            hardware=hardware.hw,
            key=key,
            vehicle=vehicle,
            zenoh_config=zenoh_config,
            log=log,
            blueprint_path=blueprint,
        )
        return
    if task is None:
        raise InputError("--task is required (or --mission tcp/HOST:PORT to take tasks from mission control)")
    _fly_one_task(
        bp,
        task,
        uav,
        name,
        sim=sim,
        seed=seed,
        camera=camera,
        faults=faults,
        dt=dt,
        timeout=timeout,
        fmt=fmt,
        hardware=hardware.hw,
        vehicle=vehicle,
    )


def _check_log(log: Path | None, mission: str | None) -> None:
    """``--log``: mission mode only, a writable ``.mcap`` file."""
    if log is None:
        return
    if mission is None:
        raise InputError("--log is for mission mode (--mission tcp/HOST:PORT)")
    from masonry.cli.outputs import check_output_path
    from masonry.cli.watch import check_log_option

    check_output_path(check_log_option(log), "--log")
