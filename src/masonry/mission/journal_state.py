"""What a mission journal holds, as values: its records and the state they fold into (:func:`fold_records`).

:mod:`masonry.mission.journal` reads the rows from the SQLite file and re-exports these names.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

from masonry.errors import JournalUnusable, ProtocolError
from masonry.mission.messages import phases_from_dict
from masonry.ports import UNCOUNTED_REASONS, PhaseTimes

__all__ = [
    "LOST_REASON",
    "DoneRecord",
    "FailureRecord",
    "JournalRecord",
    "JournalState",
    "RecordKind",
    "RunningRecord",
    "fold_records",
    "journaled_phases",
]

#: the reason of an attempt released because its UAV was declared lost (not counted against the task)
LOST_REASON = "uav lost"

RecordKind = Literal["assign", "complete", "fail", "uav_lost"]


@dataclass(frozen=True)
class JournalRecord:
    """One journal line as written: ``kind`` is assign, complete, fail or uav_lost; ``data`` the extra fields."""

    seq: int
    kind: RecordKind
    time_s: float
    task_id: str | None
    uav: str
    attempt: int | None
    data: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True)
class DoneRecord:
    """A completed task: the UAV, the completion time ``time_s``, the start of the attempt that completed it.

    ``start_s`` is the time of the matching assignment record (None if the journal has none); ``fields`` holds
    what :meth:`Journal.record_completion` was given (placement error, coverage, ...).
    """

    task_id: str
    uav: str
    time_s: float
    start_s: float | None
    attempt: int
    fields: Mapping[str, Any] = field(default_factory=dict)

    @property
    def end_s(self) -> float:
        """The completion time (same as ``time_s``)."""
        return self.time_s


@dataclass(frozen=True)
class FailureRecord:
    """A failed attempt: task, UAV, failure time, start of the attempt (if journaled), attempt number, reason."""

    task_id: str
    uav: str
    time_s: float
    start_s: float | None
    attempt: int
    reason: str


@dataclass(frozen=True)
class RunningRecord:
    """An attempt assigned and not finished when the journal ends: task, UAV, assignment time, attempt number."""

    task_id: str
    uav: str
    start_s: float
    attempt: int


@dataclass(frozen=True)
class JournalState:
    """What a journal says happened, folded for ``--resume``.

    Attributes:
        done: completed tasks in completion order (a task completed twice keeps its first completion).
        attempts: finished (completed or failed) attempts per task id: the ``attempts`` argument of
            ``Dispatcher.restore``. Attempts cut short by a lost UAV or a crash are not counted.
        failures: every failed attempt, in order; an attempt released by its UAV's loss is one, with the reason
            :data:`LOST_REASON` (not counted in ``attempts``).
        numbers: the highest attempt number any record gives each task id. An attempt's number names one
            assignment (the protocol's ``attempt``): a resumed mission control numbers a task's next assignment
            after it, so no number is given twice, even to a flight whose failure was not counted (issue 27).
        in_progress: task id -> UAV of attempts assigned but neither completed, failed nor released by a UAV
            loss when the journal ends (the previous run stopped while they flew).
        running: the same attempts with their assignment times and numbers (a resumed mission control keeps
            them with their UAVs until each is heard: ``MissionControl.restore``).
        lost_uavs: UAVs declared lost, in order.
        last_time_s: the latest mission time in any record (0.0 for an empty journal): the resumed clock.
        records: every record, in write order.
        meta: the key/value pairs stored with :meth:`Journal.set_meta`.
        measured: the latest ``measured`` snapshot any record carries (what a simulator measured when it
            wrote the record: ``distances_m`` per UAV, ``min_separation_m``); empty if none does.
    """

    done: tuple[DoneRecord, ...] = ()
    attempts: Mapping[str, int] = field(default_factory=dict)
    failures: tuple[FailureRecord, ...] = ()
    numbers: Mapping[str, int] = field(default_factory=dict)
    in_progress: Mapping[str, str] = field(default_factory=dict)
    running: tuple[RunningRecord, ...] = ()
    lost_uavs: tuple[str, ...] = ()
    last_time_s: float = 0.0
    records: tuple[JournalRecord, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)
    measured: Mapping[str, Any] = field(default_factory=dict)

    @property
    def task_ids(self) -> frozenset[str]:
        """Ids of every task any record names."""
        return frozenset(r.task_id for r in self.records if r.task_id is not None)

    @property
    def uav_names(self) -> frozenset[str]:
        """Names of every UAV any record names."""
        return frozenset(r.uav for r in self.records)

    @property
    def done_ids(self) -> frozenset[str]:
        """Ids of the completed tasks."""
        return frozenset(r.task_id for r in self.done)

    @property
    def empty(self) -> bool:
        """True when the journal holds no record."""
        return not self.records


def fold_records(where: str, rows: list[tuple[Any, ...]], meta_rows: list[tuple[Any, ...]]) -> JournalState:
    """Fold a journal's rows (``seq, kind, time_s, task_id, uav, attempt, data`` in write order) and meta rows.

    Raises:
        JournalUnusable: a record or meta value that cannot be read; ``where`` names the file.
    """
    fold = _Fold()
    for seq, kind, time_s, task_id, uav, attempt, data_text in rows:
        try:
            data = json.loads(data_text)
        except (TypeError, ValueError) as exc:
            raise JournalUnusable(f"journal {where}: record {seq}: unreadable data ({exc})") from exc
        if not isinstance(data, dict) or not isinstance(time_s, (int, float)) or not isinstance(uav, str):
            raise JournalUnusable(f"journal {where}: record {seq}: malformed")
        if kind != "uav_lost" and not isinstance(task_id, str):
            raise JournalUnusable(f"journal {where}: record {seq}: {kind} record without a task id")
        if isinstance(data.get("measured"), dict):
            fold.measured = data["measured"]
        rec = JournalRecord(int(seq), kind, float(time_s), task_id, uav, attempt, MappingProxyType(data))
        fold.records.append(rec)
        fold.last = max(fold.last, rec.time_s)
        # the schema admits no other kind; anything else is folded as a loss, as it always was
        _APPLY.get(kind, _Fold.uav_lost)(fold, rec, data)
    meta: dict[str, Any] = {}
    for key, value in meta_rows:
        try:
            meta[key] = json.loads(value)
        except (TypeError, ValueError) as exc:
            raise JournalUnusable(f"journal {where}: meta {key!r}: unreadable ({exc})") from exc
    return fold.state(meta)


class _Fold:
    """A replay under way: what the records so far say, with one method per record kind."""

    def __init__(self) -> None:
        self.records: list[JournalRecord] = []
        self.done: dict[str, DoneRecord] = {}
        self.attempts: dict[str, int] = {}
        self.failures: list[FailureRecord] = []
        self.numbers: dict[str, int] = {}  # task -> the highest attempt number named
        self.running: dict[str, tuple[str, float, int]] = {}  # task -> (uav, start_s, attempt)
        self.lost: list[str] = []
        self.last = 0.0
        self.measured: dict[str, Any] = {}

    def assign(self, rec: JournalRecord, data: dict[str, Any]) -> None:
        task_id, attempt = rec.task_id, rec.attempt
        assert task_id is not None  # checked by fold_records
        number = int(attempt) if attempt else self.numbers.get(task_id, 0) + 1
        self.running[task_id] = (rec.uav, rec.time_s, number)
        self._numbered(task_id, number)

    def finish(self, rec: JournalRecord, data: dict[str, Any]) -> None:
        """A completion or a failure: the attempt ends (a battery-low failure is not counted against the task).

        The record names its attempt (journals before issue 27's numbering do not: then it is the running one of
        the task's, or the task's next by count); one naming another attempt than the running one (a completion
        heard late, a bead's glue expired) leaves the running one running."""
        task_id, uav, attempts = rec.task_id, rec.uav, self.attempts
        assert task_id is not None  # checked by fold_records
        named = int(rec.attempt) if rec.attempt else None
        start = self.running.get(task_id)
        if start is not None and (named is None or start[2] == named):
            del self.running[task_id]
        else:
            start = None
        start_s = start[1] if start is not None and start[0] == uav else None
        number = start[2] if start is not None and start[0] == uav else attempts.get(task_id, 0) + 1
        number = named or number
        self._numbered(task_id, number)
        if rec.kind == "complete" or not str(data.get("reason", "")).startswith(UNCOUNTED_REASONS):
            attempts[task_id] = attempts.get(task_id, 0) + 1  # (the UAV's battery is not the task's fault)
        if rec.kind == "complete":
            if task_id not in self.done:
                self.done[task_id] = DoneRecord(
                    task_id, uav, rec.time_s, start_s, number, MappingProxyType(data)
                )
        else:
            self.failures.append(
                FailureRecord(task_id, uav, rec.time_s, start_s, number, str(data.get("reason", "")))
            )

    def _numbered(self, task_id: str, number: int) -> None:
        self.numbers[task_id] = max(self.numbers.get(task_id, 0), number)

    def uav_lost(self, rec: JournalRecord, data: dict[str, Any]) -> None:
        """The UAV is lost: its running task is released, not counted (a failure with :data:`LOST_REASON`)."""
        if rec.uav not in self.lost:
            self.lost.append(rec.uav)
        for tid in [t for t, (u, _, _) in self.running.items() if u == rec.uav]:
            _, start_s, number = self.running.pop(tid)
            self.failures.append(FailureRecord(tid, rec.uav, rec.time_s, start_s, number, LOST_REASON))

    def state(self, meta: dict[str, Any]) -> JournalState:
        measured = self.measured
        end = meta.get("measured")  # written when a run ends: later than its last record (the UAVs flew home)
        if (
            isinstance(end, dict)
            and isinstance(end.get("time_s"), (int, float))
            and end["time_s"] >= self.last
        ):
            measured = {k: v for k, v in end.items() if k != "time_s"}
        return JournalState(
            done=tuple(self.done.values()),
            attempts=MappingProxyType(self.attempts),
            failures=tuple(self.failures),
            numbers=MappingProxyType(self.numbers),
            in_progress=MappingProxyType({t: u for t, (u, _, _) in self.running.items()}),
            running=tuple(RunningRecord(t, u, s, n) for t, (u, s, n) in self.running.items()),
            lost_uavs=tuple(self.lost),
            last_time_s=self.last,
            records=tuple(self.records),
            meta=MappingProxyType(meta),
            measured=MappingProxyType(measured),
        )


_APPLY: dict[str, Callable[[_Fold, JournalRecord, dict[str, Any]], None]] = {
    "assign": _Fold.assign,
    "complete": _Fold.finish,
    "fail": _Fold.finish,
    "uav_lost": _Fold.uav_lost,
}


def journaled_phases(value: Any) -> PhaseTimes | None:
    """The phases a journal kept with a completion (None: none kept, or not phases: a journal is a file)."""
    if value is None:
        return None
    try:
        return phases_from_dict(value, "journal complete")
    except ProtocolError:
        logging.getLogger(__name__).warning("ignoring the journaled phases %r", value)
        return None
