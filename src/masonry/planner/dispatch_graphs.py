"""The plan as the dispatcher reads it: tasks indexed, the graphs as adjacency lists, the chains (pure).

Built once per :class:`~masonry.planner.dispatch.Dispatcher`, in O(size of the plan) (docs/dispatch.md,
"Availability"): every task by its index in the plan, its role and the places it sends a UAV; for each task its
dependents, prerequisites and conflict neighbours; the critical path's bottom levels and their tie step; and,
for the ``site`` reservation's prefetch, the tasks whose prerequisites are all done or in progress.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass

from masonry.blueprint import ROLES
from masonry.errors import PlanningError
from masonry.planner.dispatch_values import DONE, PENDING, RUNNING, task_end_m, task_start_m
from masonry.planner.tasks import Plan, Task


@dataclass(frozen=True)
class TaskIndex:
    """Each task of a plan by its place in the plan: id, role, where its flight starts and ends, and the part
    of a brick flight that does not depend on the UAV (pickup -> drop-off; 0 for adhesion)."""

    ids: list[str]
    index: dict[str, int]
    roles: list[str]
    start_m: list[tuple[float, float, float]]
    end_m: list[tuple[float, float, float]]
    leg_m: list[float]


@dataclass(frozen=True)
class Adjacency:
    """The plan's graphs by task index: dependents and prerequisites (G^d), conflict neighbours (G^c)."""

    dependents: list[list[int]]
    prerequisites: list[list[int]]
    neighbours: list[list[int]]


def index_tasks(tasks: Sequence[Task]) -> TaskIndex:
    """Task ids, roles and the places a UAV flies to for each (one pass over the plan).

    Raises:
        PlanningError: two tasks with one id, or a task of an unknown kind.
    """
    n = len(tasks)
    ids = [t.id for t in tasks]
    index: dict[str, int] = {}
    for i, tid in enumerate(ids):
        if tid in index:
            raise PlanningError(f"plan has two tasks with id {tid!r}")
        index[tid] = i
    roles: list[str] = []
    for t in tasks:
        if t.kind not in ROLES:
            raise PlanningError(f"task {t.id}: unknown kind {t.kind!r}")
        roles.append(t.kind)
    start_m = [task_start_m(t) for t in tasks]
    end_m = [task_end_m(t) for t in tasks]
    leg_m = [math.dist(start_m[i], end_m[i]) if roles[i] == "brick" else 0.0 for i in range(n)]
    return TaskIndex(ids, index, roles, start_m, end_m, leg_m)


def adjacency(plan: Plan, index: Mapping[str, int]) -> Adjacency:
    """Adjacency, built once: O(size of the plan). Duplicate edges are dropped per task afterwards (cheaper
    than a global set of pairs on a wall with millions of conflicts).

    Raises:
        PlanningError: an edge names an unknown task or joins a task to itself.
    """
    n = len(plan.tasks)
    dependents: list[list[int]] = [[] for _ in range(n)]
    prerequisites: list[list[int]] = [[] for _ in range(n)]
    try:
        for u, v in plan.dependencies:
            iu, iv = index[u], index[v]
            if iu == iv:
                raise PlanningError(f"dependency ({u}, {v}): a task cannot depend on itself")
            dependents[iv].append(iu)
            prerequisites[iu].append(iv)
    except KeyError as exc:
        raise PlanningError(f"dependency names unknown task {exc.args[0]!r}") from None
    neighbours: list[list[int]] = [[] for _ in range(n)]
    try:
        for a, b in plan.conflicts:
            ia, ib = index[a], index[b]
            if ia == ib:
                raise PlanningError(f"conflict ({a}, {b}): a task cannot conflict with itself")
            neighbours[ia].append(ib)
            neighbours[ib].append(ia)
    except KeyError as exc:
        raise PlanningError(f"conflict names unknown task {exc.args[0]!r}") from None
    for lists in (dependents, prerequisites, neighbours):
        for i, items in enumerate(lists):
            if len(items) > 1 and len(set(items)) != len(items):
                lists[i] = list(dict.fromkeys(items))
    return Adjacency(dependents, prerequisites, neighbours)


def chains(tasks: Sequence[Task], graphs: Adjacency, durations_s: Mapping[str, float] | None) -> list[float]:
    """Longest remaining dependency chain from each task (its own duration included): the bottom level.

    Raises:
        PlanningError: a not-done task without a duration, a duration not finite and >= 0, or a cycle.
    """
    n = len(tasks)
    weight = [0.0] * n
    for i, t in enumerate(tasks):
        if t.done:
            continue
        if durations_s is None:
            weight[i] = 1.0
            continue
        if t.id not in durations_s:
            raise PlanningError(f"durations_s has no entry for task {t.id}")
        d = durations_s[t.id]
        try:
            d = float(d)
        except (TypeError, ValueError):
            raise PlanningError(f"durations_s[{t.id!r}] is not a number: {d!r}") from None
        if not math.isfinite(d) or d < 0.0:
            raise PlanningError(f"durations_s[{t.id!r}] must be finite and >= 0, got {d!r}")
        weight[i] = d
    dependents, prerequisites = graphs.dependents, graphs.prerequisites
    # Kahn's algorithm from the tasks nothing depends on, walking towards prerequisites.
    pending = [len(dependents[i]) for i in range(n)]
    order = [i for i in range(n) if pending[i] == 0]
    chain = [0.0] * n
    k = 0
    while k < len(order):
        i = order[k]
        k += 1
        best = 0.0
        for j in dependents[i]:
            best = max(best, chain[j])
        chain[i] = weight[i] + best
        for p in prerequisites[i]:
            pending[p] -= 1
            if pending[p] == 0:
                order.append(p)
    if len(order) != n:
        on_cycle = next(tasks[i].id for i in range(n) if pending[i] > 0)
        raise PlanningError(f"the dependency graph has a cycle through task {on_cycle}")
    return chain


def tie_step(tasks: Iterable[Task], durations_s: Mapping[str, float] | None) -> float:
    """The step in which critical-path compares chains: the median duration of a not-done task (1 unweighted)."""
    if durations_s is None:
        return 1.0
    values = sorted(float(durations_s[t.id]) for t in tasks if not t.done)
    values = [v for v in values if v > 0.0]
    return values[len(values) // 2] if values else 1.0


def prefetchable(
    role: str,
    running: Iterable[int],
    status: Sequence[int],
    roles: Sequence[str],
    graphs: Adjacency,
    ready_left: int = 0,
) -> list[int]:
    """Pending tasks of ``role`` depending on a ``running`` task whose every prerequisite is done or in progress
    (the ``site`` reservation's prefetch: a UAV fetches the brick while the task under it is flown), but up to
    ``ready_left`` of them *ready* instead: pending, of the other role (a segment, never a brick, which would need a
    UAV of the prefetching one's own role), their own prerequisites done (issue 27, branch ``pyr41``)."""
    out: list[int] = []
    seen: set[int] = set()
    for r in running:
        for d in graphs.dependents[r]:
            if d in seen or roles[d] != role or status[d] != PENDING:
                continue
            seen.add(d)
            left = [p for p in graphs.prerequisites[d] if status[p] not in (DONE, RUNNING)]
            if len(left) <= ready_left and all(
                roles[p] != role
                and status[p] == PENDING
                and all(status[q] == DONE for q in graphs.prerequisites[p])
                for p in left
            ):
                out.append(d)
    return out


__all__ = ["Adjacency", "TaskIndex", "adjacency", "chains", "index_tasks", "prefetchable", "tie_step"]
