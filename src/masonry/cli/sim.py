"""``masonry sim``: a whole mission in simulated time, with the real state machines and mission control."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import typer

from masonry.cli.app import command
from masonry.cli.foxglove_options import (
    FOXGLOVE_CERT_OPTION,
    FOXGLOVE_KEY_OPTION,
    FOXGLOVE_OPTION,
    foxglove_option,
)
from masonry.cli.options import check_all, check_choice, help_text
from masonry.cli.outputs import check_output_paths, write_mission_outputs
from masonry.cli.watch import check_log_option
from masonry.cli.wind_options import TURBULENCE_OPTION, WIND_OPTION, site_faults
from masonry.errors import InputError
from masonry.mission.sim_options import SimOptions

#: ``masonry sim``'s defaults are the library's (:class:`masonry.mission.sim_options.SimOptions`)
_DEFAULTS = SimOptions()


@command("sim")
def sim(
    blueprint: Path = typer.Argument(..., help="Wall blueprint (YAML or JSON)."),
    brick_uavs: int | None = typer.Option(
        None,
        "--brick-uavs",
        help=help_text("sim", "--brick-uavs", "Number of brick UAVs (overrides the fleet)."),
    ),
    adhesion_uavs: int | None = typer.Option(
        None,
        "--adhesion-uavs",
        help=help_text("sim", "--adhesion-uavs", "Number of adhesion UAVs (overrides the fleet)."),
    ),
    policy: str = typer.Option(
        _DEFAULTS.policy,
        "--policy",
        help="fifo | critical-path | nearest | schedule (follow --schedule, falling back to critical-path).",
    ),
    schedule_file: Path | None = typer.Option(
        None,
        "--schedule",
        help="Offline schedule (JSON from masonry schedule) that --policy schedule follows.",
    ),
    reservation: str = typer.Option(
        _DEFAULTS.reservation,
        "--reservation",
        help="task | site: keep conflicting tasks apart for their whole duration, as the paper (task), or "
        "only while their UAVs work at their sites (site). docs/safety.md.",
    ),
    airspace: str = typer.Option(
        _DEFAULTS.airspace,
        "--airspace",
        help="columns | table: grant flights column by column with hold points (columns), or plan each flight "
        "as timed legs reserved in a space-time table, waiting on the ground or at the site (table). "
        "docs/safety.md.",
    ),
    table_dispatch: str = typer.Option(
        _DEFAULTS.table_dispatch,
        "--table-dispatch",
        help="soonest | policy: with --airspace table, give a brick UAV, of the policy's top few, the task it "
        "can finish soonest by the table (soonest), or the policy's pick (policy). docs/dispatch.md.",
    ),
    seed: int = typer.Option(
        _DEFAULTS.seed, "--seed", help=help_text("sim", "--seed", "Seed of the simulated world.")
    ),
    camera: str = typer.Option(
        _DEFAULTS.camera,
        "--camera",
        help="geometric | render (images + ArUco, slower) | mixed (images + ArUco over the pickups of 10 bricks).",
    ),
    fault: list[str] = typer.Option(
        [],
        "--fault",
        metavar="KEY=VALUE",
        help="KEY=VALUE, repeatable: grasp=0.3, dropout=0.5, "
        "occlusion=0.3, gusts=2.0, uav-loss=brick-2@120, link-loss=NAME@S, battery=R.",
    ),
    wind: str | None = WIND_OPTION,
    turbulence: str | None = TURBULENCE_OPTION,
    journal: Path | None = typer.Option(None, "--journal", help="SQLite journal of the mission."),
    resume: bool = typer.Option(False, "--resume", help="Continue the mission recorded in --journal."),
    fmt: str = typer.Option("text", "--format", help="text | json."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
    gantt: Path | None = typer.Option(None, "--gantt", help="Gantt chart (.png or .svg)."),
    plot3d: Path | None = typer.Option(None, "--plot3d", help="3-D plot of the wall and the paths (.png)."),
    dt: float = typer.Option(
        _DEFAULTS.dt_s, "--dt", help=help_text("sim", "--dt", "Simulation tick, seconds.")
    ),
    stall_timeout: float = typer.Option(
        _DEFAULTS.stall_timeout_s,
        "--stall-timeout",
        help=help_text(
            "sim",
            "--stall-timeout",
            "Stop the mission, not completed, when nothing progresses for this many simulated seconds, and "
            "report who waits for whom (`stall` in the JSON); 0: never.",
        ),
    ),
    log: Path | None = typer.Option(
        None,
        "--log",
        metavar="FILE.mcap",
        help="Write the mission's log to this MCAP file (Foxglove opens it; `masonry replay` reads it back; "
        "docs/logging.md).",
    ),
    serve: str | None = typer.Option(
        None,
        "--serve",
        metavar="[HOST:]PORT",
        help="Serve the mission's live page here (host 127.0.0.1 by default) and fly it at --time-scale; "
        "docs/observe.md.",
    ),
    foxglove: str | None = FOXGLOVE_OPTION,
    foxglove_cert: Path | None = FOXGLOVE_CERT_OPTION,
    foxglove_key: Path | None = FOXGLOVE_KEY_OPTION,
    time_scale: float = typer.Option(
        1.0,
        "--time-scale",
        help=help_text(
            "sim",
            "--time-scale",
            "With --serve or --foxglove: mission seconds per wall second (1: real time, to watch).",
        ),
    ),
    vehicle: str | None = typer.Option(
        None,
        "--vehicle",
        help="arducopter (default) | ideal: the simulated autopilot (arducopter: its setpoint shaping, delay and "
        "GPS-like noise, fitted to ArduCopter SITL, flown with the arducopter control preset; ideal: a 0.3 s "
        "first-order velocity lag, the project's old model).",
    ),
    progress: bool | None = typer.Option(
        None,
        "--progress/--no-progress",
        help="Progress on stderr: a line "
        "every few seconds (--progress), or nothing (--no-progress). Default: a "
        "bar with an ETA on a terminal, the lines when stderr is not one.",
    ),
) -> None:
    """Simulate a whole mission: plan, dispatch, fly every UAV, report (makespan, errors, safety checks).

    Exit status 0 when the wall is complete, 1 when it is not (stuck tasks are listed; a stalled mission says
    who waits for whom), 2 on bad input.
    """
    from masonry.blueprint import load_blueprint
    from masonry.cli.fly import _check_vehicle

    vehicle = _check_vehicle(vehicle)
    from masonry.mission.simulate import SimulatedMission

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    check_choice("--reservation", reservation, ("site", "task"))
    check_choice("--airspace", airspace, ("columns", "table"))
    check_choice("--table-dispatch", table_dispatch, ("soonest", "policy"))
    check_all(
        "sim",
        {
            "--brick-uavs": brick_uavs,
            "--adhesion-uavs": adhesion_uavs,
            "--seed": seed,
            "--dt": dt,
            "--stall-timeout": stall_timeout,
            "--time-scale": time_scale,
        },
    )
    for opt, p, exts in (("--gantt", gantt, (".png", ".svg")), ("--plot3d", plot3d, (".png", ".svg"))):
        if p is not None and p.suffix.lower() not in exts:
            raise InputError(f"{opt} {p}: the file must end in {' or '.join(exts)}")
    # before the work: a long simulation must not end in an unwritable report
    check_output_paths(
        [("--report", report), ("--gantt", gantt), ("--plot3d", plot3d), ("--log", check_log_option(log))]
    )
    if journal is not None and any(
        p is not None and p.resolve() == journal.resolve() for p in (report, gantt, plot3d, log)
    ):
        raise InputError(f"--journal {journal}: the same file as an output")
    if (policy == "schedule") != (schedule_file is not None):
        raise InputError("--policy schedule and --schedule FILE go together")
    faults = site_faults(fault, wind, turbulence)
    fox = foxglove_option(foxglove, foxglove_cert, foxglove_key)
    bp = load_blueprint(blueprint)
    offline = None
    if schedule_file is not None:
        from masonry.mission.schedule_file import read_schedule

        offline = read_schedule(schedule_file)
    # the one place the flags become the library's options (the library checks them: one line, the flag named)
    options = SimOptions(
        brick_uavs=brick_uavs,
        adhesion_uavs=adhesion_uavs,
        policy=policy,
        seed=seed,
        camera=camera,
        journal_path=journal,
        resume=resume,
        dt_s=dt,
        stall_timeout_s=stall_timeout,
        reservation=reservation,
        vehicle=vehicle,
        airspace=airspace,
        table_dispatch=table_dispatch,
    )
    name = bp.name or blueprint.name

    from masonry.cli.progress import progress_display
    from masonry.cli.watch import Watchers
    from masonry.observe.web import Pacer, parse_serve

    watch = Watchers(
        log, parse_serve(serve) if serve is not None else None, blueprint, name, "sim", foxglove=fox
    )
    watched = serve is not None or fox is not None
    progress_cb, finish = progress_display(progress)
    try:
        mission = SimulatedMission.from_blueprint(
            bp,
            options,
            faults=faults,
            progress=progress_cb,
            warn=lambda m: typer.echo(f"warning: {m}", err=True),
            schedule=offline,
        )
        watch.attach(mission.control, mission.plan, mission.fleet)
        if watched:
            mission.tick_hooks.append(Pacer(time_scale))
        with _keys(mission, watched):
            result = mission.run()
        watch.finish(result)
    except BaseException:
        watch.stop()
        raise
    finally:
        finish()
        watch.close()
    write_mission_outputs(result, bp, name, fmt=fmt, report=report, gantt=gantt, plot3d=plot3d)
    watch.linger()
    if not result.completed:
        raise typer.Exit(1)  # the report is printed; the status says the wall is not finished


def _keys(mission: Any, served: bool) -> Any:
    """The operator's keys in the terminal while a served mission runs (``masonry.cli.keys``)."""
    if not served:
        return contextlib.nullcontext()
    from masonry.cli.keys import TerminalKeys

    return TerminalKeys(
        mission.control.operator, [u.name for u in mission.fleet], lambda m: typer.echo(m, err=True)
    )
