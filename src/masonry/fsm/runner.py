"""The thin loop around a UAV model: tick it on an injected clock until its single task is over.

``run_single_task`` is the same loop for simulated time (``advance=world.step``: the world moves the clock and
the physics) and for wall time on a UAV (``advance=clock.sleep``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from masonry.errors import InvalidArgument
from masonry.fsm.adhesion import AdhesionUav
from masonry.fsm.brick import BrickUav
from masonry.fsm.config import UavConfig
from masonry.fsm.model import UavModel
from masonry.planner.tasks import Task
from masonry.ports import (
    Camera,
    ClearanceLink,
    Clock,
    FlightController,
    Gripper,
    MissionLink,
    Sprayer,
    TaskResult,
)

#: ``build_uav(clearance=FROM_LINK)``: the link is the clearance link too, if it is one (a mission handler).
FROM_LINK: Any = "from-link"


@dataclass(frozen=True)
class SingleTaskRun:
    """What one UAV did with one task: its result (None if the time ran out), trace and timing."""

    result: TaskResult | None
    trace: tuple[tuple[float, str], ...]
    start_s: float
    end_s: float
    final_state: str

    @property
    def duration_s(self) -> float:
        return self.end_s - self.start_s


def run_single_task(
    uav: UavModel,
    clock: Clock,
    *,
    dt_s: float = 0.05,
    advance: Callable[[float], None] | None = None,
    timeout_s: float = 900.0,
) -> SingleTaskRun:
    """Tick ``uav`` every ``dt_s`` until it has reported a result and is back to rest (landed or halted).

    Args:
        uav: a model whose link holds (or will hand out) the task.
        clock: the time source the model is ticked with.
        dt_s: control period, seconds.
        advance: moves time (and the world) by ``dt_s``; default ``clock.sleep``.
        timeout_s: give up after this much (simulated or wall) time; the run then has ``result=None``
            unless one was reported.
    """
    if not dt_s > 0.0:
        raise InvalidArgument(f"dt_s must be > 0, got {dt_s!r}")
    step_time = clock.sleep if advance is None else advance
    start_s = clock.now_s()
    n_results = len(uav.results)
    while True:
        now = clock.now_s()
        uav.step(now)
        reported = len(uav.results) > n_results
        if reported and uav.finished:
            break
        if now - start_s >= timeout_s:
            break
        step_time(dt_s)
    result = uav.results[n_results] if len(uav.results) > n_results else None
    return SingleTaskRun(result, tuple(uav.trace), start_s, clock.now_s(), uav.state)


def build_uav(
    config: UavConfig,
    *,
    fc: FlightController,
    link: MissionLink,
    clock: Clock,
    gripper: Gripper | None = None,
    camera: Camera | None = None,
    sprayer: Sprayer | None = None,
    clearance: ClearanceLink | None = FROM_LINK,
) -> UavModel:
    """The model for ``config.role`` on the given ports (a brick UAV needs a gripper and a camera, an adhesion
    UAV a sprayer).

    Args:
        clearance: mission control's airspace; None: no airspace, the UAV flies without separation from
            others (one UAV, or fixed ``lateral_altitude_m`` layers). By default the link, when it implements
            :class:`~masonry.ports.ClearanceLink` too (a :class:`~masonry.mission.handler.UavHandler`), else None.
    """
    if clearance is FROM_LINK:
        clearance = link if isinstance(link, ClearanceLink) else None
    if config.role == "brick":
        if gripper is None or camera is None:
            raise InvalidArgument(f"brick UAV {config.name} needs a gripper and a camera")
        return BrickUav(config, fc, gripper, camera, link, clock, clearance=clearance)
    if config.role == "adhesion":
        if sprayer is None:
            raise InvalidArgument(f"adhesion UAV {config.name} needs a sprayer")
        return AdhesionUav(config, fc, sprayer, link, clock, clearance=clearance)
    raise InvalidArgument(f"unknown UAV role {config.role!r}")


def fly_task(
    config: UavConfig,
    task: Task,
    *,
    fc: FlightController,
    clock: Clock,
    gripper: Gripper | None = None,
    camera: Camera | None = None,
    sprayer: Sprayer | None = None,
    dt_s: float = 0.05,
    advance: Callable[[float], None] | None = None,
    timeout_s: float = 900.0,
) -> SingleTaskRun:
    """Fly one task with one UAV from take-off to landing (``masonry fly``): connect, run, close.

    The task comes in through a :class:`~masonry.fakes.QueueMissionLink` holding just that task.
    """
    from masonry.fakes import QueueMissionLink

    link = QueueMissionLink([task])
    uav = build_uav(
        config, fc=fc, link=link, clock=clock, gripper=gripper, camera=camera, sprayer=sprayer, clearance=None
    )
    fc.connect()
    try:
        return run_single_task(uav, clock, dt_s=dt_s, advance=advance, timeout_s=timeout_s)
    finally:
        fc.close()
