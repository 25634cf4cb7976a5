"""Dispatch that looks at the table (issue 27 §1.6; docs/dispatch.md, "Airspace-aware dispatch under the table").

Under ``--airspace table`` the dispatcher's :attr:`~masonry.planner.dispatch.Dispatcher.soonest` is set to
:func:`choose`: of the few tasks the policy ranks alike (its pick first, then the nearest others:
:data:`masonry.planner.dispatch_ranking.CHOOSE_AMONG`), a brick UAV is given the one it could finish soonest by the
reservations the table holds now (:func:`masonry.reservation.soonest_order`: each site visit's flight planned as
``decide`` would, from where the UAV stays, nothing reserved), ties by the policy's order. The policy's priorities
hold (critical-path's chain step; fifo has no ties to break). A sprayer keeps the policy's pick, its run's head: by
the soonest finish it sprayed its runs backwards (pyramid 4 + 2 +3.9 %, 12 m wall 4 + 2 +4.5 %, seeds 1-3; the 12 m
wall at 8 + 4 -15.8 % with the brick UAVs' choice alone, docs/performance/fleet.md). Under the columns nothing
changes. Pure: no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from masonry.mission.reserved import TableClearance
from masonry.planner.tasks import BrickTask, Task
from masonry.reservation import Place, Work, soonest_order
from masonry.timing import DEFAULT_TIMING, TaskTiming

if TYPE_CHECKING:
    from masonry.mission.control import MissionControl

__all__ = ["DEFAULT_TABLE_DISPATCH", "TABLE_DISPATCHES", "choose", "install", "visits"]

#: How mission control under ``--airspace table`` dispatches (``SimOptions.table_dispatch``, ``masonry sim
#: --table-dispatch``): ``soonest``, a brick UAV given the task it can finish soonest by the table (:func:`choose`),
#: or ``policy``, the policy's pick as under the columns.
TABLE_DISPATCHES = ("soonest", "policy")
DEFAULT_TABLE_DISPATCH = "soonest"


def install(mc: MissionControl, table_dispatch: str = DEFAULT_TABLE_DISPATCH) -> None:
    """Set ``mc``'s dispatcher to choose by the table (:func:`choose`) if its airspace is a table with airspace
    rules and ``table_dispatch`` is ``soonest``; else nothing (the columns, or ``policy``: the policy's pick)."""
    c = mc.columns
    if table_dispatch == "soonest" and isinstance(c, TableClearance) and c.base_m is not None:
        mc.dispatcher.soonest = lambda uav, ids: choose(mc, c, uav, ids)


def choose(mc: MissionControl, c: TableClearance, uav: str, ids: Sequence[str]) -> int:
    """The index in ``ids`` (the policy's order) of the task ``uav`` could finish soonest by ``c``'s table."""
    if not isinstance(mc.tasks[ids[0]], BrickTask):
        return 0  # a sprayer keeps the policy's pick, its run's head: the soonest broke its runs (docs/dispatch.md)
    start = _start(mc, c, uav)
    if start is None:
        return 0
    timing = mc.timing or DEFAULT_TIMING
    top_m = c.layer_base_m if c.layer_base_m is not None else start.z_m
    candidates = [visits(mc.tasks[i], top_m, c.zone_r_m, timing) for i in ids]
    best, _done = soonest_order(c.guarded_for(uav), uav, start, candidates, c.now_s, c.airspace)
    return best


def visits(task: Task, top_m: float, radius_m: float, timing: TaskTiming = DEFAULT_TIMING) -> list[Work]:
    """``task``'s site visits as the table's work (up to ``top_m``, zones ``radius_m`` wide): a brick's pickup and
    drop-off (a descent and a climb each, settled, gripped or released), an adhesion segment sprayed along."""
    if isinstance(task, BrickTask):
        out = []
        dwell = timing.settle_time_s + 2 * timing.descent_duration_s
        if task.pickup_m is not None:
            pickup = (float(task.pickup_m[0]), float(task.pickup_m[1]))
            out.append(Work(pickup, top_m, dwell + timing.grasp_dwell_s, radius_m=radius_m, task=task.id))
        drop = (float(task.position_m[0]), float(task.position_m[1]))
        out.append(Work(drop, top_m, dwell + timing.release_dwell_s, radius_m=radius_m, task=task.id))
        return out
    a, b = (float(task.start_m[0]), float(task.start_m[1])), (float(task.end_m[0]), float(task.end_m[1]))
    spray_s = task.length_m / timing.spray_speed_mps
    work_s = timing.stable_time_s + timing.spray_descent_s + spray_s + timing.close_dwell_s
    return [Work(a, top_m, work_s, to_xy=b if a != b else None, radius_m=radius_m, task=task.id)]


def _start(mc: MissionControl, c: TableClearance, uav: str) -> Place | None:
    """Where ``uav`` stays (the place its next flight starts from): over its pad at the home layer when landed, the
    end of the column (or segment) it holds, else where it was last heard; None: not known."""
    stay = c.table.stay_of(uav)
    if stay is not None:
        v = stay.volume
        if v.kind == "ground":
            top = c.base_m if c.base_m is not None else v.z1_m
            return Place(v.a, top, "site")
        return Place(v.b, v.z1_m, "site")
    p = mc.uavs[uav].position_m
    return None if p is None else Place((float(p[0]), float(p[1])), float(p[2]), "site")
