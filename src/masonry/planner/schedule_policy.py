"""``--policy schedule``: the reactive dispatcher following an offline schedule (:mod:`masonry.planner.schedule`).

Each UAV takes the next task of its planned sequence as soon as the dispatcher makes it available (its
prerequisites complete, no conflicting task in progress: the same rules as every policy, so the mission stays
safe whatever the schedule says). Where the schedule cannot be followed the dispatcher falls back:

* an adhesion UAV still at the end of the segment it has just sprayed takes the segment starting there if it is
  its own (or unclaimed) and available, before its next planned one (``chain``: sprayed chained, no climb and
  descent; the schedule's model charges a segment the same whether it is chained or not, so its order chains
  few: 3 of 156 consecutive segments of a sprayer on the 12 m wall at 4 + 2; that wall, seeds 1-3, 2,308 /
  2,246 / 2,016 -> 1,983 / 1,915 / 1,726 s);
* its next task not available, a UAV takes the first available task further down its own sequence
  (``lookahead``: the flights take longer than the model's minimum, so the planned interleaving slips; on the
  69-task running bond, 2+1 UAVs, this took the mission from 1,843 s to 1,560 s);
* a task whose UAV is lost, or that the schedule does not list, is *unclaimed*: a UAV with nothing of its own
  available takes the best unclaimed one (critical-path order, then the shortest flight);
* a failed task goes back to the pool and stays its UAV's (it is retried by the same UAV);
* when nothing is in progress and no idle UAV can start one of its own tasks (it could only wait for what
  will not happen: a stuck prerequisite), a UAV takes any available task that is not the next one of its own
  idle UAV, critical-path.

Otherwise a UAV with none of its tasks available waits (this cannot dead-lock: the earliest planned pending
task has its prerequisites done, so it is available or blocked by a task in progress). :attr:`followed` counts
the assignments of a task to the UAV the schedule planned it for, :attr:`fallbacks` the others.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

from masonry.blueprint import UavSpec
from masonry.errors import PlanningError
from masonry.planner.dispatch import _PENDING, _RUNNING, Dispatcher
from masonry.planner.dispatch_admission import Admission
from masonry.planner.dispatch_glue import JustInTime, with_glue
from masonry.planner.dispatch_ranking import CHOOSE_AMONG
from masonry.planner.schedule_values import OfflineSchedule
from masonry.planner.tasks import Plan

SCHEDULE_POLICY = "schedule"


class ScheduleDispatcher(Dispatcher):
    """A :class:`~masonry.planner.dispatch.Dispatcher` that follows ``schedule`` (see the module docstring).

    Its own ``policy`` is ``critical-path`` (the fallback's order); the mission's policy is ``schedule``.

    Raises:
        PlanningError: as :class:`Dispatcher`; or the schedule names a task the plan does not have, or gives a
            task to a UAV of another role.
    """

    _per_uav_choice = True
    #: a UAV whose next planned task is not available takes a later one of its own that is
    lookahead = True
    #: ... or else an available task planned for a UAV that is busy now (off: it undoes the schedule's
    #: assignment, and sends more UAVs into a crowded wall: with ``chain``, the pyramid at 8 + 4 1,782 -> 2,357 s,
    #: the 12 m wall at 4 + 2 faster on one seed of three; docs/performance/fleet.md, "The schedule's order flown")
    steal = False
    #: with :attr:`soonest` (mission control under the table), a UAV takes of its next few available planned tasks
    #: the one it can finish soonest, not the first in the schedule's order (issue 27 §1.6; measured, off)
    by_table = False
    #: an adhesion UAV at the end of the segment it has just sprayed takes the segment starting there, if it is
    #: its own (or unclaimed) and available, before its next planned one: chained, no climb and descent
    chain = True

    def __init__(
        self,
        plan: Plan,
        fleet: Sequence[UavSpec],
        schedule: OfflineSchedule,
        max_attempts: int = 3,
        durations_s: Mapping[str, float] | None = None,
        reservation: str = "task",
    ) -> None:
        super().__init__(plan, fleet, "critical-path", max_attempts, durations_s, reservation)
        self.schedule = schedule
        self._queue: dict[str, list[int]] = {}
        self._cursor: dict[str, int] = {}
        self._owner: dict[int, str] = {}
        for u in schedule.uavs:
            if u.name not in self._fleet:
                continue
            role = self._fleet[u.name].role
            queue = []
            for t in u.tasks:
                i = self._index.get(t.id)
                if i is None:
                    raise PlanningError(
                        f"the schedule gives {u.name} task {t.id!r}, which the plan does not have"
                    )
                if self._role[i] != role:
                    raise PlanningError(
                        f"the schedule gives {role} UAV {u.name} the {self._role[i]} task {t.id}"
                    )
                queue.append(i)
                self._owner[i] = u.name
            self._queue[u.name] = queue
            self._cursor[u.name] = 0
        self.followed = 0
        self.fallbacks = 0

    def next_planned(self, uav: str) -> str | None:
        """The id of the next task of ``uav``'s planned sequence not done or taken yet (None: none left)."""
        i = self._next(uav)
        return None if i is None else self._ids[i]

    def _next(self, uav: str) -> int | None:
        queue = self._queue.get(uav)
        if not queue:
            return None
        k = self._cursor[uav]
        status = self._status
        # done, stuck and (taken by another UAV) running tasks are behind it; a failed one is pending again
        while k < len(queue) and status[queue[k]] != _PENDING:
            if status[queue[k]] == _RUNNING and self._in_progress.get(self._ids[queue[k]]) == uav:
                break
            k += 1
        self._cursor[uav] = k
        return queue[k] if k < len(queue) and status[queue[k]] == _PENDING else None

    def _unclaimed(self, i: int) -> bool:
        owner = self._owner.get(i)
        return owner is None or owner not in self._live

    def _best(self, candidates: list[int], uav: str) -> int | None:
        if not candidates:
            return None
        top = max(self._rank[i] for i in candidates)
        pos = self._position[uav]
        return min(
            (i for i in candidates if self._rank[i] == top),
            key=lambda i: (_dist(pos, self._start_m[i]) + self._leg_m[i], i),
        )

    def _own_available(self, uav: str, avail: Mapping[int, None]) -> int | None:
        """The first task of ``uav``'s remaining planned sequence that is available (``lookahead``)."""
        queue = self._queue.get(uav, ())
        for i in queue[self._cursor.get(uav, 0) :]:
            if i in avail:
                return i
        return None

    def _soonest_own(self, uav: str, first: int, avail: Mapping[int, None]) -> int:
        """``first`` (its next planned available task), or with :attr:`soonest` the one of it and the next
        available tasks of its sequence (:data:`~masonry.planner.dispatch_ranking.CHOOSE_AMONG` in all, in the
        schedule's order) that :attr:`soonest` takes (under the table: the one it can finish soonest)."""
        choose = self._chooser(uav) if self.by_table else None
        if choose is None:
            return first
        queue = self._queue.get(uav, ())
        later = [i for i in queue[self._cursor.get(uav, 0) :] if i in avail and i != first]
        order = [first, *later[: CHOOSE_AMONG - 1]]
        return order[choose(order)] if len(order) > 1 else first

    def _select(self, role: str, uav: str) -> int | None:
        avail = self._available[role]
        nxt = self._next(uav)
        if self.chain:
            after = self._after(uav)
            if after is not None:
                for j in self._successors[after]:
                    if j in avail and (self._owner.get(j) == uav or self._unclaimed(j)):
                        return j
        if nxt is not None and nxt in avail:
            return self._soonest_own(uav, nxt, avail)
        if self.lookahead:
            own = self._own_available(uav, avail)
            if own is not None:
                return self._soonest_own(uav, own, avail)
        pick = self._best([i for i in avail if self._unclaimed(i)], uav)
        if pick is not None:
            return pick
        if self.steal:
            # a task planned for a UAV that is busy now: it would wait for it, this one need not
            pick = self._best([i for i in avail if self._owner.get(i) in self._uav_task], uav)
            if pick is not None:
                return pick
        if (
            not self._in_progress
            and (nxt is None or nxt not in self._ready[role])
            and not self._someone_starts()
        ):
            # waiting would wait forever: any available task, but not one its own idle UAV is about to take
            return self._best([i for i in avail if not self._taken_next(i)], uav)
        return None

    def _someone_starts(self) -> bool:
        """An idle UAV's next planned task is available: it is about to start it (later in this assignment)."""
        for name in self._live:
            if name in self._uav_task:
                continue
            i = self._next(name)
            if i is not None and i in self._available[self._role[i]]:
                return True
        return False

    def _taken_next(self, i: int) -> bool:
        owner = self._owner.get(i)
        return (
            owner is not None
            and owner in self._live
            and owner not in self._uav_task
            and self._next(owner) == i
        )

    def _out_idle(self, role: str, rule: Admission) -> int:
        """None counted: a UAV in the air with no task waits for its own planned task, not the next one, so it
        does not keep the UAV a task is planned for on its pad (counted, a random 2 + 1 layout stalled with both
        brick UAVs idle, one out and one held; ``tests/test_schedule_policy.py``, seed 7)."""
        return 0

    def _select_conflicting(self, role: str, uav: str) -> int | None:
        nxt = self._next(uav)
        if nxt is not None and self._status[nxt] == _PENDING:
            if nxt in self._ready[role] and nxt not in self._available[role]:
                return nxt  # ``site``: the schedule let it overlap the conflicting task in progress
            if self.prefetch and role == "brick" and nxt in self._prefetchable(role):
                return nxt
        if not self._in_progress:
            return super()._select_conflicting(role, uav)
        return None

    def _start(self, i: int, uav: str) -> None:
        if self._owner.get(i) == uav:
            self.followed += 1
        else:
            self.fallbacks += 1
        super()._start(i, uav)


def _dist(a: Sequence[float], b: Sequence[float]) -> float:
    return float(((a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2) ** 0.5)


def make_dispatcher(
    plan: Plan,
    fleet: Sequence[UavSpec],
    policy: str,
    *,
    schedule: OfflineSchedule | None = None,
    max_attempts: int = 3,
    durations_s: Mapping[str, float] | None = None,
    reservation: str = "task",
) -> Dispatcher:
    """The dispatcher of ``policy``: a :class:`ScheduleDispatcher` for ``schedule``, else a plain one.

    Raises:
        PlanningError: ``schedule`` policy without a schedule, or as the dispatchers.
    """
    if policy == SCHEDULE_POLICY:
        if schedule is None:
            raise PlanningError("the schedule policy needs an offline schedule (masonry schedule)")
        by_schedule = with_glue(ScheduleDispatcher) if plan.deadlines else ScheduleDispatcher
        d: Dispatcher = by_schedule(plan, fleet, schedule, max_attempts, durations_s, reservation)
    else:
        plain = with_glue(Dispatcher) if plan.deadlines else Dispatcher
        d = plain(plan, fleet, policy, max_attempts, durations_s, reservation)
    if isinstance(d, JustInTime):  # the adhesive's open and cure times: glue just in time (docs/dispatch.md)
        d._setup_glue(plan)
    return d


__all__ = ["SCHEDULE_POLICY", "ScheduleDispatcher", "make_dispatcher"]
