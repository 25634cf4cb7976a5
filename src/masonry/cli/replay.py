"""``masonry replay``: a mission log (``--log FILE.mcap``) read back: the same summary, report and drawings as the
run that wrote it, or the mission's state at a time (``--at``)."""

from __future__ import annotations

import time
from pathlib import Path
from typing import TYPE_CHECKING

import typer

from masonry.cli.app import command
from masonry.cli.foxglove_options import (
    FOXGLOVE_CERT_OPTION,
    FOXGLOVE_KEY_OPTION,
    FOXGLOVE_OPTION,
    foxglove_option,
)
from masonry.cli.outputs import check_output_paths, write_mission_outputs
from masonry.errors import InputError

if TYPE_CHECKING:  # (the observe extra's modules load only when a log is replayed)
    from masonry.blueprint import Blueprint
    from masonry.cli.foxglove_options import FoxgloveAt
    from masonry.observe.mcap_log import RecordedMission
    from masonry.planner.tasks import Plan


@command("replay")
def replay(
    log: Path = typer.Argument(..., help="A mission log written with --log FILE.mcap."),
    fmt: str = typer.Option("text", "--format", help="text | json (the report, as the live run printed it)."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
    gantt: Path | None = typer.Option(None, "--gantt", help="Gantt chart (.png or .svg)."),
    plot3d: Path | None = typer.Option(None, "--plot3d", help="3-D plot of the wall and the paths (.png)."),
    at: float | None = typer.Option(
        None,
        "--at",
        metavar="T",
        help="Print the mission's state at mission time T (seconds) instead (with --airspace table: its "
        "reservation table too).",
    ),
    serve: str | None = typer.Option(
        None,
        "--serve",
        metavar="[HOST:]PORT",
        help="Play the log back in the live page, with a time slider, until Ctrl-C (docs/observe.md).",
    ),
    foxglove: str | None = FOXGLOVE_OPTION,
    foxglove_cert: Path | None = FOXGLOVE_CERT_OPTION,
    foxglove_key: Path | None = FOXGLOVE_KEY_OPTION,
    time_scale: float = typer.Option(
        1.0, "--time-scale", help="With --foxglove: log seconds per wall second of the playback."
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
    fox = foxglove_option(foxglove, foxglove_cert, foxglove_key)
    if not (math.isfinite(time_scale) and time_scale > 0):
        raise InputError(f"--time-scale must be a number > 0, got {time_scale!r}")
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
    the_plan = make_plan(bp)
    task_ids = [t.id for t in the_plan.tasks if not t.done]
    if at is not None:
        typer.echo("\n".join(view_at(recorded.events, at, task_ids, recorded.done).lines()))
        return
    if fox is not None:
        _foxglove(log, fox, time_scale)
        return
    if serve is not None:
        _serve(recorded, the_plan, bp, task_ids, serve)
        return
    if recorded.report is None and recorded.command.startswith("masonry fly"):
        raise InputError(
            f"{log}: a UAV's log (masonry fly) holds no mission report; --at T and --serve replay it"
        )
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


def _foxglove(log: Path, fox: FoxgloveAt, time_scale: float) -> None:
    """The log's channels, as recorded, on a Foxglove server: played at ``time_scale`` once a viewer subscribes,
    over and over (a viewer who joins late sees the next pass whole), until Ctrl-C."""
    import threading

    from masonry.observe.live import FoxgloveServer, serve_recorded
    from masonry.observe.mcap_log import iter_channel_messages

    messages = list(iter_channel_messages(log))
    viewer = threading.Event()
    server = FoxgloveServer(
        fox.host,
        fox.port,
        name=f"masonry replay {log.name}",
        tls=fox.tls,
        on_subscribe=lambda _t: viewer.set(),
    ).start()
    stop = threading.Event()
    try:
        for topic, schema, _, _ in messages:
            server.channel(topic, schema)
        typer.echo(
            f"playing {log} back to Foxglove at {server.url} (Open connection), over and over once a viewer "
            "subscribes: Ctrl-C to stop",
            err=True,
        )
        while not viewer.wait(0.5):
            pass
        while not stop.is_set():
            serve_recorded(server, messages, time_scale=time_scale, stop=stop)
            stop.wait(1.0)  # a pause between passes (Foxglove sees time go back to the start)
    except KeyboardInterrupt:
        stop.set()
    finally:
        server.stop()


def _serve(recorded: RecordedMission, the_plan: Plan, bp: Blueprint, task_ids: list[str], serve: str) -> None:
    """The log in the live page, at the slider's time, until Ctrl-C."""
    from masonry.mission.view import view_at, wall_layout
    from masonry.observe.web import ViewServer, parse_serve

    events = recorded.events
    end_s = max((e.time_s for e in events), default=0.0)
    server = ViewServer(
        *parse_serve(serve),
        layout=wall_layout(the_plan, bp.fleet, recorded.title),
        state=lambda t: view_at(events, end_s if t is None else t, task_ids, recorded.done).snapshot(),
        version=lambda: 0,
        replay=end_s,
    ).start()
    try:
        typer.echo(
            f"playing {recorded.path} back at {server.url} (0 to {end_s:.1f} s): Ctrl-C to stop", err=True
        )
        while True:
            time.sleep(0.5)
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
