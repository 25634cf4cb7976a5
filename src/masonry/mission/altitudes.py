"""Work altitudes and transit layers: how high a UAV works at each task of a wall, and where layer 0 is
(:class:`masonry.mission.airspace.ColumnClearance` hands out the layers). Pure: no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from masonry.blueprint import Blueprint, UavSpec
from masonry.errors import InvalidArgument
from masonry.planner.tasks import BrickTask, Task
from masonry.separation import LAYER_SPACING_M
from masonry.timing import DEFAULT_TIMING, TaskTiming

#: Vertical distance between two transit layers: the 1 m separation target plus tracking error and gusts.
DEFAULT_LAYER_SPACING_M = LAYER_SPACING_M


def work_altitude_m(blueprint: Blueprint, *, timing: TaskTiming | None = None) -> float:
    """The highest altitude at which a UAV works any task of ``blueprint`` (cruise altitude at least).

    The same formulas as the state machines' site altitudes (``masonry.fsm``, flying ``timing``, default:
    ``UavConfig``'s): a brick UAV keeps the carried brick ``clearance_m`` above the drop-off
    (:meth:`TaskTiming.carry_altitude_m`), an adhesion UAV its nozzle ``clearance_m`` above the spraying height
    (:meth:`TaskTiming.spray_altitude_m`).
    """
    t = DEFAULT_TIMING if timing is None else timing
    z = float(blueprint.cruise_altitude_m)
    for b in blueprint.bricks:
        size_z = float(b.size_m[2])
        z = max(z, _work_altitude_over_m(float(b.position_m[2]) + size_z / 2.0, size_z, t))
    return z


def task_work_altitude_m(task: Task, cruise_altitude_m: float, *, timing: TaskTiming | None = None) -> float:
    """The highest altitude at which a UAV works ``task``, as :func:`work_altitude_m` counts it for its brick
    (a brick task: carrying its brick over its drop-off, and spraying on its top later) or its surface (an
    adhesion task); at least ``cruise_altitude_m``.

    Once the task is assigned its brick may be on the wall: a transit layer at or above this clears it.
    """
    t = DEFAULT_TIMING if timing is None else timing
    if isinstance(task, BrickTask):
        size_z = float(task.size_m[2])
        top = float(task.position_m[2]) + size_z / 2.0
        return max(float(cruise_altitude_m), _work_altitude_over_m(top, size_z, t))
    surface = max(float(task.start_m[2]), float(task.end_m[2]))
    return max(float(cruise_altitude_m), _work_altitude_over_m(surface, 0.0, t))


def _work_altitude_over_m(top_m: float, size_z_m: float, timing: TaskTiming) -> float:
    """Where a UAV works over a brick top at ``top_m``: carrying a brick ``size_z_m`` high down onto it (0: no
    brick), or spraying it."""
    z = timing.spray_altitude_m(top_m)
    if size_z_m > 0.0:
        z = max(z, timing.carry_altitude_m(top_m, size_z_m))
    return z


def layer_base_m(blueprint: Blueprint, *, timing: TaskTiming | None = None) -> float:
    """Altitude of transit layer 0 for ``blueprint``: :func:`work_altitude_m` (the spacing of the layers above it
    has its own margin over the separation target)."""
    return work_altitude_m(blueprint, timing=timing)


def transit_layers_m(
    blueprint: Blueprint,
    fleet: Sequence[UavSpec] | None = None,
    spacing_m: float = DEFAULT_LAYER_SPACING_M,
    *,
    timing: TaskTiming | None = None,
) -> dict[str, float]:
    """Altitude of each UAV's lateral legs: ``work_altitude_m + (k + 1) * spacing_m``, k its index in ``fleet``.

    ``fleet`` defaults to the blueprint's. A UAV flying its own mission process (``masonry fly --mission``) gets
    the same layer as in ``masonry sim``, because both number the blueprint's fleet the same way. ``timing``:
    the UAVs' (default: ``UavConfig``'s), for the work altitude.
    """
    if not (spacing_m >= 0.0 and math.isfinite(spacing_m)):
        raise InvalidArgument(f"layer spacing must be a finite number >= 0, got {spacing_m!r}")
    members = tuple(blueprint.fleet if fleet is None else fleet)
    base = layer_base_m(blueprint, timing=timing)
    return {u.name: base + (k + 1) * spacing_m for k, u in enumerate(members)}


__all__ = [
    "DEFAULT_LAYER_SPACING_M",
    "layer_base_m",
    "task_work_altitude_m",
    "transit_layers_m",
    "work_altitude_m",
]
