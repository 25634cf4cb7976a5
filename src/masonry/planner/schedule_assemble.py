"""The offline schedule's result: the solved parts' starts and UAVs as an :class:`OfflineSchedule` with its bound."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from masonry.blueprint import UavSpec
from masonry.planner.bound_terms import bound_terms
from masonry.planner.bounds import min_cycles_s, min_durations_s, min_site_s
from masonry.planner.schedule_values import OfflineSchedule, ScheduledTask, UavSchedule
from masonry.planner.tasks import Plan
from masonry.timing import TaskTiming

if TYPE_CHECKING:
    from masonry.planner.schedule import _PartResult, _Problem


def _assemble(
    plan: Plan,
    fleet: Sequence[UavSpec],
    p: _Problem,
    parts: Sequence[Sequence[int]],
    last: _PartResult,
    reports: list[dict[str, object]],
    timing: TaskTiming,
    cruise_altitude_m: float,
    time_limit_s: float,
    seed: int,
    solve_s: float,
) -> OfflineSchedule:
    tick = p.tick_s
    makespan = max(p.end.values(), default=0) * tick
    md = min_durations_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m)
    site_w = (
        min_site_s(plan, timing=timing, cruise_altitude_m=cruise_altitude_m)
        if p.reservation == "site"
        else None
    )
    terms = bound_terms(
        plan, fleet, md, work_s=min_cycles_s(plan, fleet, md, timing=timing), clique_weights_s=site_w
    )
    whole = len(parts) == 1
    cp_bound = last.bound * tick if whole and last.bound is not None else None
    if p.deadlines.has_open:  # a mission is not a solution of a model with open times (docs/schedule.md)
        cp_bound = None
    bound, kind = terms.value_s, terms.kind
    if cp_bound is not None and cp_bound >= bound:
        bound, kind = cp_bound, "cp-sat"
    bound = min(bound, makespan) if whole and last.status == "optimal" else bound
    status = "optimal" if makespan <= bound + 1e-9 else "feasible"
    uavs = []
    for k, spec in enumerate(p.uavs):
        mine = sorted((i for i, u in p.uav_of.items() if u == k), key=lambda i: (p.start[i], i))
        uavs.append(
            UavSchedule(
                spec.name,
                spec.role,
                tuple(
                    ScheduledTask(
                        p.tasks[i].id,
                        p.start[i] * tick,
                        p.end[i] * tick,
                        p.site_start[i] * tick if p.reservation == "site" else None,
                        (p.site_start[i] + p.site[i]) * tick if p.reservation == "site" else None,
                    )
                    for i in mine
                ),
                tuple(w * tick for w in sorted(p.phys.swaps[k])) if p.phys is not None else (),
            )
        )
    return OfflineSchedule(
        uavs=tuple(uavs),
        makespan_s=makespan,
        bound_s=bound,
        bound_kind=kind,
        status=status,
        solve_time_s=solve_s,
        decomposition="none" if whole else "course",
        reservation=p.reservation,
        time_limit_s=time_limit_s,
        seed=seed,
        tick_s=tick,
        parts=tuple(reports) if not whole else (),
        physical=p.phys.terms if p.phys is not None else (),
    )
