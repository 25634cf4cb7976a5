"""Chaining adhesion segments in dispatch (issue 27; docs/dispatch.md, "Chaining adhesion segments"; pure).

An adhesion UAV that is given, within ``chain_wait_s`` of closing its valve, the segment that starts where its
nozzle ended sprays it without climbing out and coming down again (:mod:`masonry.fsm.adhesion`, "chaining"): a
``chain_descent_s`` descent instead of the climb, the transit, the hover and the ``spray_descent_s`` descent,
about 4 s instead of 12 on the bundled pyramid. The overlaps of one course are contiguous segments, each starting
where the one before ends, and the critical path ranks them alike; only the tie-break decides their order, and
the shortest flight to a segment's *start* sends a UAV into a run from its far end (the last segment's start is
the nearest), so it sprays the run backwards, 0.3 m between one segment's end and the next one's start: no chain.

Among the tasks the policy ranks alike (its candidates), :func:`chain_pick` therefore prefers, for a UAV still
near the end of the adhesion segment it has just sprayed, the segment starting there; and otherwise it enters
the run of the nearest candidate up to ``HEAD_DETOUR_M`` further back (predecessor by predecessor), so that it
chains along the run from there. Tasks with no segment (bricks) have no links: their choice is the shortest
flight, as before. The policy's ranking always comes first (critical-path's chain step, fifo's plan order).
"""

from __future__ import annotations

import math
from collections.abc import Collection, Sequence

from masonry.planner.tasks import AdhesionTask, Task

#: Two segment ends closer than this are one point (the plan writes both from the same brick edge).
LINK_TOLERANCE_M = 1e-3
#: A UAV whose reported position is within this (horizontally) of the end of the segment it has just sprayed is
#: still there (its body is above its nozzle; the adhesion UAV's nozzle hangs below it).
NEAR_END_M = 0.5
#: How much longer a flight the UAV takes to enter a run of contiguous segments further back than the nearest one,
#: so that it sprays along the run (chained) instead of against it. Measured (docs/performance/fleet.md,
#: "Chaining adhesion segments"): going back to the run's head whatever the distance cost the 12 m wall 8 % at 1 + 1.
HEAD_DETOUR_M = 0.75


def segment_links(tasks: Sequence[Task]) -> tuple[list[tuple[int, ...]], list[tuple[int, ...]]]:
    """For each task, the adhesion tasks starting where it ends (successors) and those ending where it starts
    (predecessors); empty for a brick task. O(n): the segment ends are hashed to ``LINK_TOLERANCE_M``."""

    def key(p: Sequence[float]) -> tuple[int, int, int]:
        return (
            round(p[0] / LINK_TOLERANCE_M),
            round(p[1] / LINK_TOLERANCE_M),
            round(p[2] / LINK_TOLERANCE_M),
        )

    starting: dict[tuple[int, int, int], list[int]] = {}
    for i, t in enumerate(tasks):
        if isinstance(t, AdhesionTask):
            starting.setdefault(key(t.start_m), []).append(i)
    successors: list[tuple[int, ...]] = [() for _ in tasks]
    predecessors: list[list[int]] = [[] for _ in tasks]
    for i, t in enumerate(tasks):
        if isinstance(t, AdhesionTask):
            nxt = tuple(j for j in starting.get(key(t.end_m), ()) if j != i)
            successors[i] = nxt
            for j in nxt:
                predecessors[j].append(i)
    return successors, [tuple(p) for p in predecessors]


def chain_pick(
    candidates: Collection[int],
    position_m: Sequence[float],
    start_m: Sequence[tuple[float, float, float]],
    leg_m: Sequence[float],
    successors: Sequence[tuple[int, ...]],
    predecessors: Sequence[tuple[int, ...]],
    after: int | None = None,
) -> int:
    """The best of ``candidates`` (not empty; the policy ranks them alike) for a UAV at ``position_m``.

    Args:
        after: the adhesion task the UAV has just sprayed, if it is still near its end (None: it is not).

    Returns:
        A successor of ``after`` among the candidates (the lowest index); else the candidate with the shortest
        flight (to its start, plus pickup -> drop-off for a brick; ties by plan order), or the segment furthest
        back along its run (predecessor by predecessor, among the candidates) whose flight is at most
        ``HEAD_DETOUR_M`` longer.
    """
    if after is not None:
        chained = [j for j in successors[after] if j in candidates]
        if chained:
            return min(chained)
    dist = math.dist
    near, near_cost = -1, math.inf
    for i in candidates:
        cost = dist(position_m, start_m[i]) + leg_m[i]
        if cost < near_cost or (cost == near_cost and i < near):
            near, near_cost = i, cost
    pick, seen = near, {near}
    while True:  # back along the run (a ring of segments, a tower's course, ends where it began)
        before = [p for p in predecessors[pick] if p in candidates and p not in seen]
        if not before:
            return pick
        p = min(before)
        if dist(position_m, start_m[p]) + leg_m[p] - near_cost > HEAD_DETOUR_M:
            return pick
        pick = p
        seen.add(p)


__all__ = ["HEAD_DETOUR_M", "LINK_TOLERANCE_M", "NEAR_END_M", "chain_pick", "segment_links"]
