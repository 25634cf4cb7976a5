"""``masonry mission-control``: mission control as its own process, talking to UAV handlers over Zenoh.

``masonry keygen``: a new mission key for ``--key-file`` (docs/security.md).
"""

from __future__ import annotations

import logging
import time
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
from masonry.cli.options import check_all, check_choice, help_text, plural
from masonry.errors import InputError
from masonry.mission.fleet_clock import UNLOOKED_S, FleetClock
from masonry.mission.stall import DEFAULT_STALL_TIMEOUT_S

DEFAULT_LISTEN = "tcp/127.0.0.1:7447"
#: Wall seconds mission control answers on after its MissionEnd at the least, so that every handler hears it (then
#: until every UAV has landed: MissionControl.may_leave).
END_HEARD_S = 2.0


def network_options(key_file: Path | None, insecure: bool, endpoints: list[str], what: str) -> bytes | None:
    """The mission key from ``--key-file`` (None without one), after refusing a non-loopback endpoint without it.

    Shared by ``mission-control`` and ``fly --mission`` (docs/security.md).
    """
    from masonry.errors import MissionError
    from masonry.mission.auth import load_key, require_key_or_loopback
    from masonry.mission.zenoh_transport import check_endpoint

    try:
        for e in endpoints:
            check_endpoint(e)
    except MissionError as exc:
        raise InputError(str(exc)) from None
    key = load_key(key_file) if key_file is not None else None
    require_key_or_loopback(key, insecure, endpoints, what)
    if key is None and insecure:
        typer.echo(
            "warning: --insecure: mission messages are not authenticated; anyone who reaches "
            f"{', '.join(endpoints) or 'this process'} can command the mission",
            err=True,
        )
    return key


def security_summary(transport: object, ignored: dict[str, int] | None = None) -> dict[str, dict[str, int]]:
    """Frames dropped by the authentication layer and results ignored by mission control, by reason."""
    dropped = dict(getattr(transport, "dropped", {}) or {})
    return {"dropped": dropped, "ignored": dict(ignored or {})}


@command("keygen")
def keygen(
    output: Path = typer.Option(..., "--output", "-o", help="Key file to write (64 hex digits, mode 0600)."),
    force: bool = typer.Option(False, "--force", help="Replace an existing key file."),
) -> None:
    """Write a new random mission key (32 bytes) for --key-file of mission-control and fly --mission."""
    from masonry.mission.auth import write_key_file

    write_key_file(output, force=force)
    typer.echo(f"wrote {output} (copy it to every UAV of the mission; keep it private)", err=True)


@command("mission-control")
def mission_control(
    blueprint: Path = typer.Argument(
        ..., help="Wall blueprint (YAML or JSON); its fleet is the mission's fleet."
    ),
    listen: list[str] = typer.Option(
        [DEFAULT_LISTEN],
        "--listen",
        help="Zenoh endpoint(s) to listen on "
        "(a real interface, e.g. tcp/10.0.0.1:7447, needs --key-file or --insecure).",
    ),
    connect: list[str] = typer.Option([], "--connect", help="Zenoh endpoint(s) of peers to connect to."),
    key_file: Path | None = typer.Option(
        None,
        "--key-file",
        help="Mission key (masonry keygen -o FILE): every message is authenticated with it.",
    ),
    insecure: bool = typer.Option(False, "--insecure", help="Allow non-loopback endpoints without a key."),
    zenoh_config: Path | None = typer.Option(
        None,
        "--zenoh-config",
        help="Zenoh configuration file (JSON5): TLS, access control (docs/security.md).",
    ),
    journal: Path | None = typer.Option(None, "--journal", help="SQLite journal of the mission."),
    resume: bool = typer.Option(False, "--resume", help="Continue the mission recorded in --journal."),
    policy: str = typer.Option("critical-path", "--policy", help="fifo | critical-path | nearest."),
    mission_name: str = typer.Option("default", "--mission-name", help="Mission name (Zenoh key prefix)."),
    time_scale: float = typer.Option(
        1.0,
        "--time-scale",
        help=help_text(
            "mission-control",
            "--time-scale",
            "Mission seconds per wall second until the UAVs report (match the UAVs' --time-scale or their "
            "SITL's speed-up); then mission time follows their own clocks, the slowest's.",
        ),
    ),
    heartbeat_timeout: float = typer.Option(
        5.0,
        "--heartbeat-timeout",
        help=help_text(
            "mission-control", "--heartbeat-timeout", "Wall seconds of silence before a UAV is lost."
        ),
    ),
    startup_timeout: float = typer.Option(
        60.0,
        "--startup-timeout",
        help=help_text(
            "mission-control",
            "--startup-timeout",
            "Wall seconds to wait for the whole fleet before starting without the rest, and for a role's last "
            "UAV declared lost to rejoin (--time-scale times as many mission seconds).",
        ),
    ),
    max_time: float | None = typer.Option(
        None,
        "--max-time",
        help=help_text("mission-control", "--max-time", "Give up after this many mission seconds."),
    ),
    tick: float = typer.Option(
        0.05, "--tick", help=help_text("mission-control", "--tick", "Control period, seconds.")
    ),
    stall_timeout: float = typer.Option(
        DEFAULT_STALL_TIMEOUT_S,
        "--stall-timeout",
        help=help_text(
            "mission-control",
            "--stall-timeout",
            "Stop the mission, not completed, when nothing progresses for this many mission seconds, and "
            "report who waits for whom (`stall` in the JSON); not counted while a wait with a known end is "
            "open (a lost UAV's rejoin window); 0: never.",
        ),
    ),
    reservation: str = typer.Option(
        "site",
        "--reservation",
        help="task | site: keep conflicting tasks apart for their whole duration (task, the paper) or only "
        "while their UAVs work at their sites (site). docs/safety.md.",
    ),
    airspace: str = typer.Option(
        "columns",
        "--airspace",
        help="columns | table: grant flights column by column with hold points (columns), or plan each flight "
        "as timed legs reserved in a space-time table, waiting on the ground or at the site (table). "
        "docs/safety.md.",
    ),
    table_dispatch: str = typer.Option(
        "soonest",
        "--table-dispatch",
        help="soonest | policy: with --airspace table, give a brick UAV, of the policy's top few, the task it "
        "can finish soonest by the table (soonest), or the policy's pick (policy). docs/dispatch.md.",
    ),
    fmt: str = typer.Option("text", "--format", help="text | json (the report at the end)."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
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
        help="Serve the mission's live page here (host 127.0.0.1 by default); docs/observe.md.",
    ),
    foxglove: str | None = FOXGLOVE_OPTION,
    foxglove_cert: Path | None = FOXGLOVE_CERT_OPTION,
    foxglove_key: Path | None = FOXGLOVE_KEY_OPTION,
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log every event on stderr."),
) -> None:
    """Run mission control in wall time: dispatch the blueprint's tasks to UAV handlers over Zenoh."""
    from masonry.blueprint import load_blueprint
    from masonry.cli.outputs import check_output_paths, write_mission_outputs
    from masonry.cli.watch import Watchers, check_log_option
    from masonry.fingerprint import wall_digest
    from masonry.mission.control import MissionControl
    from masonry.mission.messages import MISSION_CONTROL
    from masonry.mission.simulate import priority_durations_s
    from masonry.mission.zenoh_transport import ZenohTransport
    from masonry.observe.web import parse_serve
    from masonry.planner import POLICIES, estimate_durations_s
    from masonry.planner import plan as make_plan

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if policy not in POLICIES:
        raise InputError(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    if resume and journal is None:
        raise InputError("--resume needs --journal FILE")
    for flag, value, choices in (
        ("--reservation", reservation, ("site", "task")),
        ("--airspace", airspace, ("columns", "table")),
        ("--table-dispatch", table_dispatch, ("soonest", "policy")),
    ):
        check_choice(flag, value, choices)
    check_all(
        "mission-control",
        {
            "--time-scale": time_scale,
            "--heartbeat-timeout": heartbeat_timeout,
            "--startup-timeout": startup_timeout,
            "--max-time": max_time,
            "--tick": tick,
            "--stall-timeout": stall_timeout,
        },
    )
    check_output_paths([("--report", report), ("--log", check_log_option(log))])
    key = network_options(key_file, insecure, [*listen, *connect], "--listen/--connect")
    fox = foxglove_option(foxglove, foxglove_cert, foxglove_key)
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(asctime)s %(message)s")
    bp = load_blueprint(blueprint)
    the_plan = make_plan(bp)

    jr, state = _open_journal(journal, resume, bp, the_plan, reservation)
    expected_s = estimate_durations_s(the_plan, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m)
    from masonry.mission.airspace import layer_base_m, transit_layers_m
    from masonry.mission.auth import wrap
    from masonry.planner import min_durations_s

    zenoh = ZenohTransport(
        MISSION_CONTROL, listen=listen, connect=connect, mission=mission_name, config_file=zenoh_config
    )
    transport = wrap(zenoh, key, mission_name)
    watch = Watchers(
        log,
        parse_serve(serve) if serve else None,
        blueprint,
        bp.name or blueprint.name,
        "mission-control",
        foxglove=fox,
    )
    zenoh.connect()
    try:
        mc = MissionControl(
            the_plan,
            bp.fleet,
            transport,
            policy=policy,
            journal=jr,
            durations_s=priority_durations_s(expected_s),
            heartbeat_timeout_s=heartbeat_timeout * time_scale,
            startup_timeout_s=startup_timeout * time_scale,
            column_radius_m=bp.clearance_m,
            layer_base_m=layer_base_m(bp),
            layer_floor_m=bp.cruise_altitude_m,
            wall_digest=wall_digest(bp),
            min_durations_s=min_durations_s(the_plan, cruise_altitude_m=bp.cruise_altitude_m),
            stall_timeout_s=stall_timeout,
            reservation=reservation,
            airspace=airspace,
            table_dispatch=table_dispatch,
            fence=bp.site,
            # the layer each `masonry fly --mission` UAV flies at without mission control (remote.py's)
            fallback_layers_m=transit_layers_m(bp),
            placement=bp.placement,
        )
        offset = 0.0
        if state is not None:
            mc.restore(state)
            offset = state.last_time_s
        watch.attach(mc, the_plan, bp.fleet)  # (after the restore: a resumed mission's done tasks show done)
        typer.echo(
            f"mission control listening on {', '.join(listen)}: {plural(sum(1 for t in the_plan.tasks if not t.done), 'task')}, "
            f"fleet {', '.join(u.name for u in bp.fleet)}"
            + (f", resumed at {offset:.1f} s" if state is not None else "")
            + (", messages authenticated" if key is not None else ", messages NOT authenticated"),
            err=True,
        )
        _run_in_wall_time(mc, offset, time_scale=time_scale, max_time_s=max_time, tick_s=tick)
        result, security = _final_report(mc, the_plan, policy, expected_s, transport, watch)
    except BaseException:
        watch.stop()
        raise
    finally:
        transport.close()
        if jr is not None:
            jr.close()
        watch.close()
    _echo_security(security)
    write_mission_outputs(
        result,
        bp,
        bp.name or blueprint.name,
        fmt=fmt,
        report=report,
        gantt=None,
        plot3d=None,
        extra={"security": security},
    )
    watch.linger()
    if not result.completed:
        raise typer.Exit(1)


def _final_report(mc: Any, the_plan: Any, policy: str, expected_s: Any, transport: Any, watch: Any) -> Any:
    """The mission's report and security counts, also into the log."""
    from masonry.mission.report import control_report

    # the least separation of two airborne UAVs, from their positions as heard (no world to measure it in)
    sep = mc.heard_separation.min_separation_m
    result = control_report(mc, the_plan, policy=policy, durations_s=expected_s, min_separation_m=sep)
    security = security_summary(transport, mc.events.ignored)
    watch.finish(result, {"security": security})
    return result, security


def _open_journal(
    journal: Path | None, resume: bool, bp: Any, the_plan: Any, reservation: str
) -> tuple[Any, Any]:
    """The mission's journal and its replayed state (None, None without ``--journal``)."""
    if journal is None:
        return None, None
    from masonry.fingerprint import fleet_digest, wall_digest
    from masonry.mission.journal import open_mission_journal

    # the journal knows its wall and fleet: a resume with another blueprint is refused (exit 2)
    return open_mission_journal(
        journal,
        resume=resume,
        wall_digest=wall_digest(bp),
        fleet_digest=fleet_digest(bp),
        fleet_names=[u.name for u in bp.fleet],
        task_ids=[t.id for t in the_plan.tasks],
        reservation=reservation,
        warn=lambda m: typer.echo(f"warning: {m}", err=True),
    )


def _run_in_wall_time(
    mc: Any, offset_s: float, *, time_scale: float, max_time_s: float | None, tick_s: float
) -> None:
    """Step mission control every ``tick_s`` of wall time until it ends and every UAV has landed
    (:meth:`~masonry.mission.control.MissionControl.may_leave`), or ``--max-time``, on mission time that follows the
    UAVs' own clocks (:class:`~masonry.mission.fleet_clock.FleetClock`, from ``offset_s``): their
    autopilots' on hardware and on a SITL, so a SITL slowed by a loaded machine slows the mission equally."""
    # a gap of several ticks between two readings is this process left unrun, not the UAVs' silence
    clock = FleetClock(time_scale, start_s=offset_s, unlooked_s=max(UNLOOKED_S, 4.0 * tick_s))
    mc.heard_clock = clock.heard
    while True:
        now = clock.now_s()
        mc.step(now)
        # after the end, answering on (heartbeats, the flights home's clearances) until every UAV has landed
        if mc.may_leave(now, END_HEARD_S * time_scale):
            break
        if max_time_s is not None and now - offset_s >= max_time_s:
            break
        time.sleep(tick_s)


def _echo_security(security: dict[str, dict[str, int]]) -> None:
    """One stderr line per non-empty count of :func:`security_summary`."""
    for what, counts in security.items():
        if counts:
            typer.echo(
                f"{what} {sum(counts.values())} "
                + ("frames that failed authentication" if what == "dropped" else "results")
                + f" ({', '.join(f'{k} {v}' for k, v in sorted(counts.items()))})",
                err=True,
            )
