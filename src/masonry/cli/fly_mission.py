"""``masonry fly --mission``: one UAV taking its tasks from mission control over Zenoh."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

import typer

from masonry.cli.fly_adapters import _describe, select_adapters
from masonry.cli.fly_tuning import fly_settings
from masonry.errors import LinkLost

if TYPE_CHECKING:
    from masonry.blueprint import Blueprint, UavSpec

#: Wall seconds a real autopilot's link may stay down with the UAV halted out of service before `masonry fly
#: --mission` ends with one line saying so (mission control has had its out-of-service heartbeats).
AUTOPILOT_GONE_S = 5.0


def _fly_mission(
    bp: Blueprint,
    spec: UavSpec,
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
            uav_settings=fly_settings(hardware, vehicle, adapters) if hardware is not None else None,
            max_wind_mps=hardware.max_wind_mps if hardware is not None else None,
            events_sink=mission_log,
            vehicle=vehicle,
            autopilot_gone_s=None if adapters is None or hardware.sim_fc else AUTOPILOT_GONE_S,
        )
    finally:
        if adapters is not None:
            adapters.close()
        if mission_log is not None:
            mission_log.close()
            typer.echo(f"wrote {log}", err=True)
    lockstep = _lockstep_of(adapters)
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
                    "lockstep": lockstep,
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
        if lockstep is not None:
            typer.echo(
                f"in lock-step with the SITL: {lockstep['grants']} grants, {lockstep['late_replies']} not answered "
                "within 2 s"
            )
        typer.echo(f"mission {'ended' if run.mission_ended else 'did not end'}; {spec.name} is {run.state}")
    if run.autopilot_lost:
        raise LinkLost(
            f"{spec.name}: its flight controller ({hardware.fc}) went silent and stayed so: the autopilot is gone "
            f"(its process ended, its link cut); {spec.name} is {run.state}, out of the mission"
        )
    if not run.mission_ended:
        raise typer.Exit(1)


def _lockstep_of(adapters: object) -> dict[str, int] | None:
    """How the UAV kept lock-step with a SITL that asked for it (``masonry sitl --lockstep``,
    docs/sitl-lockstep.md): the grants it sent and those not answered in time; None: no lock-step (a real
    autopilot, ArduCopter's SITL, ``--sim``)."""
    paced = getattr(getattr(adapters, "clock", None), "base", None)  # wiring.ZeroedClock over a LockstepClock
    if paced is None or not getattr(paced, "lockstep", False):
        return None
    return {"grants": int(paced.grants), "late_replies": int(paced.late_replies)}
