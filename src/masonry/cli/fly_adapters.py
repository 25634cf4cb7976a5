"""The adapters of ``masonry fly`` (:func:`select_adapters`) and the picking of its UAV and task's prerequisites."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import typer

from masonry.cli.app import cli_text
from masonry.cli.fly_tuning import with_tuning_line
from masonry.errors import InputError
from masonry.ports import UavPorts

Adapters = UavPorts

if TYPE_CHECKING:
    from masonry.adapters.wiring import HardwareConfig


def select_adapters(
    *,
    sim: bool,
    blueprint: Any,
    spec: Any,
    seed: int,
    camera: str,
    faults: Any,
    hardware: Any = None,
    vehicle: str = "ideal",
) -> UavPorts:
    """Choose and build the adapters for the UAV ``spec``: the simulated world (``--sim``), or each port on its
    own (``hardware``: a :class:`masonry.adapters.wiring.HardwareConfig` from --fc/--actuators/--camera), checked
    by the pre-flight check (printed on stderr; a failure refuses to arm).
    """
    if hardware is not None and not hardware.all_sim:
        from masonry.adapters.wiring import open_adapters, preflight

        opened = open_adapters(hardware, blueprint=blueprint, spec=spec, seed=seed, faults=faults)
        try:
            report = preflight(
                opened,
                hardware,
                role=spec.role,
                progress=lambda line: typer.echo(line, err=True),
                site=getattr(blueprint, "site", None),
            )
            report = with_tuning_line(report, hardware, vehicle, opened)
            for line in report.lines():
                typer.echo(cli_text(line, report.options), err=True)
            report.raise_if_failed()
        except BaseException:
            opened.close()
            raise
        return opened
    if not sim:
        raise InputError(
            "no adapters chosen: pass --sim to fly in the simulated world, or pick hardware with "
            "--fc URL / --actuators PORT / --camera INDEX|FILE"
        )
    from masonry.sim import World
    from masonry.sim.vehicle_config import vehicle_preset

    world = World(blueprint, seed=seed, camera=camera, faults=faults, vehicle=vehicle_preset(vehicle))  # type: ignore[arg-type]
    faults.check_uavs([spec.name])
    return world.add_uav(spec).ports


def _check_vehicle(vehicle: str | None, sim: bool = True) -> str:
    """``--vehicle``: one of the simulated presets, and only for a simulated flight controller; the preset to fly
    (unset: ``DEFAULT_VEHICLE`` in simulation; ``ideal``, the default tuning, on a real autopilot)."""
    from masonry.sim.vehicle_config import VEHICLE_PRESETS, vehicle_name

    if vehicle is not None and vehicle not in VEHICLE_PRESETS:
        raise InputError(f"--vehicle must be one of {', '.join(VEHICLE_PRESETS)}, got {vehicle!r}")
    if vehicle not in (None, "ideal") and not sim:
        raise InputError("--vehicle picks the simulated autopilot: it needs --sim (a real one is what it is)")
    return vehicle_name(vehicle) if sim else "ideal"


def _a(word: str) -> str:
    return ("an " if word[:1] in "aeiou" else "a ") + word


def _pick_uav(blueprint: Any, role: str, name: str | None) -> Any:
    if name is not None:
        for spec in blueprint.fleet:
            if spec.name == name:
                if spec.role != role:
                    raise InputError(f"--name {name}: {name} is {_a(spec.role)} UAV, not {_a(role)} UAV")
                return spec
        raise InputError(
            f"--name {name}: no UAV of that name in the fleet of {blueprint.source} "
            f"({', '.join(u.name for u in blueprint.fleet) or 'empty fleet'})"
        )
    for spec in blueprint.fleet:
        if spec.role == role:
            return spec
    raise InputError(f"{blueprint.source}: the fleet has no {role} UAV")


def _prerequisites(plan: Any, task_id: str) -> set[str]:
    """Every task ``task_id`` depends on, directly or not."""
    after: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        after.setdefault(u, []).append(v)
    seen: set[str] = set()
    stack = list(after.get(task_id, ()))
    while stack:
        t = stack.pop()
        if t not in seen:
            seen.add(t)
            stack.extend(after.get(t, ()))
    return seen


def _describe(hw: HardwareConfig) -> str:
    return f"fc {hw.fc}, actuators {hw.actuators}, camera {hw.camera}"
