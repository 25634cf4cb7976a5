"""The attempt ledger: every attempt mission control made, the running one of each task, and their journal lines.

An :class:`~masonry.mission.records.Attempt` begins when a task is assigned (journaled ``assigned``) and ends done
(``completed``), failed (``failed``: a failure report, a UAV lost with it, a task its UAV forgot) or, for a
completion heard late, done after all. :meth:`AttemptLedger.restore` rebuilds the history from a journal's
replayed state (``--resume``). The ledger only records: what a result means for the dispatcher, the airspace and
the spares is mission control's (:mod:`masonry.mission.control`).

The ledger numbers the assignments: each assignment of a task gets the next number, whether the failure before it
counted against the task or not (a lost link, the operator's recall, the battery, mission control lost). The
number is the protocol's ``attempt`` (an assignment, its result and a recall of it name it), so a stale recall or
result of an earlier flight cannot match a later one. It is journaled with the assignment and carries on after a
resume (:meth:`restore`); how many attempts count against the task's ``max_attempts`` is the dispatcher's
(``Dispatcher.attempts``), not this number (issue 27, branch ``attempt43``).

A brick attempt whose UAV said its brick is on the wall (released at its place, not yet reported done) is journaled
too (:meth:`AttemptLedger.journal_released`, the meta key ``released/<task id>``): a resumed mission control that
then loses the UAV counts the task done, as the run that heard it would have (:func:`journaled_releases`; branch
``resume50``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

from masonry.mission.as_built import journaled_as_built, take_result
from masonry.mission.control_ports import JournalPort
from masonry.mission.journal_state import journaled_phases
from masonry.mission.records import Attempt, AttemptStatus, completion_fields
from masonry.mission.sites import SITE_META_PREFIX
from masonry.ports import TaskResult

if TYPE_CHECKING:
    from masonry.mission.journal_state import DoneRecord, FailureRecord
    from masonry.mission.sites import SiteVisit

__all__ = ["RELEASED_META_PREFIX", "AttemptLedger", "ReleaseMark", "journaled_releases"]

#: Journal meta keys of the brick attempts whose UAV said its brick was released at its place:
#: ``released/<task id>`` -> {uav, attempt, time_s, state} (the latest such attempt of the task).
RELEASED_META_PREFIX = "released/"


@dataclass(frozen=True)
class ReleaseMark:
    """A brick attempt whose UAV was heard with its brick on the wall: its UAV, number, time and state then."""

    task_id: str
    uav: str
    attempt: int
    time_s: float
    state: str = ""


def journaled_releases(meta: Mapping[str, object]) -> dict[str, ReleaseMark]:
    """The release marks a journal's meta table holds, by task id (anything unreadable in it is ignored; a journal
    written before them has none)."""
    out: dict[str, ReleaseMark] = {}
    for key, v in meta.items():
        if not key.startswith(RELEASED_META_PREFIX) or not isinstance(v, Mapping):
            continue
        uav, attempt, time_s, state = v.get("uav"), v.get("attempt"), v.get("time_s"), v.get("state", "")
        if isinstance(uav, str) and isinstance(attempt, int) and isinstance(time_s, (int, float)):
            tid = key[len(RELEASED_META_PREFIX) :]
            out[tid] = ReleaseMark(tid, uav, attempt, float(time_s), str(state))
    return out


class AttemptLedger:
    """The history of attempts and the running one per task, written to ``journal`` (None: none) as they change."""

    def __init__(self, journal: JournalPort | None) -> None:
        self.journal = journal
        self.history: list[Attempt] = []
        self.running: dict[str, Attempt] = {}  # task id -> its running attempt
        #: attempts ended by a result or by their UAV dropping them (progress for the stall watchdog)
        self.results = 0
        #: (task id, UAV, attempt) of the attempts in ``history`` ended done (:meth:`completed`; kept by
        #: :meth:`end` and :meth:`restore`, so a result asks a set, not the whole history)
        self._done_keys: set[tuple[str, str, int]] = set()
        #: task id -> the number of its latest assignment (:meth:`begin` gives the next one)
        self._numbers: dict[str, int] = {}
        #: (task id, attempt) of the attempts whose UAV said it works on them (:meth:`under_way`)
        self._under_way: set[tuple[str, int]] = set()
        #: (task id, attempt) of the brick attempts journaled as released (:meth:`journal_released`)
        self._released: set[tuple[str, int]] = set()

    def begin(self, task_id: str, uav: str, now_s: float) -> Attempt:
        """``task_id`` assigned to ``uav`` now, numbered one more than its previous assignment: running,
        journaled."""
        number = self._numbers.get(task_id, 0) + 1
        self._numbers[task_id] = number
        att = Attempt(task_id, uav, number, now_s)
        self.history.append(att)
        self.running[task_id] = att
        if self.journal is not None:
            self.journal.record_assignment(now_s, task_id, uav, number)
        return att

    def adopt(self, task_id: str, uav: str, attempt: int, start_s: float) -> Attempt:
        """A journaled attempt still running when the previous run stopped: running again (not journaled twice)."""
        att = Attempt(task_id, uav, attempt, start_s, adopted=True)
        self.history.append(att)
        self.running[task_id] = att
        self._numbers[task_id] = max(self._numbers.get(task_id, 0), attempt)
        return att

    def under_way(self, task_id: str, uav: str) -> Attempt | None:
        """``uav`` reported progress on ``task_id``: its running attempt if that is the first word of it from
        ``uav`` (None: not its attempt, or said before)."""
        att = self.running.get(task_id)
        if att is None or att.uav != uav or (task_id, att.attempt) in self._under_way:
            return None
        self._under_way.add((task_id, att.attempt))
        return att

    def number_of(self, task_id: str) -> int:
        """The number of ``task_id``'s running attempt, else of its latest one (0: never assigned): what a recall
        of the assignment in progress names."""
        att = self.running.get(task_id)
        return att.attempt if att is not None else self._numbers.get(task_id, 0)

    def end(
        self,
        att: Attempt,
        now_s: float,
        status: AttemptStatus,
        reason: str | None = None,
        *,
        result: bool = True,
    ) -> None:
        """``att`` ended now (no longer running); ``result``: on a result or a dropped task (counted)."""
        if self.running.get(att.task_id) is att:
            del self.running[att.task_id]
        if result:
            self.results += 1
        key = (att.task_id, att.uav, att.attempt)
        if status == "done":
            self._done_keys.add(key)
        elif att.status == "done":
            self._done_keys.discard(key)
        att.end_s = now_s
        att.status = status
        att.reason = reason

    def done(self, att: Attempt, r: TaskResult, now_s: float) -> None:
        """``att`` completed with result ``r`` (its measurements kept); not journaled (:meth:`journal_done`)."""
        self.end(att, now_s, "done")
        take_result(att, r)

    def journal_done(self, now_s: float, r: TaskResult, att: Attempt, *, phases: bool = True) -> None:
        """Journal the completion ``r`` of ``att`` (with its phases unless ``phases`` is False: heard late)."""
        if self.journal is not None:
            fields = completion_fields(r, phases=phases)
            self.journal.record_completion(now_s, r.task_id, att.uav, attempt=att.attempt, **fields)

    def journal_failed(self, now_s: float, att: Attempt, reason: str) -> None:
        """Journal that ``att`` failed with ``reason``."""
        if self.journal is not None:
            self.journal.record_failure(now_s, att.task_id, att.uav, reason, attempt=att.attempt)

    def journal_lost(self, now_s: float, uav: str) -> None:
        """Journal that ``uav`` is out of the mission."""
        if self.journal is not None:
            self.journal.record_uav_lost(now_s, uav)

    def journal_released(self, now_s: float, att: Attempt, state: str) -> None:
        """``att``'s UAV said its brick is on the wall (in ``state``): journaled once per attempt (meta
        ``released/<task id>``), for a resumed mission control that loses the UAV (:func:`journaled_releases`)."""
        key = (att.task_id, att.attempt)
        if key in self._released:
            return
        self._released.add(key)
        mark = {"uav": att.uav, "attempt": att.attempt, "time_s": now_s, "state": state}
        self.set_meta(f"{RELEASED_META_PREFIX}{att.task_id}", mark)

    def released(self, att: Attempt) -> bool:
        """``att``'s UAV said its brick is on the wall (:meth:`journal_released`, or the journal's mark)."""
        return (att.task_id, att.attempt) in self._released

    def released_before(self, mark: ReleaseMark) -> None:
        """A release the journal holds (a resume): not journaled again."""
        self._released.add((mark.task_id, mark.attempt))

    def set_meta(self, key: str, value: object) -> None:
        """Keep ``value`` under ``key`` in the journal's metadata (none without a journal)."""
        if self.journal is not None:
            self.journal.set_meta(key, value)

    def journal_visit(self, visit: SiteVisit) -> None:
        """A site interval started or ended: journaled (the last visit of each task), for a resumed report."""
        record = {"uav": visit.uav, "start_s": visit.start_s, "end_s": visit.end_s}
        self.set_meta(f"{SITE_META_PREFIX}{visit.task_id}", record)

    def completed(self, task_id: str, uav: str, attempt: int) -> bool:
        """This very attempt was already taken as done (its UAV said it again)."""
        return (task_id, uav, attempt) in self._done_keys

    def find(self, task_id: str, uav: str, attempt: int) -> Attempt | None:
        """``uav``'s attempt ``attempt`` of ``task_id``, if it had that one."""
        return next(
            (
                a
                for a in reversed(self.history)
                if a.task_id == task_id and a.attempt == attempt and a.uav == uav
            ),
            None,
        )

    def restore(
        self,
        failures: tuple[FailureRecord, ...],
        done: Mapping[str, DoneRecord],
        numbers: Mapping[str, int],
    ) -> None:
        """The failed and the completed attempts of a journal's replayed state, into the history; each task's next
        assignment numbered after the highest number the journal gave it (``numbers``: ``JournalState.numbers``)."""
        for task_id, n in numbers.items():
            self._numbers[task_id] = max(self._numbers.get(task_id, 0), n)
        for f in failures:
            start_s = f.start_s if f.start_s is not None else f.time_s
            self.history.append(Attempt(f.task_id, f.uav, f.attempt, start_s, f.time_s, "failed", f.reason))
        for task_id, rec in done.items():
            fields = dict(rec.fields)
            self.history.append(
                Attempt(
                    task_id=task_id,
                    uav=rec.uav,
                    attempt=rec.attempt,
                    start_s=rec.start_s if rec.start_s is not None else rec.time_s,
                    end_s=rec.time_s,
                    status="done",
                    placement_error_m=fields.get("placement_error_m"),
                    coverage=fields.get("coverage"),
                    phases=journaled_phases(fields.get("phases")),
                    as_built=journaled_as_built(fields.get("as_built")),
                )
            )
            self._done_keys.add((task_id, rec.uav, rec.attempt))

    def sort(self) -> None:
        """The history in the order the attempts began (after a restore)."""
        self.history.sort(key=lambda a: (a.start_s, a.task_id))
