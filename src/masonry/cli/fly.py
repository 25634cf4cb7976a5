"""``masonry fly``: one UAV flies one task of a blueprint, here in the simulated world (``--sim``).

The command is thin: parse, pick the UAV and the task, wire the adapters (:func:`select_adapters`, the one place
that decides what drives the flight controller, the actuators and the camera), fly it, print the result.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import typer

from masonry.cli.app import cli_text, command
from masonry.cli.fly_tuning import tuning_preset, with_tuning_line
from masonry.cli.options import check_all, help_text
from masonry.cli.wind_options import TURBULENCE_OPTION, WIND_OPTION, site_faults
from masonry.errors import InputError
from masonry.placement_check import wall_tops_m
from masonry.ports import UavPorts

#: The old name of what :func:`select_adapters` returns (it is :class:`masonry.ports.UavPorts` now).
Adapters = UavPorts


def select_adapters(
    *,
    sim: bool,
    blueprint: Any,
    spec: Any,
    seed: int,
    camera: str,
    faults: Any,
    hardware: Any = None,
    vehicle: str = "ideal",
) -> UavPorts:
    """Choose and build the adapters for the UAV ``spec``: the simulated world (``--sim``), or each port on its
    own (``hardware``: a :class:`masonry.adapters.wiring.HardwareConfig` from --fc/--actuators/--camera), checked
    by the pre-flight check (printed on stderr; a failure refuses to arm).
    """
    if hardware is not None and not hardware.all_sim:
        from masonry.adapters.wiring import open_adapters, preflight

        opened = open_adapters(hardware, blueprint=blueprint, spec=spec, seed=seed, faults=faults)
        try:
            report = preflight(
                opened,
                hardware,
                role=spec.role,
                progress=lambda line: typer.echo(line, err=True),
                site=getattr(blueprint, "site", None),
            )
            report = with_tuning_line(report, hardware, vehicle, opened)
            for line in report.lines():
                typer.echo(cli_text(line, report.options), err=True)
            report.raise_if_failed()
        except BaseException:
            opened.close()
            raise
        return opened
    if not sim:
        raise InputError(
            "no adapters chosen: pass --sim to fly in the simulated world, or pick hardware with "
            "--fc URL / --actuators PORT / --camera INDEX|FILE"
        )
    from masonry.sim import World
    from masonry.sim.vehicle_config import vehicle_preset

    world = World(blueprint, seed=seed, camera=camera, faults=faults, vehicle=vehicle_preset(vehicle))  # type: ignore[arg-type]
    faults.check_uavs([spec.name])
    return world.add_uav(spec).ports


def _check_vehicle(vehicle: str | None, sim: bool = True) -> str:
    """``--vehicle``: one of the simulated presets, and only for a simulated flight controller; the preset to fly
    (unset: ``DEFAULT_VEHICLE`` in simulation; ``ideal``, the default tuning, on a real autopilot)."""
    from masonry.sim.vehicle_config import VEHICLE_PRESETS, vehicle_name

    if vehicle is not None and vehicle not in VEHICLE_PRESETS:
        raise InputError(f"--vehicle must be one of {', '.join(VEHICLE_PRESETS)}, got {vehicle!r}")
    if vehicle not in (None, "ideal") and not sim:
        raise InputError("--vehicle picks the simulated autopilot: it needs --sim (a real one is what it is)")
    return vehicle_name(vehicle) if sim else "ideal"


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _pick_uav(blueprint: Any, role: str, name: str | None) -> Any:
    if name is not None:
        for spec in blueprint.fleet:
            if spec.name == name:
                if spec.role != role:
                    raise InputError(f"--name {name}: {name} is {_a(spec.role)} UAV, not {_a(role)} UAV")
                return spec
        raise InputError(
            f"--name {name}: no UAV of that name in the fleet of {blueprint.source} "
            f"({', '.join(u.name for u in blueprint.fleet) or 'empty fleet'})"
        )
    for spec in blueprint.fleet:
        if spec.role == role:
            return spec
    raise InputError(f"{blueprint.source}: the fleet has no {role} UAV")


def _prerequisites(plan: Any, task_id: str) -> set[str]:
    """Every task ``task_id`` depends on, directly or not."""
    after: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        after.setdefault(u, []).append(v)
    seen: set[str] = set()
    stack = list(after.get(task_id, ()))
    while stack:
        t = stack.pop()
        if t not in seen:
            seen.add(t)
            stack.extend(after.get(t, ()))
    return seen


@dataclass(frozen=True)
class _Hardware:
    hw: Any  # masonry.adapters.wiring.HardwareConfig
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


def _describe(hw: Any) -> str:
    return f"fc {hw.fc}, actuators {hw.actuators}, camera {hw.camera}"


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


def _identify(
    bp: Any, spec: Any, *, sim: bool, seed: int, camera: str, dt: float, fmt: str, hardware: Any, vehicle: str
) -> None:
    """``--identify``: velocity steps in a hover on the chosen flight controller; the lag and the suggested tuning."""
    from masonry.fsm import UavConfig
    from masonry.fsm.identify import identify
    from masonry.sim import Faults

    adapters = select_adapters(
        sim=sim, blueprint=bp, spec=spec, seed=seed, camera=camera, faults=Faults(), hardware=hardware,
        vehicle=vehicle,
    )  # fmt: skip
    config = UavConfig.from_spec(
        spec,
        cruise_altitude_m=bp.cruise_altitude_m,
        **hardware.uav_settings(tuning_preset(vehicle, adapters)),
    )
    try:
        adapters.fc.connect()
        found = identify(adapters.fc, adapters.clock, adapters.advance, config=config, dt_s=dt)
    finally:
        adapters.close()
    if fmt == "json":
        typer.echo(json.dumps({"uav": spec.name, **found.to_dict()}))
        return
    where = f"simulated, seed {seed}" if hardware.all_sim else _describe(hardware)
    typer.echo(f"{spec.name}: velocity response ({where})")
    for line in found.lines():
        typer.echo(line)


def _fly_one_task(
    bp: Any,
    task: str,
    uav: str,
    name: str | None,
    *,
    sim: bool,
    seed: int,
    camera: str,
    faults: Any,
    dt: float,
    timeout: float,
    fmt: str,
    hardware: Any,
    vehicle: str = "ideal",
) -> None:
    """Single-task mode: fly ``task`` with the UAV of role ``uav`` (``name``); print the trace and the result."""
    from masonry.fsm import UavConfig, fly_task
    from masonry.planner import plan

    the_plan = plan(bp)
    the_task, spec = _pick_task(bp, the_plan, task, uav), _pick_uav(bp, uav, name)

    # Single-task mode: every brick the task depends on is taken as already built.
    before = {t for t in _prerequisites(the_plan, task) if t.startswith("B")}
    bricks = tuple(replace(b, placed=True) if f"B{b.id}" in before else b for b in bp.bricks)
    world_bp = replace(bp, bricks=bricks)

    adapters = select_adapters(
        sim=sim, blueprint=world_bp, spec=spec, seed=seed, camera=camera, faults=faults, hardware=hardware,
        vehicle=vehicle,
    )  # fmt: skip
    uav_config = UavConfig.from_spec(
        spec,
        cruise_altitude_m=bp.cruise_altitude_m,
        markers=bp.markers,
        wall=wall_tops_m(bp.bricks),
        fence=bp.site,
        **hardware.uav_settings(tuning_preset(vehicle, adapters)),
    )
    try:
        run = fly_task(
            uav_config,
            the_task,
            fc=adapters.fc,
            clock=adapters.clock,
            gripper=adapters.gripper,
            camera=adapters.camera,
            sprayer=adapters.sprayer,
            dt_s=dt,
            advance=adapters.advance,
            timeout_s=timeout,
        )
    finally:
        adapters.close()

    out = _task_outcome(run, the_task, spec.name, adapters.world, timeout)
    if fmt == "json":
        typer.echo(json.dumps(out))
        return
    where = f"simulated, seed {seed}, {camera} camera" if hardware.all_sim else _describe(hardware)
    typer.echo(f"{spec.name} flies {the_task.id} ({where})")
    for t, s in run.trace:
        typer.echo(f"{t:8.2f} s  {s}")
    line = f"{the_task.id}: {out['status']} in {out['duration_s']:.1f} s"
    if out.get("placement_error_m") is not None:
        line += f", placement error {out['placement_error_m'] * 1000:.1f} mm"
    if out.get("coverage") is not None:
        line += f", coverage {out['coverage']:.0%}"
    if "reason" in out:
        line += f": {out['reason']}"
    typer.echo(line)
    if out["status"] != "done":
        raise typer.Exit(1)


def _pick_task(bp: Any, the_plan: Any, task: str, uav: str) -> Any:
    """The task ``--task`` names, if the plan has it, it is of the UAV's kind and not already done."""
    try:
        the_task = the_plan.task(task)
    except KeyError:
        ids = [t.id for t in the_plan.tasks if not t.done]
        shown = ", ".join(ids[:12]) + (", ..." if len(ids) > 12 else "")
        raise InputError(f"--task {task}: no such task in {bp.source} (tasks: {shown or 'none'})") from None
    if the_task.kind != uav:
        raise InputError(f"--task {task} is {_a(the_task.kind)} task: fly it with --uav {the_task.kind}")
    if the_task.done:
        raise InputError(f"--task {task}: brick {task[1:]} is already in place in {bp.source}")
    return the_task


def _task_outcome(run: Any, the_task: Any, uav_name: str, world: Any, timeout: float) -> dict[str, Any]:
    """The result of a single-task flight as ``--format json`` prints it (the world measures, if there is one)."""
    from masonry.planner.tasks import BrickTask

    result = run.result
    status = result.status if result is not None else "failed"
    out: dict[str, Any] = {
        "uav": uav_name,
        "task": the_task.id,
        "status": status,
        "duration_s": round(result.duration_s if result is not None else run.duration_s, 2),
        "placement_error_m": None,
    }
    if isinstance(the_task, BrickTask):
        error: float | None
        if world is not None:
            error = world.placement_error_m(the_task.brick)
        else:
            error = result.placement_error_m if result is not None else None
        out["placement_error_m"] = None if error is None else round(float(error), 4)
    else:
        coverage: float | None
        if world is not None:
            coverage = world.coverage(the_task)
        else:
            coverage = result.coverage if result is not None else None
        out["coverage"] = None if coverage is None else round(float(coverage), 3)
    if status != "done":
        out["reason"] = result.reason if result is not None else f"no result after {timeout:g} s"
    out["trace"] = [{"t_s": round(t, 2), "state": s} for t, s in run.trace]
    return out


def _fly_mission(
    bp: Any,
    spec: Any,
    endpoint: str,
    *,
    listen: list[str],
    mission_name: str,
    seed: int,
    camera: str,
    faults: Any,
    dt: float,
    time_scale: float,
    wait: float,
    fmt: str,
    heartbeat_timeout: float = 5.0,
    sim: bool = True,
    hardware: Any = None,
    key: bytes | None = None,
    zenoh_config: Path | None = None,
    log: Path | None = None,
    blueprint_path: Path | None = None,
    vehicle: str = "ideal",
) -> None:
    """Mission mode: one UAV taking its tasks from mission control over Zenoh (masonry.mission.remote).

    ``--sim``: a simulated world paced at ``time_scale``. Otherwise the adapters chosen with --fc/--actuators/
    --camera, checked by the pre-flight check (a failure refuses to arm before joining), on the autopilot's clock.
    """
    from masonry.mission.remote import paced, run_remote_uav

    echo = None if fmt == "json" else typer.echo
    adapters = None
    mission_log = None
    if log is not None and blueprint_path is not None:
        from masonry.cli.watch import open_log
        from masonry.planner import plan

        mission_log = open_log(log, plan(bp), blueprint_path, spec.name, "fly").open()
    if not sim:
        adapters = select_adapters(
            sim=False, blueprint=bp, spec=spec, seed=seed, camera=camera, faults=faults, hardware=hardware
        )
        if hardware.sim_fc:  # a simulated autopilot (with real actuators or camera) keeps time with the wall
            adapters = replace(adapters, advance=paced(adapters.clock, adapters.advance, time_scale))
    try:
        if echo is not None:
            where = (
                f"simulated, seed {seed}, x{time_scale:g} real time"
                if adapters is None
                else _describe(hardware) + ("" if hardware.sim_fc else ", on the autopilot's clock")
            )
            echo(f"{spec.name} joins the mission at {endpoint} ({where})")
        run = run_remote_uav(
            bp,
            spec,
            connect=[endpoint],
            listen=listen,
            mission_name=mission_name,
            seed=seed,
            camera=camera,
            faults=faults,
            dt_s=dt,
            time_scale=time_scale,
            wait_s=wait,
            # in mission seconds: the UAV's clock runs time_scale faster than the wall (1: a real autopilot)
            heartbeat_timeout_s=heartbeat_timeout
            * (time_scale if adapters is None or hardware.sim_fc else 1.0),
            max_time_s=float("inf"),
            echo=echo,
            adapters=adapters,
            key=key,
            zenoh_config=zenoh_config,
            uav_settings=hardware.uav_settings(tuning_preset(vehicle, adapters))
            if hardware is not None
            else None,
            max_wind_mps=hardware.max_wind_mps if hardware is not None else None,
            events_sink=mission_log,
            vehicle=vehicle,
        )
    finally:
        if adapters is not None:
            adapters.close()
        if mission_log is not None:
            mission_log.close()
            typer.echo(f"wrote {log}", err=True)
    tasks = [
        {
            "task": e.task_id,
            "attempt": e.attempt,
            "start_s": round(e.start_s, 2),
            "end_s": None if e.end_s is None else round(e.end_s, 2),
            "status": e.status,
            "reason": getattr(e, "reason", None),
        }
        for e in run.executions
    ]
    if fmt == "json":
        typer.echo(
            json.dumps(
                {
                    "uav": spec.name,
                    "mission_ended": run.mission_ended,
                    "mission_completed": run.mission_completed,
                    "state": run.state,
                    "tasks": tasks,
                    "refused": list(run.refused),
                    "dropped": run.dropped,
                }
            )
        )
    else:
        for t in tasks:
            why = f": {t['reason']}" if t["reason"] else ""
            typer.echo(
                f"{t['task']} (attempt {t['attempt']}): {t['status']} {t['start_s']} -> {t['end_s']} s{why}"
            )
        if run.dropped:
            typer.echo(
                f"dropped {sum(run.dropped.values())} frames that failed authentication ("
                + ", ".join(f"{k} {v}" for k, v in sorted(run.dropped.items()))
                + ")"
            )
        typer.echo(f"mission {'ended' if run.mission_ended else 'did not end'}; {spec.name} is {run.state}")
    if not run.mission_ended:
        raise typer.Exit(1)
