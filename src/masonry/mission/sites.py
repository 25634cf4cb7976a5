"""Site intervals: when each task's UAV works at its site, and (``--reservation site``) the rule that conflicting
tasks never work at their sites at once.

The paper keeps conflicting tasks (G^c: sites within r_c) from running at the same time at all. A brick task is
mostly spent away from its drop-off, though (the flight to the pallet, the pose estimate, the grasp), so with the
``site`` reservation the dispatcher may give conflicting tasks to two UAVs and mission control keeps only their
*site intervals* apart: from the grant of a UAV's flight down to its task's site (the drop-off, or the start of
the adhesion segment) to the moment it asks to fly elsewhere (or its task or the UAV ends). A UAV whose site is
busy waits for it like for a busy column, at a hold point (:class:`masonry.mission.airspace.SiteGate`).

Pure: no I/O, no clock (times are passed in).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Protocol

from masonry.planner.tasks import BrickTask, Plan, Task

Vec3 = tuple[float, float, float]
XY = tuple[float, float]

#: A flight to within this (horizontally) of a task's work point goes to its site (pickups and homes are
#: metres away: validation keeps pads 1 m from the wall, generated pallets are r_c + 1 m from it).
AT_SITE_M = 0.5


def work_point_m(task: Task) -> Vec3:
    """Where a task's UAV works: a brick's drop-off, an adhesion segment's start."""
    p = task.position_m if isinstance(task, BrickTask) else task.start_m
    return (float(p[0]), float(p[1]), float(p[2]))


def work_span_m(task: Task) -> tuple[XY, XY]:
    """Where a task's UAV works, seen from above: a brick's drop-off (a point), an adhesion segment."""
    if isinstance(task, BrickTask):
        p = (float(task.position_m[0]), float(task.position_m[1]))
        return p, p
    return (float(task.start_m[0]), float(task.start_m[1])), (float(task.end_m[0]), float(task.end_m[1]))


class SiteGate(Protocol):
    """Who else decides whether a UAV may come down at a site (mission control's site intervals: conflicting
    tasks never work at their sites at once, ``--reservation site``)."""

    def may_enter(self, uav: str, site_m: Vec3) -> bool:
        """``uav`` may come down at ``site_m`` now (False: it waits, at a hold point, as for a busy site)."""
        ...

    def entered(self, uav: str, site_m: Vec3, now_s: float) -> None:
        """``uav`` was granted its flight down to ``site_m`` at ``now_s``."""
        ...

    def waited_on(self, uav: str) -> tuple[tuple[XY, XY], ...]:
        """Where the not-done tasks ``uav``'s task waits on are worked (each a span, start to end): a UAV that
        waits for them must not hold over them, or their UAVs would wait for it in turn."""
        ...

    def left(self, uav: str, now_s: float) -> bool:
        """``uav`` moves on from its site (it asked for another one): its visit ends (True if one did)."""
        ...


def enter_ungoverned(gate: SiteGate | None, uav: str, site_m: Vec3, now_s: float) -> bool:
    """A flight with no airspace rules (separation off) goes unless ``gate`` holds it back; True: it goes (and the
    gate is told it entered)."""
    if gate is None:
        return True
    if not gate.may_enter(uav, site_m):
        return False
    gate.entered(uav, site_m, now_s)
    return True


@dataclass
class SiteVisit:
    """One stay of a task's UAV at its site."""

    task_id: str
    uav: str
    start_s: float
    end_s: float | None = None
    #: journaled by a run before a resume (an open one was cut by the crash: its end is not known)
    restored: bool = False


class SiteIntervals:
    """The site intervals of a mission, and its :class:`~masonry.mission.airspace.SiteGate`.

    Args:
        plan: the tasks and their conflicts.
        task_of: UAV name -> the task it works on now (None: none).
        exclusive: keep conflicting tasks' site intervals apart (``site`` reservation); False only records them
            (``task``: the dispatcher already keeps conflicting tasks apart for their whole duration).
        on_visit: called when a visit starts and when it ends (mission control journals them).
    """

    def __init__(
        self,
        plan: Plan,
        task_of: Callable[[str], str | None],
        *,
        exclusive: bool,
        on_visit: Callable[[SiteVisit], None] | None = None,
        is_done: Callable[[str], bool] | None = None,
    ) -> None:
        self._tasks = {t.id: t for t in plan.tasks}
        self._work = {t.id: work_point_m(t) for t in plan.tasks}
        self._span = {t.id: work_span_m(t) for t in plan.tasks}
        self._neighbours: dict[str, set[str]] = {t.id: set() for t in plan.tasks}
        for a, b in plan.conflicts:
            self._neighbours[a].add(b)
            self._neighbours[b].add(a)
        self._task_of = task_of
        self.exclusive = exclusive
        self._is_done = is_done
        self._prerequisites: dict[str, list[str]] = {}
        for u, v in plan.dependencies:
            self._prerequisites.setdefault(u, []).append(v)
        self._on_visit = on_visit
        self.on_site: dict[str, SiteVisit] = {}  # task id -> its visit in progress
        self._uav_visit: dict[str, SiteVisit] = {}  # UAV -> its visit in progress
        self.visits: list[SiteVisit] = []

    def _work_task(self, uav: str, site_m: Vec3) -> str | None:
        tid = self._task_of(uav)
        if tid is None:
            return None
        w = self._work[tid]
        return tid if math.hypot(site_m[0] - w[0], site_m[1] - w[1]) < AT_SITE_M else None

    def is_work_site(self, uav: str, site_m: Vec3) -> bool:
        """``site_m`` is where ``uav``'s task is worked (a flight there starts a site interval)."""
        return self._work_task(uav, site_m) is not None

    def may_enter(self, uav: str, site_m: Vec3) -> bool:
        """No conflicting task's UAV is at its site (``exclusive``); any other flight may go."""
        if not self.exclusive:
            return True
        tid = self._work_task(uav, site_m)
        if tid is None:
            return True
        # over the visits in progress (one per UAV at most), not the task's neighbourhood (hundreds on a long wall)
        neighbours = self._neighbours[tid]
        if any(visit.uav != uav for n, visit in self.on_site.items() if n in neighbours):
            return False
        done = self._is_done
        return done is None or all(done(p) for p in self._prerequisites.get(tid, ()))

    def waited_on(self, uav: str) -> tuple[tuple[XY, XY], ...]:
        """The work spans of the prerequisites of ``uav``'s task that are not done (:class:`SiteGate`)."""
        tid = self._task_of(uav)
        if tid is None:
            return ()
        done = self._is_done
        return tuple(self._span[p] for p in self._prerequisites.get(tid, ()) if done is None or not done(p))

    def entered(self, uav: str, site_m: Vec3, now_s: float) -> None:
        """``uav``'s flight down to ``site_m`` was granted: if that is its task's site, its visit starts."""
        tid = self._work_task(uav, site_m)
        if tid is None:
            return
        current = self._uav_visit.get(uav)
        if current is not None and current.task_id == tid:
            return  # the same stay (a hold flight, then the rest)
        self.left(uav, now_s)
        visit = SiteVisit(tid, uav, now_s)
        self.on_site[tid] = visit
        self._uav_visit[uav] = visit
        self.visits.append(visit)
        if self._on_visit is not None:
            self._on_visit(visit)

    def left(self, uav: str, now_s: float) -> bool:
        """``uav`` leaves its site (it asked to fly elsewhere, or it is out of the mission); True if a visit ended."""
        visit = self._uav_visit.pop(uav, None)
        if visit is None:
            return False
        visit.end_s = now_s
        self.on_site.pop(visit.task_id, None)
        if self._on_visit is not None:
            self._on_visit(visit)
        return True

    def restore(self, visits: list[SiteVisit]) -> None:
        """The visits a previous run journaled (before a resume): for the report only; none is in progress."""
        self.visits = [*visits, *self.visits]

    def released(self, uav: str, site_m: Vec3, now_s: float) -> bool:
        """``uav`` is out of the column over ``site_m`` (or gave it up): if that was its site, its visit ends."""
        visit = self._uav_visit.get(uav)
        if visit is None:
            return False
        w = self._work[visit.task_id]
        if math.hypot(site_m[0] - w[0], site_m[1] - w[1]) >= AT_SITE_M:
            return False
        return self.left(uav, now_s)

    def leaving(self, uav: str, site_m: Vec3, now_s: float) -> bool:
        """``uav`` asks to fly to ``site_m``: a visit elsewhere ends (True if one did)."""
        visit = self._uav_visit.get(uav)
        if visit is None:
            return False
        w = self._work[visit.task_id]
        if math.hypot(site_m[0] - w[0], site_m[1] - w[1]) < AT_SITE_M:
            return False
        return self.left(uav, now_s)


#: Journal meta keys of the site intervals: ``site/<task id>`` -> the task's last visit.
SITE_META_PREFIX = "site/"


def journaled_visits(meta: Mapping[str, Any], done: set[str], last_time_s: float | None) -> list[SiteVisit]:
    """The site visits of the tasks a journal says are done; one still open at the crash ends at it
    (``last_time_s``, the journal's last record): the resumed mission control holds no reservation of the run
    before, so every UAV asks again for any column and site (in simulation it restarts on its pad)."""
    out = []
    for key, v in meta.items():
        tid = key[len(SITE_META_PREFIX) :]
        if not key.startswith(SITE_META_PREFIX) or tid not in done or not isinstance(v, dict):
            continue
        start, end, uav = v.get("start_s"), v.get("end_s"), v.get("uav")
        if not isinstance(start, (int, float)) or not isinstance(uav, str):
            continue
        if not isinstance(end, (int, float)):
            end = last_time_s  # its UAV was still there at the crash (None: the journal has no time)
        out.append(SiteVisit(tid, uav, float(start), None if end is None else float(end), restored=True))
    return sorted(out, key=lambda v: (v.start_s, v.task_id))


__all__ = [
    "AT_SITE_M",
    "SITE_META_PREFIX",
    "SiteGate",
    "SiteIntervals",
    "SiteVisit",
    "enter_ungoverned",
    "journaled_visits",
    "work_point_m",
    "work_span_m",
]
