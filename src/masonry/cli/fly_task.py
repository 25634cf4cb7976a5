"""``masonry fly``'s single-task mode (one task of the plan, its trace and result) and ``--identify``."""

from __future__ import annotations

import json
from dataclasses import replace
from typing import TYPE_CHECKING, Any

import typer

from masonry.cli.fly_adapters import _a, _describe, _pick_uav, _prerequisites, select_adapters
from masonry.cli.fly_tuning import fly_settings
from masonry.errors import InputError

if TYPE_CHECKING:
    from masonry.adapters.wiring import HardwareConfig
    from masonry.blueprint import Blueprint, UavSpec


def _identify(
    bp: Blueprint,
    spec: UavSpec,
    *,
    sim: bool,
    seed: int,
    camera: str,
    dt: float,
    fmt: str,
    hardware: HardwareConfig,
    vehicle: str,
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
        **fly_settings(hardware, vehicle, adapters),
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
    hardware: HardwareConfig,
    vehicle: str = "ideal",
) -> None:
    """Single-task mode: fly ``task`` with the UAV of role ``uav`` (``name``); print the trace and the result."""
    from masonry.fsm import UavConfig, blueprint_settings, fly_task
    from masonry.planner import plan

    the_plan = plan(bp)
    the_task = _pick_task(bp, the_plan, task, uav)
    spec = _pick_uav(bp, uav, name)

    # Single-task mode: every brick the task depends on is taken as already built.
    before = {t for t in _prerequisites(the_plan, task) if t.startswith("B")}
    bricks = tuple(replace(b, placed=True) if f"B{b.id}" in before else b for b in bp.bricks)
    world_bp = replace(bp, bricks=bricks)

    adapters = select_adapters(
        sim=sim, blueprint=world_bp, spec=spec, seed=seed, camera=camera, faults=faults, hardware=hardware,
        vehicle=vehicle,
    )  # fmt: skip
    # the blueprint's and its fleet's fields as the simulator's (the other UAVs' pads too, issue 27), the tuning over
    uav_config = UavConfig.from_spec(
        spec, **{**blueprint_settings(bp, spec), **fly_settings(hardware, vehicle, adapters)}
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
