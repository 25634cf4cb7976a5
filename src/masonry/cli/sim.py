"""``masonry sim``: a whole mission in simulated time, with the real state machines and mission control."""

from __future__ import annotations

import contextlib
from pathlib import Path
from typing import Any

import typer

from masonry.cli.app import command
from masonry.cli.options import check_all, help_text
from masonry.cli.outputs import check_output_paths, write_mission_outputs
from masonry.errors import InputError
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S


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
    policy: str = typer.Option("critical-path", "--policy", help="fifo | critical-path | nearest."),
    reservation: str = typer.Option(
        "task",
        "--reservation",
        help="task | site: keep conflicting tasks apart for their whole duration, as the paper (task), or "
        "only while their UAVs work at their sites (site). docs/safety.md.",
    ),
    seed: int = typer.Option(0, "--seed", help=help_text("sim", "--seed", "Seed of the simulated world.")),
    camera: str = typer.Option("geometric", "--camera", help="geometric | render (images + ArUco, slower)."),
    fault: list[str] = typer.Option(
        [],
        "--fault",
        metavar="KEY=VALUE",
        help="KEY=VALUE, repeatable: grasp=0.3, dropout=0.5, "
        "occlusion=0.3, gusts=2.0, uav-loss=brick-2@120, link-loss=NAME@S, battery=R.",
    ),
    journal: Path | None = typer.Option(None, "--journal", help="SQLite journal of the mission."),
    resume: bool = typer.Option(False, "--resume", help="Continue the mission recorded in --journal."),
    fmt: str = typer.Option("text", "--format", help="text | json."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
    gantt: Path | None = typer.Option(None, "--gantt", help="Gantt chart (.png or .svg)."),
    plot3d: Path | None = typer.Option(None, "--plot3d", help="3-D plot of the wall and the paths (.png)."),
    dt: float = typer.Option(0.05, "--dt", help=help_text("sim", "--dt", "Simulation tick, seconds.")),
    stall_timeout: float = typer.Option(
        DEFAULT_STALL_TIMEOUT_S,
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
    from masonry.mission.simulate import SimulatedMission
    from masonry.sim import Faults

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if reservation not in ("site", "task"):
        raise InputError(f"--reservation must be site or task, got {reservation!r}")
    check_all(
        "sim",
        {
            "--brick-uavs": brick_uavs,
            "--adhesion-uavs": adhesion_uavs,
            "--seed": seed,
            "--dt": dt,
            "--stall-timeout": stall_timeout,
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
    bp = load_blueprint(blueprint)
    faults = Faults.parse(fault)
    name = bp.name or blueprint.name

    from masonry.cli.progress import progress_display

    progress_cb, finish = progress_display(progress)
    try:
        mission = SimulatedMission.from_blueprint(
            bp,
            brick_uavs=brick_uavs,
            adhesion_uavs=adhesion_uavs,
            policy=policy,
            seed=seed,
            camera=camera,
            faults=faults,
            journal_path=journal,
            resume=resume,
            dt_s=dt,
            progress=progress_cb,
            warn=lambda m: typer.echo(f"warning: {m}", err=True),
            stall_timeout_s=stall_timeout,
            reservation=reservation,
        )
        with contextlib.ExitStack() as watchers:
            if log is not None:
                mission_log = watchers.enter_context(open_log(log, mission.plan, blueprint, name, "sim"))
                mission.control.sink = mission_log
            result = mission.run()
            if log is not None:
                mission_log.finish(result)
    finally:
        finish()
    if log is not None:
        typer.echo(f"wrote {log}", err=True)
    write_mission_outputs(result, bp, name, fmt=fmt, report=report, gantt=gantt, plot3d=plot3d)
    if not result.completed:
        raise typer.Exit(1)  # the report is printed; the status says the wall is not finished


def open_log(path: Path, plan: Any, blueprint: Path, name: str, command: str) -> Any:
    """The MCAP log of a mission (``--log``), to open (``with``): it records the blueprint file's text for ``masonry replay``."""
    try:
        from masonry.observe.mcap_log import McapLog
    except ImportError as exc:  # the `observe` extra is not installed
        raise InputError(f"--log needs the mcap package (pip install 'masonry[observe]'): {exc}") from None
    from masonry.blueprint_yaml import read_text_limited

    return McapLog(
        path, plan, read_text_limited(blueprint), title=name, command=f"masonry {command} {blueprint}"
    )


def check_log_option(log: Path | None) -> Path | None:
    """``--log``, if given, must name a ``.mcap`` file (returned as given)."""
    if log is not None and log.suffix.lower() != ".mcap":
        raise InputError(f"--log {log}: the file must end in .mcap")
    return log
