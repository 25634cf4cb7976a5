"""``masonry sitl``: the simulator's UAV behind a real MAVLink 2 endpoint, for trying ``masonry fly --fc`` on a PC."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import typer

from masonry.cli.app import command
from masonry.cli.options import check, help_text
from masonry.errors import InputError

#: ``--lockstep``: the longest wall time (s) the SITL waits at a grant for the next before it runs free (a client
#: waiting on its own wall clock, e.g. for a take-off; the flying loop grants every step, 20-50 times a second).
LOCKSTEP_WAIT_S = 1.0


def sitl_home(blueprint: Any, role: str, name: str | None) -> tuple[tuple[float, float, float], str]:
    """The home (and name) of the UAV a SITL stands in for: ``name`` or the first of ``role`` in the fleet."""
    for spec in blueprint.fleet:
        if (name is None and spec.role == role) or spec.name == name:
            if spec.role != role:
                article = "an" if spec.role[:1] in "aeiou" else "a"
                raise InputError(
                    f"--name {name}: {name} is not a {role} UAV (it is {article} {spec.role} UAV)"
                )
            return tuple(spec.home_m), spec.name
    who = f"named {name}" if name is not None else f"of role {role}"
    raise InputError(f"{blueprint.source}: the fleet has no UAV {who}")


def build_sitl(
    *,
    port: int,
    host: str = "127.0.0.1",
    uav: str = "brick",
    blueprint: Path | None = None,
    name: str | None = None,
    time_scale: float = 1.0,
    signing_key: Path | None = None,
    prearm_failure: str | None = None,
    seed: int = 0,
    autopilot: str | None = None,
    vehicle: str = "ideal",
    log: Any = None,
    lockstep: bool = False,
) -> tuple[Any, str]:
    """The MavlinkSitl ``masonry sitl`` runs (not started) and a one-line description of it.

    ``vehicle`` (``--vehicle``): the simulated vehicle's preset with the autopilot knobs that come with it
    (``px4``: PX4 v1.16 on GNSS, and ``autopilot`` px4 unless given); ``autopilot`` default: the preset's, else
    ardupilot. ``lockstep`` (``--lockstep``): simulated time waits for the client's grants
    (:mod:`masonry.adapters.sitl_lockstep`), each wait at most :data:`LOCKSTEP_WAIT_S` of wall.
    """
    from masonry.adapters.mavlink import load_signing_key
    from masonry.adapters.sitl import SITL_PRESETS, MavlinkSitl, SitlConfig

    if uav not in ("brick", "adhesion"):
        raise InputError(f"--uav must be brick or adhesion, got {uav!r}")
    if vehicle not in SITL_PRESETS:
        raise InputError(f"--vehicle must be one of {', '.join(SITL_PRESETS)}, got {vehicle!r}")
    preset = dict(SITL_PRESETS[vehicle])
    autopilot = autopilot if autopilot is not None else str(preset.pop("autopilot", "ardupilot"))
    preset.pop("autopilot", None)
    if autopilot not in ("ardupilot", "px4"):
        raise InputError(f"--autopilot must be ardupilot or px4, got {autopilot!r}")
    check("sitl", "--port", port)
    check("sitl", "--time-scale", time_scale)
    check("sitl", "--seed", seed)
    home: tuple[float, float, float] = (0.0, 0.0, 0.0)
    who = f"a {uav} UAV"
    if blueprint is not None:
        from masonry.blueprint import load_blueprint

        bp = load_blueprint(blueprint)
        home, uav_name = sitl_home(bp, uav, name)
        who = f"{uav_name} ({uav}) of {bp.source}"
    key = load_signing_key(signing_key) if signing_key is not None else None
    sitl = MavlinkSitl(
        port,
        host,
        home_m=home,
        time_scale=time_scale,
        signing_key=key,
        config=SitlConfig(prearm_failure=prearm_failure, autopilot=autopilot, **preset),
        seed=seed,
        log=log,
        lockstep_wait_s=LOCKSTEP_WAIT_S if lockstep else None,
    )
    description = (
        f"SITL: {who} at ({home[0]:.2f}, {home[1]:.2f}, {home[2]:.2f}) m, "
        f"{'PX4' if autopilot == 'px4' else 'ArduCopter'}-style MAVLink 2 to "
        f"udp {host}:{port}{' (signed)' if key else ''}, x{time_scale:g} real time"
        + (f", vehicle {vehicle}" if vehicle != "ideal" else "")
        + (", in lock-step with its client" if lockstep else "")
    )
    return sitl, description


@command("sitl")
def sitl(
    port: int = typer.Option(
        14550,
        "--port",
        help=help_text("sitl", "--port", "UDP port the ground station listens on (the SITL sends there)."),
    ),
    host: str = typer.Option("127.0.0.1", "--host", help="Address of the ground station."),
    uav: str = typer.Option("brick", "--uav", help="brick | adhesion: which fleet member to stand in for."),
    blueprint: Path | None = typer.Option(None, "--blueprint", help="Start at this blueprint's UAV home."),
    name: str | None = typer.Option(
        None, "--name", help="The UAV of the fleet (default: the first of --uav)."
    ),
    time_scale: float = typer.Option(
        1.0, "--time-scale", help=help_text("sitl", "--time-scale", "Simulated seconds per wall second.")
    ),
    signing_key: Path | None = typer.Option(
        None, "--signing-key", help="MAVLink 2 signing key file (32 bytes, 64 hex digits, or a passphrase)."
    ),
    prearm_failure: str | None = typer.Option(
        None, "--prearm-failure", help="Refuse every arming with this reason (to rehearse a pre-arm failure)."
    ),
    seed: int = typer.Option(
        0, "--seed", help=help_text("sitl", "--seed", "Seed of the motion-capture noise.")
    ),
    autopilot: str | None = typer.Option(
        None,
        "--autopilot",
        help="ardupilot (GUIDED) | px4 (OFFBOARD); default: the --vehicle's, else ardupilot.",
    ),
    vehicle: str = typer.Option(
        "ideal",
        "--vehicle",
        help="ideal | arducopter | px4: the simulated vehicle (px4: PX4 v1.16 on GNSS: EKF2's flags, the ground "
        "0.5 m up in its frame, a thrust ramp on take-off, GNSS-grade noise; --autopilot px4).",
    ),
    lockstep: bool = typer.Option(
        False,
        "--lockstep",
        help="Lock-step: simulated time waits for the flying client (`masonry fly` grants it each step, "
        "docs/sitl-lockstep.md); a client silent for 1 s of wall leaves it running free until it grants again.",
    ),
) -> None:
    """Run a simulated ArduCopter over MAVLink 2 until Ctrl-C: `masonry fly --fc udpin:0.0.0.0:PORT` flies it."""
    server, description = build_sitl(
        port=port,
        host=host,
        uav=uav,
        blueprint=blueprint,
        name=name,
        time_scale=time_scale,
        signing_key=signing_key,
        prearm_failure=prearm_failure,
        seed=seed,
        autopilot=autopilot,
        vehicle=vehicle,
        log=typer.echo,
        lockstep=lockstep,
    )
    typer.echo(description)
    typer.echo(f"fly it with: masonry fly --fc udpin:0.0.0.0:{port} ... (Ctrl-C to stop)")
    try:
        server.serve_forever()
    finally:  # on Ctrl-C too: whether its client (a `masonry fly`, in a mission or not) paced it
        if server.lockstep is not None:
            typer.echo(server.lockstep.summary())
