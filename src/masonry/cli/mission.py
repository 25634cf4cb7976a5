"""``masonry mission-control``: mission control as its own process, talking to UAV handlers over Zenoh."""

from __future__ import annotations

import logging
import time
from pathlib import Path

import typer

from masonry.cli.app import command
from masonry.cli.options import check_all, help_text, plural
from masonry.errors import InputError


@command("mission-control")
def mission_control(
    blueprint: Path = typer.Argument(..., help="Wall blueprint (YAML or JSON); its fleet is the mission's fleet."),
    listen: list[str] = typer.Option(["tcp/0.0.0.0:7447"], "--listen", help="Zenoh endpoint(s) to listen on."),
    connect: list[str] = typer.Option([], "--connect", help="Zenoh endpoint(s) of peers to connect to."),
    journal: Path | None = typer.Option(None, "--journal", help="SQLite journal of the mission."),
    resume: bool = typer.Option(False, "--resume", help="Continue the mission recorded in --journal."),
    policy: str = typer.Option("critical-path", "--policy", help="fifo | critical-path | nearest."),
    mission_name: str = typer.Option("default", "--mission-name", help="Mission name (Zenoh key prefix)."),
    time_scale: float = typer.Option(1.0, "--time-scale", help=help_text(
        "mission-control", "--time-scale", "Mission seconds per wall second (match the UAVs' --time-scale when "
        "they are simulated faster than real time).")),
    heartbeat_timeout: float = typer.Option(5.0, "--heartbeat-timeout", help=help_text(
        "mission-control", "--heartbeat-timeout", "Wall seconds of silence before a UAV is lost.")),
    startup_timeout: float = typer.Option(60.0, "--startup-timeout", help=help_text(
        "mission-control", "--startup-timeout",
        "Wall seconds to wait for the whole fleet before starting without the rest.")),
    max_time: float | None = typer.Option(None, "--max-time", help=help_text(
        "mission-control", "--max-time", "Give up after this many mission seconds.")),
    tick: float = typer.Option(0.05, "--tick", help=help_text("mission-control", "--tick", "Control period, seconds.")),
    fmt: str = typer.Option("text", "--format", help="text | json (the report at the end)."),
    report: Path | None = typer.Option(None, "--report", help="Write the JSON report to this file."),
    verbose: bool = typer.Option(False, "--verbose", "-v", help="Log every event on stderr."),
) -> None:
    """Run mission control in wall time: dispatch the blueprint's tasks to UAV handlers over Zenoh."""
    from masonry.blueprint import load_blueprint
    from masonry.mission.control import MissionControl
    from masonry.mission.journal import Journal
    from masonry.mission.messages import MISSION_CONTROL
    from masonry.mission.report import control_report
    from masonry.mission.simulate import POLICIES, priority_durations_s
    from masonry.mission.zenoh_transport import ZenohTransport
    from masonry.planner import estimate_durations_s
    from masonry.planner import plan as make_plan

    if fmt not in ("text", "json"):
        raise InputError(f"--format must be text or json, got {fmt!r}")
    if policy not in POLICIES:
        raise InputError(f"--policy must be one of {', '.join(POLICIES)}, got {policy!r}")
    if resume and journal is None:
        raise InputError("--resume needs --journal FILE")
    check_all("mission-control", {"--time-scale": time_scale, "--heartbeat-timeout": heartbeat_timeout,
                                  "--startup-timeout": startup_timeout, "--max-time": max_time, "--tick": tick})
    logging.basicConfig(level=logging.INFO if verbose else logging.WARNING, format="%(asctime)s %(message)s")
    bp = load_blueprint(blueprint)
    the_plan = make_plan(bp)

    jr = None
    state = None
    if journal is not None:
        from masonry.errors import JournalError

        existed = journal.exists() and journal.stat().st_size > 0
        if resume and not existed:
            raise JournalError(f"{journal}: no journal to resume from")
        jr = Journal(journal).open()
        if existed:
            state = jr.replay()
            if not resume and not state.empty:
                jr.close()
                raise JournalError(f"{journal} already holds a mission: pass --resume to continue it, "
                                   "or give another --journal file")
            if not resume:
                state = None
    expected_s = estimate_durations_s(the_plan, bp.fleet, cruise_altitude_m=bp.cruise_altitude_m)
    from masonry.mission.airspace import layer_base_m

    transport = ZenohTransport(MISSION_CONTROL, listen=listen, connect=connect, mission=mission_name)
    transport.connect()
    try:
        mc = MissionControl(the_plan, bp.fleet, transport, policy=policy, journal=jr,
                            durations_s=priority_durations_s(
                                expected_s),
                            heartbeat_timeout_s=heartbeat_timeout * time_scale,
                            startup_timeout_s=startup_timeout * time_scale,
                            column_radius_m=bp.clearance_m, layer_base_m=layer_base_m(bp),
                            layer_floor_m=bp.cruise_altitude_m)
        offset = 0.0
        if state is not None:
            mc.restore(state)
            offset = state.last_time_s
        typer.echo(f"mission control listening on {', '.join(listen)}: {plural(sum(1 for t in the_plan.tasks if not t.done), 'task')}, "
                   f"fleet {', '.join(u.name for u in bp.fleet)}"
                   + (f", resumed at {offset:.1f} s" if state is not None else ""), err=True)
        t0 = time.monotonic()
        linger_until = None
        while True:
            now = offset + (time.monotonic() - t0) * time_scale
            mc.step(now)
            if mc.ended_at_s is not None:
                # keep answering heartbeats a moment so every handler hears MissionEnd
                linger_until = linger_until or now + 2.0 * time_scale
                if now >= linger_until:
                    break
            if max_time is not None and now - offset >= max_time:
                break
            time.sleep(tick)
    finally:
        transport.close()
        if jr is not None:
            jr.close()
    result = control_report(mc, the_plan, policy=policy, durations_s=expected_s)
    if report is not None:
        report.write_text(result.to_json(indent=1) + "\n")
        typer.echo(f"wrote {report}", err=True)
    typer.echo(result.to_json() if fmt == "json" else result.summary())
    if not result.completed:
        raise typer.Exit(1)
