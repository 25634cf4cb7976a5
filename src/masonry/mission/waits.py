"""Why each task waited: its reasons as intervals of mission time (issue 27, "Explain every wait").

A task that is not done waits while it is not assigned (for a prerequisite, a conflicting task, a UAV of its role,
a take-off column, the operator, the wind) and, once assigned, while its UAV is held back by the airspace (another
UAV's reserved volumes, the ``site`` rule, a prerequisite's completion, the adhesive's open time). Mission control
says at each tick what each task waits for (:class:`WaitCause`, worked out in :mod:`masonry.mission.wait_causes`);
:class:`WaitLog` turns those answers into intervals: one cause at a time per task, so a task's waits never overlap.

Pure: no I/O, no clock (times are passed in).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass

#: What a task may wait for (``what`` of a wait in the JSON report, docs/mission.md "Why each task waited").
CAUSES: tuple[str, ...] = (
    "dependency",  # a prerequisite not done yet (``blocking_task``)
    "conflict",  # ``task`` reservation: a conflicting task in progress (``blocking_task``, ``blocking_uav``)
    "site",  # ``site`` rule: a conflicting task's UAV works at its site (``blocking_task``, ``blocking_uav``)
    "airspace",  # its UAV held back by another UAV's reserved volume or earlier request (``blocking_uav``)
    "take-off",  # a UAV of its role on its pad, the column over the pad not free (``blocking_uav``)
    "fleet",  # every UAV of its role busy with another task (or none left)
    "operator",  # the operator paused the mission, recalled its UAVs or limited its role
    "wind",  # the wind above the max_wind_mps of the UAVs of its role
    "glue",  # a brick over adhesive not sprayed recently enough (the open time)
    "battery",  # held by its UAV's handler for a battery swap (the ``queued`` phase), or its role's free UAV sent
    # home for one with no task (masonry.mission.swap_stagger: ``blocking_uav`` names it)
)

#: Where a waiting UAV was: on its pad, or in the air.
GROUND, AIR = "ground", "air"


@dataclass(frozen=True)
class WaitCause:
    """What a task waits for at one moment.

    Attributes:
        what: one of :data:`CAUSES`.
        blocking_uav: the UAV in the way, where known.
        blocking_task: the task in the way (the prerequisite, the conflicting task, the blocking UAV's task).
        holds: what of the blocking UAV is in the way (its volume's kind, ``earlier-request``), where known;
            ``to-hold`` (no blocking UAV): the answer waits for the UAV's arrival at its hold point.
        uav: the UAV the task is assigned to while it waits (None: not assigned).
        where: ``ground`` or ``air``, where the waiting UAV was (None: no UAV waited).
    """

    what: str
    blocking_uav: str | None = None
    blocking_task: str | None = None
    holds: str | None = None
    uav: str | None = None
    where: str | None = None


@dataclass(frozen=True)
class TaskWait:
    """One interval a task waited for one cause, from ``from_s`` for ``duration_s`` (mission control's clock)."""

    task_id: str
    cause: WaitCause
    from_s: float
    duration_s: float

    @property
    def to_s(self) -> float:
        return self.from_s + self.duration_s

    def to_dict(self) -> dict[str, str | float | None]:
        """One entry of a task's ``waits`` in the JSON report."""
        c = self.cause
        return {
            "what": c.what,
            "blocking_uav": c.blocking_uav,
            "blocking_task": c.blocking_task,
            "holds": c.holds,
            "uav": c.uav,
            "where": c.where,
            "from_s": _r2(self.from_s),
            "duration_s": _r2(self.duration_s),
        }


def _r2(v: float) -> float | None:
    return round(float(v), 2) if math.isfinite(v) else None


class WaitLog:
    """The waits of every task: told each task's cause as it changes, it keeps the intervals."""

    def __init__(self) -> None:
        self._open: dict[str, tuple[WaitCause, float]] = {}  # task id -> (its cause now, since when)
        self.closed: list[TaskWait] = []
        #: told each interval as it closes (mission control journals them, for a resumed mission's report)
        self.on_close: Callable[[TaskWait], None] | None = None

    @property
    def current(self) -> Mapping[str, WaitCause]:
        """Each waiting task's cause now."""
        return {tid: cause for tid, (cause, _) in self._open.items()}

    def set(self, now_s: float, task_id: str, cause: WaitCause | None) -> None:
        """From ``now_s`` ``task_id`` waits for ``cause`` (None: for nothing). The same cause goes on; another
        one ends the interval of the last."""
        was = self._open.get(task_id)
        if was is not None and was[0] == cause:
            return
        if was is not None:
            del self._open[task_id]
            if now_s > was[1]:  # a cause that held for no time leaves no interval
                self.closed.append(TaskWait(task_id, was[0], was[1], now_s - was[1]))
                if self.on_close is not None:
                    self.on_close(self.closed[-1])
        if cause is not None:
            self._open[task_id] = (cause, now_s)

    def update(self, now_s: float, causes: Mapping[str, WaitCause | None]) -> None:
        """:meth:`set` for each task of ``causes``."""
        for task_id, cause in causes.items():
            self.set(now_s, task_id, cause)

    def waits(self, until_s: float) -> dict[str, tuple[TaskWait, ...]]:
        """Every task's waits in time order, those still open ending at ``until_s``."""
        out: dict[str, list[TaskWait]] = {}
        for w in self.closed:
            out.setdefault(w.task_id, []).append(w)
        for tid, (cause, since_s) in self._open.items():
            if until_s > since_s:
                out.setdefault(tid, []).append(TaskWait(tid, cause, since_s, until_s - since_s))
        return {tid: tuple(sorted(ws, key=lambda w: w.from_s)) for tid, ws in out.items()}


def with_battery_holds(
    waits: Mapping[str, tuple[TaskWait, ...]], holds: Iterable[tuple[str, str, float, float]]
) -> dict[str, tuple[TaskWait, ...]]:
    """``waits`` with each battery hold ``(task id, UAV, from_s, duration_s)`` added as a ``battery`` wait: the time
    its UAV's handler kept the assignment for a battery swap (the flight home, the landing, the swap), which only
    the UAV measures (its attempt's ``queued`` phase, from the assignment). Another wait of the task in that time
    (its flight home asked for, as mission control saw it) is cut to what lies outside it: one cause at a time."""
    out = dict(waits)
    for task_id, uav, from_s, duration_s in holds:
        if duration_s <= 0.0:
            continue
        hold = TaskWait(task_id, WaitCause("battery", uav=uav), from_s, duration_s)
        kept: list[TaskWait] = [hold]
        for w in out.get(task_id, ()):
            if w.from_s < hold.from_s:
                end = min(w.to_s, hold.from_s)
                kept.append(TaskWait(task_id, w.cause, w.from_s, end - w.from_s))
            if w.to_s > hold.to_s:
                start = max(w.from_s, hold.to_s)
                kept.append(TaskWait(task_id, w.cause, start, w.to_s - start))
        out[task_id] = tuple(sorted(kept, key=lambda w: w.from_s))
    return out


def waiting_split_s(waiting_s: float, waits: Iterable[TaskWait], uav: str) -> tuple[float, float]:
    """``uav``'s ``waiting_s`` (its attempts' ``waiting`` and ``holding``, as it measured them) split into on the
    ground and in the air: the ground part is what mission control saw it wait on its pad with a task (at most
    ``waiting_s``), the rest was in the air. Returns ``(waiting_ground_s, waiting_air_s)``; they add up to
    ``waiting_s``."""
    ground = sum(w.duration_s for w in waits if w.cause.uav == uav and w.cause.where == GROUND)
    ground = min(max(ground, 0.0), waiting_s)
    return ground, waiting_s - ground


def waits_lines(waits: Iterable[TaskWait]) -> list[str]:
    """The text summary's line: the task-seconds waited per cause, most first (none: no line)."""
    waited: dict[str, float] = {}
    for w in waits:
        waited[w.cause.what] = waited.get(w.cause.what, 0.0) + w.duration_s
    if not waited:
        return []
    spent = ", ".join(f"{k} {v:.0f} s" for k, v in sorted(waited.items(), key=lambda kv: -kv[1]))
    return [f"tasks waited for (task-seconds, JSON: tasks[].waits): {spent}"]


__all__ = [
    "AIR",
    "CAUSES",
    "GROUND",
    "TaskWait",
    "WaitCause",
    "WaitLog",
    "waiting_split_s",
    "waits_lines",
    "with_battery_holds",
]
