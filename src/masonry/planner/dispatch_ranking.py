"""The dispatch policies' order: the available tasks of each role, kept as the policy picks them (pure).

docs/dispatch.md, "Policies": ``fifo`` keeps a heap of plan indices (lazy deletion), ``critical-path`` a bucket
of available tasks per chain step and a heap of the steps (lazy deletion), ``nearest`` only the set; every pick
ends on the shortest flight for the UAV (to the task's start, plus pickup -> drop-off for a brick), ties by plan
order, except that an adhesion UAV takes the segment starting where it has just sprayed, else the head of a run
of contiguous segments (:mod:`masonry.planner.dispatch_chaining`). :class:`~masonry.planner.dispatch.Dispatcher` says when a task becomes available or stops being so.
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Callable, Collection, Sequence

from masonry.blueprint import ROLES
from masonry.planner.dispatch_chaining import chain_pick

#: How many of the tasks the policy ranks alike a chooser (:data:`Choose`) is shown: the policy's pick, then the
#: nearest others (issue 27 §1.6: the table's soonest finish among the policy's top few).
CHOOSE_AMONG = 4

#: Given candidates in the policy's order (its pick first), the index of the one to take (airspace-aware dispatch).
Choose = Callable[[Sequence[int]], int]


class Ranking:
    """The available tasks per role in the order of ``policy``.

    Args:
        policy: ``"fifo"``, ``"critical-path"`` or ``"nearest"`` (checked by the dispatcher).
        rank: each task's chain step (critical-path's priority: higher first).
        start_m: where each task's flight starts.
        leg_m: the part of each task's flight that does not depend on the UAV.
        successors, predecessors: each task's adhesion segments starting where it ends and ending where it
            starts (:func:`~masonry.planner.dispatch_chaining.segment_links`; None: no links, every task a head).
    """

    def __init__(
        self,
        policy: str,
        rank: Sequence[int],
        start_m: Sequence[tuple[float, float, float]],
        leg_m: Sequence[float],
        successors: Sequence[tuple[int, ...]] | None = None,
        predecessors: Sequence[tuple[int, ...]] | None = None,
    ) -> None:
        self.policy = policy
        self._rank, self._start_m, self._leg_m = rank, start_m, leg_m
        none: list[tuple[int, ...]] = [() for _ in rank]
        self._succ = none if successors is None else successors
        self._pred = none if predecessors is None else predecessors
        #: available tasks per role (an insertion-ordered dict used as a set)
        self.available: dict[str, dict[int, None]] = {r: {} for r in ROLES}
        self._heap: dict[str, list[tuple[int, int]]] = {r: [] for r in ROLES}
        self._in_heap = [False] * len(rank)
        # critical-path: bucket of available tasks per chain value and a heap of the values (lazy deletion).
        self._buckets: dict[str, dict[int, dict[int, None]]] = {r: {} for r in ROLES}
        self._heap_values: dict[str, set[int]] = {r: set() for r in ROLES}

    def add(self, i: int, role: str) -> None:
        """Task ``i`` (of ``role``) is available (again); nothing if it is already."""
        avail = self.available[role]
        if i in avail:
            return
        avail[i] = None
        if self.policy == "fifo":
            if not self._in_heap[i]:
                self._in_heap[i] = True
                heapq.heappush(self._heap[role], (i, i))
        elif self.policy == "critical-path":
            c = self._rank[i]
            buckets = self._buckets[role]
            bucket = buckets.get(c)
            if bucket is None:
                buckets[c] = bucket = {}
                if c not in self._heap_values[role]:
                    self._heap_values[role].add(c)
                    heapq.heappush(self._heap[role], (-c, i))
            bucket[i] = None

    def discard(self, i: int, role: str) -> None:
        """Task ``i`` (of ``role``) is not available (any more); nothing if it was not."""
        if self.available[role].pop(i, 0) is None and self.policy == "critical-path":
            buckets = self._buckets[role]
            c = self._rank[i]
            bucket = buckets[c]
            del bucket[i]
            if not bucket:
                del buckets[c]  # its heap entry is dropped lazily

    def pick(
        self, role: str, position_m: Sequence[float], after: int | None = None, choose: Choose | None = None
    ) -> int | None:
        """The policy's best available task of ``role`` for a UAV at ``position_m`` (None: none available);
        ``after``: the adhesion segment the UAV has just sprayed, if it is still at its end (chaining); ``choose``:
        picks among the policy's top few (:meth:`_finish`)."""
        avail = self.available[role]
        if not avail:
            return None
        if self.policy == "fifo":
            heap = self._heap[role]
            while heap:
                _, i = heap[0]
                if i in avail:
                    return i
                heapq.heappop(heap)
                self._in_heap[i] = False
            return None  # pragma: no cover - avail non-empty implies a heap entry
        candidates = avail
        if self.policy == "critical-path":
            heap = self._heap[role]
            buckets = self._buckets[role]
            while True:
                c = -heap[0][0]
                bucket = buckets.get(c)
                if bucket:
                    candidates = bucket
                    break
                heapq.heappop(heap)
                self._heap_values[role].discard(c)
        # The segment chained to ``after``, else the nearest run head (shortest flight: to the start, plus
        # pickup -> drop-off for a brick); ties by plan order.
        return self._finish(candidates, position_m, after, choose)

    def _finish(
        self,
        candidates: Collection[int],
        position_m: Sequence[float],
        after: int | None,
        choose: Choose | None,
    ) -> int:
        """The last step of every pick among tasks the policy ranks alike: :func:`chain_pick`; with ``choose``, the
        one it takes of chain_pick's choice and the :data:`CHOOSE_AMONG` - 1 nearest others (by the shortest flight,
        ties by plan order), but a segment chained to ``after`` (no flight at all) is kept."""
        pick = chain_pick(candidates, position_m, self._start_m, self._leg_m, self._succ, self._pred, after)
        if choose is None or len(candidates) < 2 or (after is not None and pick in self._succ[after]):
            return pick
        start, leg = self._start_m, self._leg_m
        others = sorted(
            (i for i in candidates if i != pick), key=lambda i: (math.dist(position_m, start[i]) + leg[i], i)
        )
        order = [pick, *others[: CHOOSE_AMONG - 1]]
        return order[choose(order)]

    def pick_among(
        self,
        candidates: Sequence[int],
        position_m: Sequence[float],
        after: int | None = None,
        choose: Choose | None = None,
    ) -> int:
        """The policy's best of ``candidates`` (not empty; not available: blocked or to prefetch) for a UAV at
        ``position_m``: highest chain step for ``critical-path``, plan order for ``fifo``; then the segment
        chained to ``after``, else the nearest run head, ties by plan order."""
        if self.policy == "critical-path":
            top = max(self._rank[i] for i in candidates)
            candidates = [i for i in candidates if self._rank[i] == top]
        elif self.policy == "fifo":
            return min(candidates)
        return self._finish(dict.fromkeys(candidates), position_m, after, choose)


__all__ = ["CHOOSE_AMONG", "Choose", "Ranking"]
