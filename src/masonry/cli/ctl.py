"""``masonry ctl``: an operator's command to a running mission control over its Zenoh link (docs/observe.md)."""

from __future__ import annotations

import secrets
import time
from pathlib import Path

import typer

from masonry.cli.app import command
from masonry.cli.options import check_all, help_text
from masonry.errors import InputError

#: How often an unanswered command is sent again (mission control answers a repeated one without applying it).
RESEND_S = 0.5


@command("ctl")
def ctl(
    what: str = typer.Argument(
        ..., metavar="COMMAND", help="pause | resume | abort | recall | return-all | limit."
    ),
    uav: str | None = typer.Argument(None, metavar="[UAV]", help="The UAV to recall (recall only)."),
    mission: str = typer.Option(
        ..., "--mission", help="Mission control's Zenoh endpoint, e.g. tcp/HOST:7447."
    ),
    key_file: Path | None = typer.Option(
        None, "--key-file", help="The mission's key (as mission-control's --key-file): the command is signed."
    ),
    insecure: bool = typer.Option(False, "--insecure", help="Allow a non-loopback endpoint without a key."),
    zenoh_config: Path | None = typer.Option(
        None,
        "--zenoh-config",
        help="Zenoh configuration file (JSON5): TLS, access control (docs/security.md).",
    ),
    mission_name: str = typer.Option("default", "--mission-name", help="Mission name (Zenoh key prefix)."),
    role: str | None = typer.Option(None, "--role", help="limit: the role (brick | adhesion)."),
    limit: int | None = typer.Option(
        None, "--limit", help="limit: how many UAVs of --role may fly tasks at once (-1: no limit)."
    ),
    timeout: float = typer.Option(
        10.0,
        "--timeout",
        help=help_text("ctl", "--timeout", "Wall seconds to wait for mission control's answer."),
    ),
) -> None:
    """Send one operator command to a running mission and print mission control's answer.

    Exit status 0 when it is accepted, 1 when it is refused (the reason is printed) or not answered in time, 2 on
    bad input.
    """
    from masonry.cli.mission import network_options
    from masonry.mission.auth import wrap
    from masonry.mission.messages import (
        MISSION_CONTROL,
        OPERATOR,
        OPERATOR_COMMANDS,
        CommandAnswer,
        OperatorCommand,
        decode,
        encode,
    )
    from masonry.mission.zenoh_transport import ZenohTransport

    if what not in OPERATOR_COMMANDS:
        raise InputError(f"COMMAND must be one of {', '.join(OPERATOR_COMMANDS)}, got {what!r}")
    if (what == "recall") != (uav is not None):
        raise InputError(
            "recall needs the UAV to recall (masonry ctl recall brick-1 ...); only recall takes one"
        )
    if (what == "limit") != (role is not None and limit is not None):
        raise InputError(
            "limit needs --role and --limit (masonry ctl limit --role brick --limit 2 ...); only limit"
        )
    check_all("ctl", {"--timeout": timeout})
    key = network_options(key_file, insecure, [mission], "--mission")
    zenoh = ZenohTransport(OPERATOR, connect=[mission], mission=mission_name, config_file=zenoh_config)
    transport = wrap(zenoh, key, mission_name)
    zenoh.connect()
    cid = secrets.token_hex(8)
    answer: CommandAnswer | None = None
    try:
        deadline = time.monotonic() + timeout
        sent_at = -RESEND_S
        while answer is None and time.monotonic() < deadline:
            if time.monotonic() - sent_at >= RESEND_S:
                sent_at = time.monotonic()
                msg = OperatorCommand(OPERATOR, what, time.time(), cid, uav=uav, role=role, limit=limit)
                transport.send(MISSION_CONTROL, encode(msg))
            for raw in transport.receive():
                try:
                    got = decode(raw)
                except Exception:
                    continue
                if isinstance(got, CommandAnswer) and got.id == cid:
                    answer = got
            time.sleep(0.05)
    finally:
        transport.close()
    if answer is None:
        dropped = getattr(transport, "dropped", None)
        hint = " (frames failed authentication: is --key-file the mission's key?)" if dropped else ""
        typer.echo(f"error: no answer from mission control at {mission} in {timeout:g} s{hint}", err=True)
        raise typer.Exit(1)
    target = f" {uav}" if uav else (f" {role} {limit}" if what == "limit" else "")
    if not answer.accepted:
        typer.echo(f"{what}{target}: refused: {answer.reason}")
        raise typer.Exit(1)
    typer.echo(f"{what}{target}: accepted")
