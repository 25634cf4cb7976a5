"""The two checks the mission report carries, computed from a trace of executed intervals.

Independent of the dispatcher that produced the trace: :func:`count_violations` (conflicting tasks that overlapped,
attempts started before a prerequisite completed) and, under the ``site`` reservation,
:func:`count_site_violations` (the same over the UAVs' work at their sites).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from masonry.planner.tasks import Plan


def count_violations(plan: Plan, intervals: Iterable[tuple[str, float, float | None]]) -> tuple[int, int]:
    """Conflict and dependency violations in a trace of executed intervals.

    Args:
        plan: the plan whose conflicts and dependencies are checked.
        intervals: (task id, start_s, end_s) for every attempt as the UAVs flew it; ``end_s`` None means
            still in progress at the end of the trace (open interval).

    Returns:
        (conflict_violations, dependency_violations): the number of pairs of conflicting tasks whose
        intervals overlap for a positive time (each pair counted once; a zero-length attempt, refused at
        once, was never in progress), and the number of attempts that started before every
        prerequisite had completed (a prerequisite done before the mission, ``done`` in the plan, counts as
        completed at -inf).
    """
    by_task: dict[str, list[tuple[float, float]]] = {}
    for task_id, start, end in intervals:
        by_task.setdefault(task_id, []).append((start, math.inf if end is None else end))
    conflicts = 0
    for a, b in plan.conflicts:
        ia, ib = by_task.get(a), by_task.get(b)
        if not ia or not ib:
            continue
        # Two attempts overlap when they share time: max(starts) < min(ends). An attempt refused at once
        # (start == end: a machine out of service, or of the wrong kind, reporting it failed when handed it)
        # was never in progress, so it overlaps nothing; any overlap of positive length is counted.
        if any(max(s1, s2) < min(e1, e2) for s1, e1 in ia for s2, e2 in ib):
            conflicts += 1
    # completion time of each task = end of its last interval (the successful one closes the task)
    pre_done = {t.id for t in plan.tasks if t.done}
    completion: dict[str, float] = {}
    for task_id, ivs in by_task.items():
        ends = [e for _, e in ivs if math.isfinite(e)]
        if ends:
            completion[task_id] = max(ends)
    prereqs: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        prereqs.setdefault(u, []).append(v)
    deps = 0
    for task_id, ivs in by_task.items():
        for start, _ in ivs:
            for v in prereqs.get(task_id, ()):
                if v in pre_done:
                    continue
                if completion.get(v, math.inf) > start:
                    deps += 1
                    break
    return conflicts, deps


def count_site_violations(
    plan: Plan,
    site_intervals: Iterable[tuple[str, float, float | None]],
    task_intervals: Iterable[tuple[str, float, float | None]],
) -> tuple[int, int]:
    """Violations under the ``site`` reservation: pairs of conflicting tasks whose *site* intervals overlap, and
    site intervals that started before a prerequisite completed (completions: the ends of ``task_intervals``,
    as in :func:`count_violations`)."""
    sites = list(site_intervals)
    conflicts, _ = count_violations(plan, sites)
    completion: dict[str, float] = {}
    for task_id, _start, end in task_intervals:
        if end is not None:
            completion[task_id] = max(completion.get(task_id, -math.inf), end)
    pre_done = {t.id for t in plan.tasks if t.done}
    prereqs: dict[str, list[str]] = {}
    for u, v in plan.dependencies:
        prereqs.setdefault(u, []).append(v)
    deps = sum(
        1
        for task_id, start, _end in sites
        if any(v not in pre_done and completion.get(v, math.inf) > start for v in prereqs.get(task_id, ()))
    )
    return conflicts, deps
