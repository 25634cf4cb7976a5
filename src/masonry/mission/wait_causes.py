"""What each task waits for now, read from mission control's state (its dispatcher, airspace, operator, wind).

:class:`WaitWatch` is told every tick (:meth:`WaitWatch.observe`) and hands :class:`~masonry.mission.waits.WaitLog`
the causes that changed. Two parts, looked at again only when what they read changed:

- a task not assigned waits for its first unfinished prerequisite (plan order: when it completes, the next one),
  else (``task`` reservation) a conflicting task in progress, else a UAV of its role: none idle (``fleet``), or
  the idle ones may not fly (the operator, the wind) or not take off (``take-off``: the column over the pad);
  the operator's pause holds every one of them;
- a task assigned waits while its UAV's flight is asked for and not granted: the site rule or the adhesive
  (the gate mission control's airspace asks first), else the UAVs the airspace names (``blockers``).

The airspace is read through three questions only (``asked_for``, ``blockers``, ``can_take_off``), so another
airspace answering them feeds the same record. Pure: no I/O, no clock.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from collections.abc import Set as AbstractSet
from typing import TYPE_CHECKING

from masonry.errors import MissionError
from masonry.mission.airspace import ON_PAD_Z_M
from masonry.mission.airspace_state import Phase
from masonry.mission.report_codec import wait_record, waits_from_record
from masonry.mission.table_holds import is_held
from masonry.mission.waits import AIR, GROUND, TaskWait, WaitCause, WaitLog
from masonry.planner.tasks import Plan

if TYPE_CHECKING:
    from masonry.mission.airspace import ColumnClearance
    from masonry.mission.control import MissionControl
    from masonry.mission.control_ports import JournalPort
    from masonry.mission.reserved import TableClearance

Vec3 = tuple[float, float, float]

_OPERATOR = WaitCause("operator")

#: ``holds`` of an ``airspace`` wait while the UAV flies to its hold point: the answer waits for its arrival
TO_HOLD = "to-hold"


#: Journal meta keys of the waits: ``waits/<task id>`` -> the task's closed waits (:func:`wait_record` each).
WAITS_META_PREFIX = "waits/"


class WaitWatch:
    """Mission control's record of why each task waited (:attr:`log`), kept up to date by :meth:`observe`."""

    def __init__(self, plan: Plan, reservation: str) -> None:
        self.log = WaitLog()
        self._journal: JournalPort | None = None
        self._journaled: dict[str, list[dict[str, object]]] = {}  # task id -> its closed waits, as journaled
        self._order = {t.id: i for i, t in enumerate(plan.tasks)}
        self._role = {t.id: t.kind for t in plan.tasks}
        self._task_rule = reservation == "task"
        self._prereqs: dict[str, list[str]] = {}
        for u, v in plan.dependencies:
            self._prereqs.setdefault(u, []).append(v)
        for ps in self._prereqs.values():
            ps.sort(key=self._order.__getitem__)
        self._neighbours: dict[str, list[str]] = {}
        for a, b in plan.conflicts:
            self._neighbours.setdefault(a, []).append(b)
            self._neighbours.setdefault(b, []).append(a)
        self._pending = {t.id for t in plan.tasks if not t.done}  # neither done nor stuck
        self._waiting_on: dict[str, set[str]] = {}  # prerequisite -> tasks waiting for it
        self._frontier: set[str] = set()  # pending tasks whose prerequisites are done
        self._blocked_by: dict[str, str] = {}  # task -> the prerequisite it is filed under
        self._seen_done = {t.id for t in plan.tasks if t.done}
        self._holds: bool | None = None  # the operator's pause at the last look (None: not looked yet)
        self._running_was: set[str] = set()
        self._task_sig: object = None
        self._air_sig: object = None
        self._held: set[str] = set()  # running tasks with a wait open for their flight
        #: UAV -> (its task, the site) while the last answer to its request said no
        self._refused: dict[str, tuple[str, Vec3]] = {}

    # -- the tick --------------------------------------------------------------------------------------
    def restore(self, meta: Mapping[str, object]) -> None:
        """The waits a previous run journaled (before a resume): its report lists them too (a wait still open at
        the crash was not journaled: it ended there, and the resumed run sees its cause again)."""
        for key, value in meta.items():
            if key.startswith(WAITS_META_PREFIX):
                try:
                    waits = waits_from_record(value)
                except MissionError as exc:
                    logging.getLogger(__name__).warning("ignoring the journaled %s: %s", key, exc)
                    continue
                self.log.closed.extend(waits)
                self._journaled[key[len(WAITS_META_PREFIX) :]] = [wait_record(w) for w in waits]
        self.log.closed.sort(key=lambda w: (w.from_s, w.task_id))

    def _keep(self, w: TaskWait) -> None:
        """A wait closed: the task's closed waits go to the journal (``waits/<task id>``)."""
        mine = self._journaled.setdefault(w.task_id, [])
        mine.append(wait_record(w))
        if self._journal is not None:
            self._journal.set_meta(f"{WAITS_META_PREFIX}{w.task_id}", mine)

    def observe(self, mc: MissionControl, now_s: float) -> None:
        """Mission control's state at ``now_s``: the causes that changed since the last call go to the log."""
        if self.log.on_close is None:
            self._journal, self.log.on_close = mc.journal, self._keep
        d = mc.dispatcher
        wind = mc.wind_limit
        columns = mc.columns
        op = mc.operator
        task_sig = (
            d.events,
            op.version,
            op.paused,
            op.aborting,
            None if wind is None else wind.version,
            None if mc._deferred_at is None else columns.version,
        )
        if task_sig != self._task_sig:
            self._task_sig = task_sig
            self._tasks(mc, now_s)
        running = d.in_progress
        refused = self._refused
        asking = tuple(
            n
            for tid, n in running.items()
            if columns.asked_for(n) is not None or (n in refused and refused[n][0] == tid)
        )
        air_sig = (columns.version, d.events, asking)
        if air_sig != self._air_sig or any(t not in running for t in self._held):
            self._air_sig = air_sig
            self._flights(mc, now_s, asking)

    def answered(self, uav: str, task_id: str | None, site_m: Vec3, granted: bool) -> None:
        """Mission control answered ``uav``'s request for a flight to ``site_m`` (for ``task_id``): a refusal
        counts as a wait until a grant, even from an airspace that keeps no request (no transit layers)."""
        if granted or task_id is None:
            self._refused.pop(uav, None)
        else:
            self._refused[uav] = (task_id, site_m)

    # -- tasks not assigned ----------------------------------------------------------------------------
    def _place(self, tid: str, done: AbstractSet[str]) -> None:
        """File ``tid`` under its first unfinished prerequisite, or in the frontier."""
        first = next((p for p in self._prereqs.get(tid, ()) if p not in done), None)
        if first is None:
            self._frontier.add(tid)
            self._blocked_by.pop(tid, None)
        else:
            self._waiting_on.setdefault(first, set()).add(tid)
            self._blocked_by[tid] = first

    def _tasks(self, mc: MissionControl, now_s: float) -> None:
        """The tasks not assigned whose cause may have changed: those whose prerequisite completed, those back
        in the pool, every one when the operator's pause starts or ends, and the frontier."""
        d = mc.dispatcher
        log = self.log
        pending = self._pending
        dirty: set[str] = set()
        if self._holds is None:  # the first look: every task
            for tid in pending:
                self._place(tid, d.done)
            dirty.update(pending)
        dirty.update(self._finished(mc, now_s))
        holds = mc.operator.holds_dispatch()
        if holds != self._holds:
            self._holds = holds
            dirty.update(pending)
        running = set(d.in_progress)
        dirty.update(self._running_was - running)  # back in the pool (done and stuck ones are not pending)
        for tid in running - self._running_was:
            if tid not in self._held:
                log.set(now_s, tid, None)  # assigned: from now on its flight's part says
        self._running_was = running
        dirty.update(self._frontier)
        refusals = self._refusals(mc) if self._frontier else {}
        for tid in dirty:
            if tid not in pending or tid in running:
                continue
            if holds:
                cause = _OPERATOR
            elif tid in self._frontier:
                cause = self._ready_cause(mc, tid, refusals)
            else:
                cause = WaitCause("dependency", blocking_task=self._blocked_by[tid])
            log.set(now_s, tid, cause)

    def _finished(self, mc: MissionControl, now_s: float) -> set[str]:
        """Tasks done or stuck since the last look leave the pending ones (their waits end); returns the tasks
        that waited for one done and now wait for something else."""
        d = mc.dispatcher
        log = self.log
        pending = self._pending
        dirty: set[str] = set()
        done, seen = d.done, self._seen_done
        if len(done) != len(seen):
            last = d.last_done
            if len(done) == len(seen) + 1 and last is not None and last not in seen:
                fresh = [last]  # (done only grows and the seen are among its tasks: the one new is the last)
            else:
                fresh = [t for t in done if t not in seen]
            for tid in fresh:
                self._seen_done.add(tid)
                pending.discard(tid)
                self._frontier.discard(tid)
                log.set(now_s, tid, None)
                for waiter in self._waiting_on.pop(tid, ()):
                    if waiter in pending:
                        self._place(waiter, d.done)
                        dirty.add(waiter)
        if d.stuck:
            for tid in [t for t in pending if t in d.stuck]:
                pending.discard(tid)
                self._frontier.discard(tid)
                log.set(now_s, tid, None)
        return dirty

    def _ready_cause(self, mc: MissionControl, tid: str, refusals: dict[str, WaitCause | None]) -> WaitCause:
        """Why a task whose prerequisites are done is not assigned."""
        d = mc.dispatcher
        if self._task_rule:
            for other in self._neighbours.get(tid, ()):
                uav = d.in_progress.get(other)
                if uav is not None:
                    return WaitCause("conflict", uav, other)
        role = self._role[tid]
        for name in d.idle_uavs:
            if mc.uavs[name].spec.role == role:
                why = refusals[name]
                if why is not None:
                    return why
        return WaitCause("fleet")

    def _refusals(self, mc: MissionControl) -> dict[str, WaitCause | None]:
        """Why each idle UAV may not take a task now (None: nothing known stops it)."""
        out: dict[str, WaitCause | None] = {}
        wind = mc.wind_limit
        for name in mc.dispatcher.idle_uavs:
            if not mc.operator.may_fly(mc, name):
                out[name] = _OPERATOR
            elif mc.swaps.is_sent(mc, name):  # given nothing: it flies home for a fresh pack (swap_stagger)
                out[name] = WaitCause("battery", name)
            elif wind is not None and not wind.allows(name):
                out[name] = WaitCause("wind")
            elif not mc.columns.can_take_off(name):
                by = mc.columns.blockers(name)
                other, kind = by[0] if by else (None, None)
                task = None if other is None else mc.dispatcher.task_of(other)
                out[name] = WaitCause("take-off", other, task, kind, where=GROUND)
            else:
                out[name] = None
        return out

    # -- tasks assigned --------------------------------------------------------------------------------
    def _flights(self, mc: MissionControl, now_s: float, asking: tuple[str, ...]) -> None:
        d = mc.dispatcher
        held: set[str] = set()
        for name in asking:
            tid = d.task_of(name)
            if tid is None:
                continue
            held.add(tid)
            self.log.set(now_s, tid, self._flight_cause(mc, name, tid))
        for tid in self._held - held:
            if tid in d.in_progress:  # granted (one back in the pool, done or stuck is the other part's)
                self.log.set(now_s, tid, None)
        self._held = held

    def _flight_cause(self, mc: MissionControl, name: str, tid: str) -> WaitCause:
        """Why ``name``'s flight for ``tid`` is not granted: the site gate first (the airspace asks it first),
        then the UAVs in the way."""
        link = mc.uavs[name]
        p = link.position_m
        where = AIR if p is None or p[2] - link.spec.home_m[2] > ON_PAD_Z_M else GROUND
        site = mc.columns.asked_for(name)
        if site is None and name in self._refused:
            site = self._refused[name][1]
        gate = mc.glue if mc.glue is not None else mc.sites
        if site is not None and not gate.may_enter(name, site):
            on_site = mc.sites.on_site
            for other in self._neighbours.get(tid, ()):
                visit = on_site.get(other)
                if visit is not None and visit.uav != name:
                    return WaitCause("site", visit.uav, other, None, name, where)
            for prereq in self._prereqs.get(tid, ()):
                if prereq not in mc.dispatcher.done:
                    uav = mc.dispatcher.in_progress.get(prereq)
                    return WaitCause("dependency", uav, prereq, None, name, where)
            if mc.sites.may_enter(name, site):
                return WaitCause("glue", uav=name, where=where)
        return airspace_cause(mc.columns, name, mc.dispatcher.task_of, where)


def airspace_cause(
    columns: ColumnClearance | TableClearance,
    name: str,
    task_of: Callable[[str], str | None],
    where: str | None,
) -> WaitCause:
    """Why the airspace holds ``name``'s flight back: the first UAV the airspace names (``blockers``); when it
    names none, ``to-hold`` while ``name`` flies to its hold point (the answer waits for its arrival; the
    blockers judge the rest from where it asked), else no one (its answer is on the way)."""
    by = columns.blockers(name)
    held = is_held(by)
    if held is not None:  # (under the table: the operator's or the wind's hold keeps it on the ground)
        return WaitCause(held, uav=name, where=where)
    if not by:
        holds = TO_HOLD if columns.phase(name) is Phase.TO_HOLD else None
        return WaitCause("airspace", holds=holds, uav=name, where=where)
    other, kind = by[0]
    return WaitCause("airspace", other, task_of(other), kind, name, where)


__all__ = ["TO_HOLD", "WaitWatch", "airspace_cause"]
