"""The rows of the mission report: one per UAV, per task and per attempt, and the sums over attempts.

:class:`~masonry.mission.report.MissionReport` holds them; each row's ``to_dict`` is its part of the JSON of
``masonry sim --format json`` (numbers rounded, non-finite ones ``null``). Where the time goes (docs/mission.md):
every attempt carries the seconds its UAV spent in each phase (:class:`~masonry.ports.PhaseTimes`), every task
those of the attempt that completed it, every UAV its ``idle_s`` (:func:`idle_s`) and ``waiting_s``.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

from masonry.mission.waits import TaskWait
from masonry.ports import PhaseTimes


@dataclass(frozen=True)
class UavReport:
    """One UAV over the mission."""

    name: str
    role: str
    busy_s: float
    distance_m: float
    status: str  # "ok", "lost" (silent past the heartbeat timeout) or "out of service" (it reported so)
    idle_s: float = 0.0  # mission time with no task assigned (on the ground, hovering or flying home)
    waiting_s: float = 0.0  # its attempts' seconds waiting for clearance and holding (PhaseTimes.clearance_s)
    #: ``waiting_s`` split: on its pad with a task, and in the air (:func:`masonry.mission.waits.waiting_split_s`)
    waiting_ground_s: float = 0.0
    waiting_air_s: float = 0.0
    #: seconds it hovered near the wall with no task, for one due soon instead of flying home
    #: (:mod:`masonry.mission.linger`), and how many times it did
    lingering_s: float = 0.0
    lingers: int = 0

    def to_dict(self) -> dict[str, object]:
        return {
            "name": self.name,
            "role": self.role,
            "busy_s": _r(self.busy_s, 2),
            "idle_s": _r(self.idle_s, 2),
            "waiting_s": _r(self.waiting_s, 2),
            "waiting_ground_s": _r(self.waiting_ground_s, 2),
            "waiting_air_s": _r(self.waiting_air_s, 2),
            "lingering_s": _r(self.lingering_s, 2),
            "lingers": self.lingers,
            "distance_m": _r(self.distance_m, 2),
            "status": self.status,
        }


@dataclass(frozen=True)
class TaskReport:
    """One task: the attempt that completed it (start at its assignment, end at its completion)."""

    id: str
    uav: str | None
    start_s: float | None
    end_s: float | None
    status: str  # "done", "stuck" (attempt limit reached or no UAV of its role left) or "pending"
    attempts: int
    kind: str = "brick"
    phases: PhaseTimes | None = None  # of the attempt that completed it (None: not done, or not reported)
    #: when its UAV worked at its site: from the grant of its flight down there to its asking to leave
    site_start_s: float | None = None
    site_end_s: float | None = None
    #: every attempt at it, in start order (``attempts_detail`` in the JSON: who, when, how, why it failed)
    tries: tuple[AttemptReport, ...] = ()
    #: why it waited, in time order (:mod:`masonry.mission.waits`; ``waits`` in the JSON)
    waits: tuple[TaskWait, ...] = ()

    def to_dict(self) -> dict[str, object]:
        return {
            "id": self.id,
            "uav": self.uav,
            "start_s": _r(self.start_s, 2),
            "end_s": _r(self.end_s, 2),
            "site_start_s": _r(self.site_start_s, 2),
            "site_end_s": _r(self.site_end_s, 2),
            "status": self.status,
            "attempts": self.attempts,
            "attempts_detail": [a.detail() for a in self.tries],
            "phases": _phases(self.phases),
            "waits": [w.to_dict() for w in self.waits],
        }


@dataclass(frozen=True)
class AttemptReport:
    """One assignment of a task to a UAV (for the Gantt chart: failures are marked)."""

    task_id: str
    uav: str
    attempt: int  # the assignment's number (``Attempt.attempt``), not its count against ``max_attempts``
    start_s: float
    end_s: float | None
    status: str  # "done", "failed", "running" (the mission ended first)
    kind: str
    reason: str | None = None
    phases: PhaseTimes | None = None  # as its UAV measured them (None: not reported, or still running)

    def detail(self) -> dict[str, object]:
        """One entry of a task's ``attempts_detail``: ``outcome`` done/failed/running, ``reason`` (failed only)."""
        return {
            "uav": self.uav,
            "start_s": _r(self.start_s, 2),
            "end_s": _r(self.end_s, 2),
            "outcome": self.status,
            "reason": self.reason if self.status == "failed" else None,
        }


def _r(v: float | None, nd: int) -> float | None:
    if v is None or not math.isfinite(v):
        return None
    return round(float(v), nd)


def _phases(phases: PhaseTimes | None) -> dict[str, float | None] | None:
    return None if phases is None else {name: _r(s, 2) for name, s in phases.items()}


def phase_totals(attempts: Iterable[AttemptReport]) -> PhaseTimes:
    """The phases of ``attempts`` summed (those that reported none count nothing)."""
    total = PhaseTimes()
    for a in attempts:
        if a.phases is not None:
            total = total + a.phases
    return total


def idle_s(attempts: Sequence[AttemptReport], uav: str, start_s: float, end_s: float) -> float:
    """Seconds of ``[start_s, end_s]`` in which ``uav`` had no attempt assigned (mission control's times).

    A UAV has one attempt at a time, so its idle time and its attempts' phases add up to the window.
    """
    busy = 0.0
    for a in attempts:
        if a.uav != uav:
            continue
        s, e = max(a.start_s, start_s), min(end_s if a.end_s is None else a.end_s, end_s)
        busy += max(0.0, e - s)
    return max(0.0, end_s - start_s - busy)


def makespan_s(attempts: Sequence[AttemptReport], start_s: float = 0.0) -> float:
    """Time from ``start_s`` to the last completion."""
    ends = [a.end_s for a in attempts if a.status == "done" and a.end_s is not None]
    return max(ends) - start_s if ends else 0.0
