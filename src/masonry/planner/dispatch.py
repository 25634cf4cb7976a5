"""Reactive task assignment (the paper's Algorithm 1), incremental so that a 20,000-brick wall dispatches fast.

A task is *available* when it is not done, not in progress, not stuck, all its prerequisites in the dependency
graph G^d are complete, and it conflicts (G^c) with no task in progress. The dispatcher keeps two counters per
task: ``prereqs`` (prerequisites not yet complete) and ``blockers`` (conflicting tasks in progress). An
assignment, completion, failure or UAV loss touches only the task's neighbours in both graphs, so an event costs
about the degree of the task, never a rescan of the wall. Available tasks sit in per-role priority structures
ordered by the policy; see docs/dispatch.md for the algorithm, its complexity and the failure rules.

The module is pure: no I/O, no clock. Mission control calls :meth:`Dispatcher.assign` whenever something
changed and feeds back :meth:`~Dispatcher.complete`, :meth:`~Dispatcher.fail` and
:meth:`~Dispatcher.remove_uav`. Its parts: the plan indexed and its graphs (:mod:`.dispatch_graphs`), the
policies' order (:mod:`.dispatch_ranking`), the read-only queries (:mod:`.dispatch_queries`), the values it
hands out (:mod:`.dispatch_values`); this module keeps the state and reacts to the events.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Literal

from masonry.blueprint import ROLES, UavSpec
from masonry.errors import PlanningError
from masonry.planner.dispatch_admission import Admission, coming_alone, crowded, queued
from masonry.planner.dispatch_chaining import NEAR_END_M, segment_links
from masonry.planner.dispatch_graphs import adjacency, chains, index_tasks, prefetchable, tie_step
from masonry.planner.dispatch_queries import DispatchQueries
from masonry.planner.dispatch_ranking import Choose, Ranking
from masonry.planner.dispatch_values import (
    DONE,
    PENDING,
    RUNNING,
    STUCK,
    Assignment,
    task_end_m,
    task_start_m,
    vec3,
)
from masonry.planner.tasks import Plan

Policy = Literal["fifo", "critical-path", "nearest"]
POLICIES: tuple[str, ...] = ("fifo", "critical-path", "nearest")
DEFAULT_POLICY: Policy = "critical-path"
#: How conflicting tasks are kept apart: for their whole duration (``task``, the paper) or for the time their
#: UAVs work at their sites (``site``, mission control's site intervals; docs/safety.md).
RESERVATIONS: tuple[str, ...] = ("site", "task")
#: Mission control's default (``masonry sim``, ``mission-control``, :func:`masonry.mission.simulate`): site
#: intervals, which need mission control's site gate. The dispatcher alone defaults to ``task`` (Algorithm 1).
DEFAULT_RESERVATION = "site"

Vec3 = Sequence[float]

# the task states (masonry.planner.dispatch_values), by the names the dispatchers built on this one use
_PENDING, _RUNNING, _DONE, _STUCK = PENDING, RUNNING, DONE, STUCK


#: the wall's last tasks of a role whose prefetch may start with one segment under them still only ready
END_BRICKS = 2


class Dispatcher(DispatchQueries):
    """Assign available, non-conflicting tasks of a :class:`Plan` to idle UAVs, reacting to every event.

    Args:
        plan: the frozen plan (tasks, dependencies (u, v) "u after v", unordered conflicts).
        fleet: the UAVs; each takes tasks of its role ("brick" or "adhesion") one at a time.
        policy: priority among available tasks: ``"fifo"`` (plan order, the paper's baseline),
            ``"critical-path"`` (longest remaining dependency chain first, ties by flight distance; default) or
            ``"nearest"`` (shortest flight for the UAV: to the pickup then the drop-off for a brick, to the
            segment start for adhesion; ties by plan order).
        max_attempts: a task that failed this many times is *stuck* and never assigned again.
        durations_s: expected duration per task id, used by ``critical-path`` to weight the chain (each
            not-done task must be present); without it every task weighs 1.
        reservation: ``"task"`` (the paper: a task blocks its conflicting tasks from assignment to completion)
            or ``"site"`` (conflicting tasks may run at once; mission control keeps their *site intervals*
            apart): a UAV with no non-conflicting task available then takes a conflicting one (it fetches its
            brick while the site is busy). Both prefer tasks that conflict with nothing in progress.

    Raises:
        PlanningError: unknown policy, duplicate task or UAV names, unknown ids or self-loops in the graphs,
            a dependency cycle, or bad durations.
    """

    #: each UAV chooses for itself (``--policy schedule``): one UAV left idle does not mean the next one is
    _per_uav_choice = False
    #: mission control's admission rule (:mod:`masonry.planner.dispatch_admission`; None: every idle UAV is
    #: given a task, as Algorithm 1)
    admission: Admission | None = None
    #: airspace-aware dispatch (issue 27 §1.6): given a UAV and the task ids the policy ranks alike, its pick
    #: first, the index of the one to give it (mission control under ``--airspace table``: the one it can finish
    #: soonest by the reservations, :mod:`masonry.mission.table_dispatch`); None: the policy's pick
    soonest: Callable[[str, Sequence[str]], int] | None = None

    def __init__(
        self,
        plan: Plan,
        fleet: Sequence[UavSpec],
        policy: str = DEFAULT_POLICY,
        max_attempts: int = 3,
        durations_s: Mapping[str, float] | None = None,
        reservation: str = "task",
    ) -> None:
        if reservation not in RESERVATIONS:
            raise PlanningError(
                f"unknown reservation {reservation!r}; expected one of {', '.join(RESERVATIONS)}"
            )
        if policy not in POLICIES:
            raise PlanningError(f"unknown dispatch policy {policy!r}; expected one of {', '.join(POLICIES)}")
        if isinstance(max_attempts, bool) or not isinstance(max_attempts, int) or max_attempts < 1:
            raise PlanningError(f"max_attempts must be an integer >= 1, got {max_attempts!r}")
        self.plan = plan
        self.policy: str = policy
        self.max_attempts = max_attempts
        self.reservation = reservation
        #: ``site`` only: may give a brick task whose prerequisites are still in progress (its UAV fetches the
        #: brick; mission control's site gate keeps it off the site until they are done). Not adhesion: it has
        #: nothing to fetch, and would only hold a place in the airspace's queue.
        self.prefetch = reservation == "site"
        self._tasks = plan.tasks
        index = index_tasks(plan.tasks)
        self._ids, self._index, self._role = index.ids, index.index, index.roles
        self._start_m, self._end_m, self._leg_m = index.start_m, index.end_m, index.leg_m
        self._graphs = graphs = adjacency(plan, self._index)
        self._dependents, self._prerequisites = graphs.dependents, graphs.prerequisites
        self._neighbours = graphs.neighbours
        self._chain = chains(self._tasks, graphs, durations_s)
        # critical-path compares chains in steps of one typical task (the median duration; 1 unweighted): tasks
        # whose remaining chains differ by less than that are ties, and ties go to the shortest flight.
        self.tie_step_s = tie_step(self._tasks, durations_s)
        self._rank = [math.floor(c / self.tie_step_s + 1e-9) for c in self._chain]
        self._add_fleet(fleet)
        self._init_state()

    # ------------------------------------------------------------------ construction helpers

    def _add_fleet(self, fleet: Sequence[UavSpec]) -> None:
        self._fleet = {}
        for spec in fleet:
            if spec.name in self._fleet:
                raise PlanningError(f"fleet has two UAVs named {spec.name!r}")
            if spec.role not in ROLES:
                raise PlanningError(f"UAV {spec.name}: unknown role {spec.role!r}")
            self._fleet[spec.name] = spec
        self._position: dict[str, tuple[float, float, float]] = {
            s.name: vec3(s.home_m, f"UAV {s.name} home_m") for s in self._fleet.values()
        }
        self._live = set(self._fleet)
        self._uav_task = {}
        self._live_count = dict.fromkeys(ROLES, 0)
        for s in self._fleet.values():
            self._live_count[s.role] += 1

    def _init_state(self) -> None:
        """Per-task state and the policy's structures; the tasks available from the start."""
        tasks = self._tasks
        n = len(tasks)
        self._status = [_DONE if t.done else _PENDING for t in tasks]
        self._prereqs = [sum(1 for p in self._prerequisites[i] if self._status[p] != _DONE) for i in range(n)]
        self._blockers = [0] * n
        self._attempts = {}
        self._done = {self._ids[i] for i in range(n) if self._status[i] == _DONE}
        self._last_done: str | None = None  # (the task marked done last: :attr:`last_done`)
        self._stuck = set()
        self._in_progress = {}

        # Available tasks per role in the policy's order, and (``site`` reservation) the pending tasks whose
        # prerequisites are done, blocked by a conflict or not.
        self._successors, predecessors = segment_links(tasks)
        self._ranking = Ranking(
            self.policy, self._rank, self._start_m, self._leg_m, self._successors, predecessors
        )
        #: per UAV, the adhesion segment it has just sprayed (until its next task): chaining's "after"
        self._sprayed: dict[str, int] = {}
        self._available = self._ranking.available
        self._ready: dict[str, dict[int, None]] = {r: {} for r in ROLES}
        self._events = 0
        for i in range(n):
            self._maybe_available(i)

    # ------------------------------------------------------------------ availability bookkeeping

    def _maybe_available(self, i: int) -> None:
        if self._status[i] != _PENDING or self._prereqs[i]:
            return
        role = self._role[i]
        self._ready[role][i] = None
        if not self._blockers[i]:
            self._ranking.add(i, role)

    def _unavailable(self, i: int) -> None:
        self._ranking.discard(i, self._role[i])

    # ------------------------------------------------------------------ selection per policy

    def _after(self, uav: str) -> int | None:
        """The adhesion segment ``uav`` has just sprayed, if it is still (horizontally) near its end."""
        i = self._sprayed.get(uav)
        if i is None:
            return None
        p, end = self._position[uav], self._end_m[i]
        return i if math.hypot(p[0] - end[0], p[1] - end[1]) <= NEAR_END_M else None

    def _select(self, role: str, uav: str) -> int | None:
        return self._ranking.pick(role, self._position[uav], self._after(uav), self._chooser(uav))

    def _chooser(self, uav: str) -> Choose | None:
        """:attr:`soonest` for ``uav`` over plan indices (None: not set)."""
        soonest, ids = self.soonest, self._ids
        if soonest is None:
            return None
        return lambda order: soonest(uav, [ids[i] for i in order])

    def _select_conflicting(self, role: str, uav: str) -> int | None:
        """``site`` reservation, nothing else available: the best ready task that conflicts with one in
        progress, or else (``prefetch``) a task whose every prerequisite is done or in progress (its UAV
        fetches the brick while the glue is sprayed; its site interval waits for them). Highest chain for
        ``critical-path``, plan order for ``fifo``; then the shortest flight. With the admission rule, a UAV on its
        pad prefetches only where it would be the one UAV coming to the site (:func:`coming_alone`)."""
        avail = self._available[role]
        candidates = [i for i in self._ready[role] if i not in avail]
        if not candidates and self.prefetch and role == "brick":
            candidates = self._prefetchable(role)
            if candidates and self.admission is not None and self.admission.landed(uav):
                st, nb = self._status, self._neighbours
                candidates = [i for i in candidates if coming_alone(i, lambda k: st[k] == _RUNNING, nb)]
        if not candidates:
            return None
        return self._ranking.pick_among(candidates, self._position[uav], self._after(uav), self._chooser(uav))

    def _admitted(self, uav: str, role: str, i: int) -> int | None:
        """``i``, or for a landed ``uav`` None while its role has its cap of busy UAVs, else the policy's best task
        of ``role`` not crowded when ``i`` is (None: none); :mod:`masonry.planner.dispatch_admission`."""
        rule = self.admission
        if rule is None or not rule.applies(sum(self._live_count.values())):
            return i
        st, nb, pre = self._status, self._neighbours, self._prerequisites
        if not rule.landed(uav):
            return i  # already out: it is not added to the crowd (holding it back left holds unserved)
        # busy: holding a task, or out with none (it takes the next one: a spare that took over a swapping UAV's
        # work is not undercut by it back from its swap, and their segments' chains are not split)
        busy = sum(1 for j in self._uav_task.values() if self._role[j] == role) + self._out_idle(role, rule)
        if busy >= rule.cap(*self._cap_counts(role)):
            return None  # its role has its share of the UAVs the wall can keep busy: it stays on its pad
        running = list(self._uav_task.values())
        waiting = queued(running, lambda k: st[k] == _RUNNING, lambda j: nb[j])
        if not crowded(i, waiting, nb, pre):
            return i
        for pool in (self._available[role], self._ready[role]):
            free = [k for k in pool if not crowded(k, waiting, nb, pre)]
            if free:
                return self._ranking.pick_among(free, self._position[uav], self._after(uav))
        return None

    def _out_idle(self, role: str, rule: Admission) -> int:
        """The live UAVs of ``role`` in the air with no task, but those flying home for their swap."""
        return sum(
            1
            for n, spec in self._fleet.items()
            if spec.role == role
            and n in self._live
            and n not in self._uav_task
            and not rule.landed(n)
            and not rule.swap_sent(n)
        )

    def capped_alone(self, role: str) -> bool:
        """The admission rule applies and lets one UAV of ``role`` be busy at a time (the pyramid's sprayers
        at 4 + 2 to 8 + 4): that UAV's work is its role's (:func:`masonry.mission.swap_stagger.swap_due`)."""
        rule, live = self.admission, sum(self._live_count.values())
        return rule is not None and rule.applies(live) and rule.cap(*self._cap_counts(role)) == 1

    def _cap_counts(self, role: str) -> tuple[int, int]:
        """The UAVs of ``role`` and of the fleet the admission cap shares the wall among (the live fleet)."""
        return self._live_count[role], sum(self._live_count.values())

    def _prefetchable(self, role: str) -> list[int]:
        """Pending tasks of ``role`` not ready yet whose every prerequisite is done or in progress; for the wall's
        last :data:`END_BRICKS` tasks of ``role``, one prerequisite may be ready instead (issue 27, branch
        ``pyr40``: the pyramid's second-last brick fetched while the sprayer finishes the segment before its last)."""
        st = self._status
        pending = sum(1 for i, r in enumerate(self._role) if r == role and st[i] == _PENDING)
        ready_left = 1 if pending <= END_BRICKS else 0
        return prefetchable(role, self._uav_task.values(), st, self._role, self._graphs, ready_left)

    # ------------------------------------------------------------------ events

    def assign(
        self,
        uav_positions_m: Mapping[str, Vec3] | None = None,
        may_start: Callable[[str], bool] | None = None,
    ) -> list[Assignment]:
        """Give available, mutually non-conflicting tasks to idle UAVs and mark them in progress.

        Roles are served brick first, then adhesion (the order of the paper's Algorithm 1), idle UAVs in fleet
        order; a task assigned here blocks its conflicting tasks for the rest of the call.

        Args:
            uav_positions_m: current positions of (some) UAVs for the distance-based choices; a UAV not listed
                is taken to be where its last task ended (its home before the first one).
            may_start: asked once a task is chosen for an idle UAV: False keeps the UAV idle for now and the
                task available (mission control: a landed UAV whose take-off column is not free).

        Returns:
            The new assignments (possibly empty).

        Raises:
            PlanningError: a position is given for a UAV not in the fleet, or is not 3 finite numbers.
        """
        if uav_positions_m:
            for name, p in uav_positions_m.items():
                if name not in self._fleet:
                    raise PlanningError(f"position given for unknown UAV {name!r}")
                self._position[name] = vec3(p, f"position of UAV {name}")
        out: list[Assignment] = []
        # ``prefetch``: brick UAVs still idle look again once adhesion tasks have started (bricks on them)
        for role in (*ROLES, "brick") if self.prefetch else ROLES:
            if not self._available[role] and self.reservation != "site":
                continue  # (``site``: a conflicting ready task, or a brick to prefetch, may still be given)
            for name, spec in self._fleet.items():
                if spec.role != role or name not in self._live or name in self._uav_task:
                    continue
                i = self._select(role, name)
                if i is None and self.reservation == "site":
                    i = self._select_conflicting(role, name)
                if i is None:
                    if self._per_uav_choice:
                        continue
                    break
                if self.admission is not None:
                    i = self._admitted(name, role, i)
                    if i is None:
                        continue
                if may_start is not None and not may_start(name):
                    continue
                self._start(i, name)
                tid = self._ids[i]
                out.append(Assignment(name, tid, self._attempts.get(tid, 0) + 1))
        return out

    def _start(self, i: int, uav: str) -> None:
        self._events += 1
        self._unavailable(i)
        self._ready[self._role[i]].pop(i, None)
        self._status[i] = _RUNNING
        self._uav_task[uav] = i
        self._sprayed.pop(uav, None)
        self._in_progress[self._ids[i]] = uav
        blockers = self._blockers
        for j in self._neighbours[i]:
            blockers[j] += 1
            if blockers[j] == 1:
                self._unavailable(j)

    def _stop(self, i: int) -> str:
        """Take running task ``i`` off its UAV and unblock its conflicting tasks; returns the UAV's name."""
        self._events += 1
        uav = self._in_progress.pop(self._ids[i])
        del self._uav_task[uav]
        self._status[i] = _PENDING
        blockers = self._blockers
        for j in self._neighbours[i]:
            blockers[j] -= 1
            if blockers[j] == 0:
                self._maybe_available(j)
        return uav

    def _running(self, task_id: str, action: str) -> int:
        i = self._index.get(task_id)
        if i is None:
            raise PlanningError(f"cannot {action} unknown task {task_id!r}")
        if self._status[i] != _RUNNING:
            state = {_PENDING: "not assigned", _DONE: "already done", _STUCK: "stuck"}[self._status[i]]
            raise PlanningError(f"cannot {action} task {task_id}: it is {state}, not in progress")
        return i

    def complete(self, task_id: str) -> None:
        """Mark an in-progress task done: its UAV becomes idle where the task ended and dependents may start.

        Raises:
            PlanningError: the task is unknown or not in progress.
        """
        i = self._running(task_id, "complete")
        uav = self._stop(i)
        self._position[uav] = self._end_m[i]
        if self._role[i] == "adhesion":
            self._sprayed[uav] = i
        self._mark_done(i, task_id)

    def _mark_done(self, i: int, task_id: str) -> None:
        """Task ``i`` is done (one more attempt counted): the tasks that waited for it may become available."""
        self._status[i] = _DONE
        self._done.add(task_id)
        self._last_done = task_id
        self._attempts[task_id] = self._attempts.get(task_id, 0) + 1
        prereqs = self._prereqs
        for d in self._dependents[i]:
            prereqs[d] -= 1
            if prereqs[d] == 0:
                self._maybe_available(d)

    def complete_late(self, task_id: str) -> str | None:
        """Mark a task done that was released from a UAV declared lost, which did it after all (its result came
        late): in progress with another UAV (freed: it must drop it) or back in the pool.

        Returns:
            The UAV that was on it now (to be told to drop it), or None.

        Raises:
            PlanningError: the task is unknown, done already or stuck.
        """
        i = self._index.get(task_id)
        if i is None:
            raise PlanningError(f"cannot complete unknown task {task_id!r}")
        if self._status[i] not in (_RUNNING, _PENDING):
            raise PlanningError(f"cannot complete task {task_id} late: it is done or stuck")
        uav = self._stop(i) if self._status[i] == _RUNNING else None
        self._unavailable(i)
        self._ready[self._role[i]].pop(i, None)
        self._mark_done(i, task_id)
        return uav

    def fail(self, task_id: str, *, count: bool = True, give_up: bool = False) -> bool:
        """Count a failed attempt of an in-progress task and free its UAV.

        ``count`` False: the attempt failed for a reason that is not the task's (the UAV's battery): the task
        returns to the pool without counting it. ``give_up``: it is stuck now (its brick is gone, no spare left).

        Returns:
            True if the task went back to the pool, False if it reached ``max_attempts`` (or gave up): stuck.

        Raises:
            PlanningError: the task is unknown or not in progress.
        """
        i = self._running(task_id, "fail")
        self._stop(i)
        if count:
            self._attempts[task_id] = self._attempts.get(task_id, 0) + 1
        if not give_up and (not count or self._attempts[task_id] < self.max_attempts):
            self._maybe_available(i)
            return True
        self._ready[self._role[i]].pop(i, None)
        self._status[i] = _STUCK
        self._stuck.add(task_id)
        return False

    def remove_uav(self, name: str) -> str | None:
        """Drop a UAV that is lost; its task (if any) returns to the pool without counting an attempt.

        Returns:
            The released task id, or None if the UAV had no task (or was already removed).

        Raises:
            PlanningError: the UAV is not in the fleet.
        """
        if name not in self._fleet:
            raise PlanningError(f"cannot remove unknown UAV {name!r}")
        if name not in self._live:
            return None
        self._live.discard(name)
        self._live_count[self._fleet[name].role] -= 1
        i = self._uav_task.get(name)
        if i is None:
            return None
        self._stop(i)
        self._maybe_available(i)
        return self._ids[i]

    def readmit_uav(self, name: str) -> bool:
        """Take back a UAV removed as lost (it is heard again, with no task): it may be assigned tasks again.

        Returns:
            True if it was out of the mission and is back, False if it was in it already.

        Raises:
            PlanningError: the UAV is not in the fleet.
        """
        if name not in self._fleet:
            raise PlanningError(f"cannot readmit unknown UAV {name!r}")
        if name in self._live:
            return False
        self._live.add(name)
        self._live_count[self._fleet[name].role] += 1
        return True

    def adopt(self, task_id: str, uav: str) -> None:
        """Resume from a journal: ``task_id`` was in progress on ``uav`` when the previous run stopped, and stays
        so (mission control hears from the UAV whether it is still on it, done with it, or forgot it).

        Call after :meth:`restore`, before the first :meth:`assign`. Its conflicting tasks are blocked as by
        an assignment; the attempt number stays the journal's (finished attempts, plus this one). With
        ``prefetch`` a brick is adopted whatever its prerequisites' state, as it was given (its UAV fetched it while
        the segment under it was flown, which may since have failed or been given up: mission control recalls it
        then, :func:`~masonry.mission.control_results.release_waiting`).

        Raises:
            PlanningError: the task is unknown, not pending or (but a ``prefetch`` brick) waits for a prerequisite;
                the UAV is unknown, lost, of the other role or already holds a task.
        """
        i = self._lookup(task_id, "adopted attempt")
        spec = self._fleet.get(uav)
        if spec is None:
            raise PlanningError(f"cannot adopt {task_id} on unknown UAV {uav!r}")
        if uav not in self._live or uav in self._uav_task:
            raise PlanningError(f"cannot adopt {task_id} on {uav}: it is lost or holds a task")
        if spec.role != self._role[i]:
            raise PlanningError(f"cannot adopt {task_id} on {uav}: a {spec.role} UAV")
        prefetched = self.prefetch and self._role[i] == "brick"  # (given before its segments were done)
        if self._status[i] != _PENDING or (self._prereqs[i] and not prefetched):
            raise PlanningError(f"cannot adopt {task_id}: it is not pending with its prerequisites done")
        self._start(i, uav)

    def restore(self, done_ids: Iterable[str], attempts: Mapping[str, int]) -> None:
        """Resume from a journal: mark ``done_ids`` complete and set the attempt counts (see JournalState).

        ``attempts`` counts the finished (completed or failed) attempts per task; a not-done task whose count
        reached ``max_attempts`` is stuck. Call before the first :meth:`assign`.

        Raises:
            PlanningError: a task is in progress, an id is unknown, or a count is negative.
        """
        if self._in_progress:
            raise PlanningError("restore() must be called before any task is assigned")
        for tid in done_ids:
            i = self._lookup(tid, "restored done set")
            if self._status[i] == _DONE:
                continue
            self._unavailable(i)
            self._ready[self._role[i]].pop(i, None)
            self._status[i] = _DONE
            self._stuck.discard(tid)
            self._done.add(tid)
            self._last_done = tid
            for d in self._dependents[i]:
                self._prereqs[d] -= 1
        for tid, n in attempts.items():
            i = self._lookup(tid, "restored attempts")
            if isinstance(n, bool) or not isinstance(n, int) or n < 0:
                raise PlanningError(f"restored attempts[{tid!r}] must be an integer >= 0, got {n!r}")
            if n:
                self._attempts[tid] = n
            else:
                self._attempts.pop(tid, None)
            if self._status[i] == _PENDING and n >= self.max_attempts:
                self._ready[self._role[i]].pop(i, None)
                self._unavailable(i)
                self._status[i] = _STUCK
                self._stuck.add(tid)
        # Prerequisite counts changed in bulk: drop what is no longer available, then add what now is.
        for role in ROLES:
            for i in [i for i in self._available[role] if self._status[i] != _PENDING or self._prereqs[i]]:
                self._unavailable(i)
        for role in ROLES:
            self._ready[role].clear()
        for i in range(len(self._tasks)):
            self._maybe_available(i)


__all__ = [
    "DEFAULT_POLICY",
    "DEFAULT_RESERVATION",
    "POLICIES",
    "RESERVATIONS",
    "Assignment",
    "Dispatcher",
    "Policy",
    "task_end_m",
    "task_start_m",
]
