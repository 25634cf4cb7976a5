"""What the dispatcher says of its mission: live read-only views of its state and look-ups by id (pure).

:class:`~masonry.planner.dispatch.Dispatcher` keeps the state and changes it on each event; this base class only
reads it (each view is O(1) to obtain, the tuples O(fleet) or O(plan) to build).
"""

from __future__ import annotations

from collections.abc import Mapping
from collections.abc import Set as AbstractSet
from types import MappingProxyType

from masonry.blueprint import ROLES, UavSpec
from masonry.errors import PlanningError
from masonry.planner.dispatch_values import DONE, SetView
from masonry.planner.tasks import Task


class DispatchQueries:
    """The queries of a :class:`~masonry.planner.dispatch.Dispatcher` (its base: the state is the dispatcher's)."""

    _tasks: tuple[Task, ...]
    _ids: list[str]
    _index: dict[str, int]
    _chain: list[float]
    _status: list[int]
    _attempts: dict[str, int]
    _done: set[str]
    _stuck: set[str]
    _in_progress: dict[str, str]
    _fleet: dict[str, UavSpec]
    _live: set[str]
    _live_count: dict[str, int]
    _uav_task: dict[str, int]
    _dependents: list[list[int]]
    _prerequisites: list[list[int]]
    _available: dict[str, dict[int, None]]
    _events: int
    _last_done: str | None

    def _lookup(self, task_id: str, graph: str) -> int:
        try:
            return self._index[task_id]
        except KeyError:
            raise PlanningError(f"{graph} names unknown task {task_id!r}") from None

    @property
    def done(self) -> AbstractSet[str]:
        """Ids of completed tasks (pre-placed bricks included); a live read-only view."""
        return SetView(self._done)

    @property
    def last_done(self) -> str | None:
        """The task marked done last (None: none yet), so that a watcher seeing :attr:`done` one larger knows
        which without a scan."""
        return self._last_done

    @property
    def in_progress(self) -> Mapping[str, str]:
        """Task id -> UAV name for every task in progress; a live read-only view."""
        return MappingProxyType(self._in_progress)

    @property
    def stuck(self) -> AbstractSet[str]:
        """Ids of tasks that failed ``max_attempts`` times; a live read-only view."""
        return SetView(self._stuck)

    @property
    def attempts(self) -> Mapping[str, int]:
        """Finished (completed or failed) attempts per task id; tasks never finished are absent."""
        return MappingProxyType(self._attempts)

    @property
    def idle_uavs(self) -> tuple[str, ...]:
        """Names of UAVs in the fleet, not removed, with no task, in fleet order."""
        return tuple(n for n in self._fleet if n in self._live and n not in self._uav_task)

    @property
    def uavs(self) -> tuple[str, ...]:
        """Names of the UAVs not removed, in fleet order."""
        return tuple(n for n in self._fleet if n in self._live)

    @property
    def available(self) -> tuple[str, ...]:
        """Ids of tasks that could be assigned now (both roles), in plan order."""
        return tuple(self._ids[i] for i in sorted(i for r in ROLES for i in self._available[r]))

    @property
    def remaining(self) -> tuple[str, ...]:
        """Ids of tasks not done (pending, in progress or stuck), in plan order."""
        return tuple(tid for i, tid in enumerate(self._ids) if self._status[i] != DONE)

    @property
    def finished(self) -> bool:
        """True when every task of the plan is done."""
        return len(self._done) == len(self._tasks)

    @property
    def blocked(self) -> bool:
        """True when the mission cannot finish: not finished, nothing in progress and nothing assignable.

        This happens when a task is stuck (it and everything depending on it can never run) or every UAV of a
        role that still has work was removed.
        """
        if self.finished or self._in_progress:
            return False
        return not any(self._available[r] and self._live_count[r] for r in ROLES)

    @property
    def events(self) -> int:
        """Number of assignment, completion, failure and release events processed so far."""
        return self._events

    def task(self, task_id: str) -> Task:
        """The task with id ``task_id`` (O(1), unlike ``Plan.task``)."""
        return self._tasks[self._lookup(task_id, "query")]

    def task_of(self, uav: str) -> str | None:
        """The id of the task UAV ``uav`` is flying, or None."""
        i = self._uav_task.get(uav)
        return None if i is None else self._ids[i]

    def attempt_of(self, task_id: str) -> int:
        """The number the next (or current) attempt of ``task_id`` has among those counted against its
        ``max_attempts``: finished (counted) attempts + 1. Not an assignment's identity: a flight failed for a
        reason that is not the task's is followed by one with the same count (mission control's protocol numbers
        each assignment: :meth:`masonry.mission.ledger.AttemptLedger.number_of`)."""
        self._lookup(task_id, "query")
        return self._attempts.get(task_id, 0) + 1

    def waiting_on(self, task_id: str) -> dict[str, str]:
        """The tasks in progress that depend on ``task_id``, directly or through others (task id -> its UAV): a
        brick fetched while the segment under it is flown (the ``site`` reservation's prefetch) waits for it, and
        waits in vain once it is given up (issue 27, branch ``stuck41``)."""
        seen: set[int] = set()
        todo = [self._lookup(task_id, "query")]
        while todo:
            for d in self._dependents[todo.pop()]:
                if d not in seen:
                    seen.add(d)
                    todo.append(d)
        by_index = {i: uav for uav, i in self._uav_task.items()}
        return {self._ids[i]: by_index[i] for i in sorted(seen) if i in by_index}

    def given_up_under(self, task_id: str) -> str | None:
        """The first (by id) given-up task that ``task_id`` depends on, directly or through others, or None: a task in
        progress with one waits in vain (issue 27, branch ``recall41``). Only tasks not done are walked (a done
        task's prerequisites are done), so a task with its prerequisites done costs nothing."""
        if not self._stuck:
            return None
        seen: set[int] = set()
        todo = [self._lookup(task_id, "query")]
        while todo:
            for p in self._prerequisites[todo.pop()]:
                if p not in seen and self._status[p] != DONE:
                    seen.add(p)
                    todo.append(p)
        return min((self._ids[p] for p in seen if self._ids[p] in self._stuck), default=None)

    def chain_s(self, task_id: str) -> float:
        """The longest dependency chain from ``task_id`` (its own weight included) used by ``critical-path``."""
        return self._chain[self._lookup(task_id, "query")]


__all__ = ["DispatchQueries"]
