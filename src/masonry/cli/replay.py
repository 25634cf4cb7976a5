"""``masonry replay``: a mission log (``--log FILE.mcap``) read back: the same summary, report and drawings as the
run that wrote it, or the mission's state at a time (``--at``)."""

from __future__ import annotations

from pathlib import Path

import typer

from masonry.cli.app import command
from masonry.cli.outputs import check_output_paths, write_mission_outputs
from masonry.errors import InputError


@command("replay")
def replay(
    log: Path = typer.Argument(..., help="A mission log written with --log FILE.mcap."),
    fmt: str = typer.Option("text", "--format", help="text | json (the report, as the live run printed it)."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
    gantt: Path | None = typer.Option(None, "--gantt", help="Gantt chart (.png or .svg)."),
    plot3d: Path | None = typer.Option(None, "--plot3d", help="3-D plot of the wall and the paths (.png)."),
    at: float | None = typer.Option(
        None, "--at", metavar="T", help="Print the mission's state at mission time T (seconds) instead."
    ),
) -> None:
    """Replay a mission log: print the summary (or JSON) and write the report and drawings the live run did.

    Exit status 0 when the logged mission completed, 1 when it did not, 2 on a bad file.
    """
    import math

    from masonry.blueprint import parse_blueprint
    from masonry.blueprint_yaml import safe_load
    from masonry.mission.view import view_at
    from masonry.planner import plan as make_plan

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if at is not None and not math.isfinite(at):
        raise InputError(f"--at must be a finite time in seconds, got {at!r}")
    for opt, p in (("--gantt", gantt), ("--plot3d", plot3d)):
        if p is not None and p.suffix.lower() not in (".png", ".svg"):
            raise InputError(f"{opt} {p}: the file must end in .png or .svg")
    check_output_paths([("--report", report), ("--gantt", gantt), ("--plot3d", plot3d)])
    try:
        from masonry.observe.mcap_log import read_log
    except ImportError as exc:
        raise InputError(
            f"masonry replay needs the mcap package (pip install 'masonry[observe]'): {exc}"
        ) from None
    recorded = read_log(log)
    try:
        bp = parse_blueprint(safe_load(recorded.blueprint_yaml), f"{log} (its blueprint)")
    except Exception as exc:  # a YAML error or a BlueprintError: the log's record is bad
        raise InputError(f"{log}: its blueprint record is unusable: {exc}") from None
    if at is not None:
        the_plan = make_plan(bp)
        view = view_at(recorded.events, at, [t.id for t in the_plan.tasks if not t.done])
        typer.echo("\n".join(view.lines()))
        return
    if recorded.report is None:
        raise InputError(
            f"{log}: the log ends before the mission's report (the run was cut short); --at T still reads it"
        )
    write_mission_outputs(
        recorded.report,
        bp,
        recorded.title,
        fmt=fmt,
        report=report,
        gantt=gantt,
        plot3d=plot3d,
        extra=recorded.extra,
    )
    if not recorded.report.completed:
        raise typer.Exit(1)
