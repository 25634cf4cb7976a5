"""The mission journal: every assignment, completion, failure and UAV loss, durable on return, replayable.

The journal is an SQLite database (standard library ``sqlite3``) in WAL mode with ``synchronous=FULL`` (or
NORMAL on request); every record is its own transaction, committed before the ``record_*`` call returns, so a
record that was acknowledged survives ``kill -9`` of the process (and, with FULL, a power cut). The file carries an
``application_id`` and a schema version (``user_version``): a file of another program, a corrupt file or a
journal of an unknown version raises :class:`~masonry.errors.JournalError` naming the file.

:meth:`Journal.replay` folds the records into a :class:`JournalState`, what ``--resume`` needs: the completed
tasks with their times, the attempt counts (as :meth:`masonry.planner.Dispatcher.restore` takes them), the
UAVs declared lost and the last mission time.
"""

from __future__ import annotations

import json
import math
import sqlite3
import threading
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from pathlib import Path
from types import MappingProxyType, TracebackType
from typing import Any, Literal

from masonry.errors import JournalError
from masonry.ports import BATTERY_LOW_REASON

SCHEMA_VERSION = 1
APPLICATION_ID = 0x4D534E4A  # "MSNJ": masonry journal

RecordKind = Literal["assign", "complete", "fail", "uav_lost"]

_SCHEMA = """
CREATE TABLE records (
    seq INTEGER PRIMARY KEY AUTOINCREMENT,
    kind TEXT NOT NULL CHECK (kind IN ('assign', 'complete', 'fail', 'uav_lost')),
    time_s REAL NOT NULL,
    task_id TEXT,
    uav TEXT NOT NULL,
    attempt INTEGER,
    data TEXT NOT NULL DEFAULT '{}'
);
CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL);
"""
_TABLES = {"records", "meta"}


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
class JournalState:
    """What a journal says happened, folded for ``--resume``.

    Attributes:
        done: completed tasks in completion order (a task completed twice keeps its first completion).
        attempts: finished (completed or failed) attempts per task id: the ``attempts`` argument of
            ``Dispatcher.restore``. Attempts cut short by a lost UAV or a crash are not counted.
        failures: every failed attempt, in order.
        in_progress: task id -> UAV of attempts assigned but neither completed, failed nor released by a UAV
            loss when the journal ends (the previous run stopped while they flew; they are flown again).
        lost_uavs: UAVs declared lost, in order.
        last_time_s: the latest mission time in any record (0.0 for an empty journal): the resumed clock.
        records: every record, in write order.
        meta: the key/value pairs stored with :meth:`Journal.set_meta`.
    """

    done: tuple[DoneRecord, ...] = ()
    attempts: Mapping[str, int] = field(default_factory=dict)
    failures: tuple[FailureRecord, ...] = ()
    in_progress: Mapping[str, str] = field(default_factory=dict)
    lost_uavs: tuple[str, ...] = ()
    last_time_s: float = 0.0
    records: tuple[JournalRecord, ...] = ()
    meta: Mapping[str, Any] = field(default_factory=dict)

    @property
    def done_ids(self) -> frozenset[str]:
        """Ids of the completed tasks."""
        return frozenset(r.task_id for r in self.done)

    @property
    def empty(self) -> bool:
        """True when the journal holds no record."""
        return not self.records


def _json_default(value: Any) -> Any:
    # numpy scalars and arrays (placement errors, positions) without importing numpy here
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    raise TypeError(f"{type(value).__name__} is not JSON serialisable")


class Journal:
    """An append-only mission journal in an SQLite file; every ``record_*`` is durable when it returns.

    Construct, then open: ``Journal(path)`` only stores the path; :meth:`open` (or ``with Journal(path) as j``)
    creates the file if needed, or checks that an existing one is a masonry journal of a known version. The
    methods may be called from several threads.

    ``sync="full"`` (default) fsyncs every record: it survives a kill -9 of the process and a power cut.
    ``sync="normal"`` (SQLite's WAL + synchronous=NORMAL) still commits every record before returning, so it
    survives kill -9 of the process, but not a crash of the operating system; it avoids an fsync per record
    (useful for long simulations on a busy disk).

    Raises:
        JournalError: (on open) the file cannot be created or opened, is not an SQLite database, is a
            database of another program, or is a journal of another schema version; (on writes) a bad
            argument or a write failure. The message names the file.
    """

    def __init__(self, path: str | PathLike[str], *, sync: Literal["full", "normal"] = "full") -> None:
        if sync not in ("full", "normal"):
            raise JournalError(f"journal {path}: sync must be 'full' or 'normal', got {sync!r}")
        self.path = Path(path)
        self.sync = sync
        self._conn: sqlite3.Connection | None = None
        self._lock = threading.Lock()

    # ------------------------------------------------------------------ lifecycle

    def open(self) -> Journal:
        """Open (creating if absent) the journal file; returns ``self``."""
        if self._conn is not None:
            return self
        if self.path.is_dir():
            raise JournalError(f"journal {self.path}: is a directory")
        try:
            conn = sqlite3.connect(str(self.path), isolation_level=None, check_same_thread=False, timeout=10.0)
        except sqlite3.Error as exc:
            raise JournalError(f"journal {self.path}: cannot open: {exc}") from exc
        try:
            self._check_or_create(conn)
        except BaseException:
            conn.close()
            raise
        self._conn = conn
        return self

    def _check_or_create(self, conn: sqlite3.Connection) -> None:
        where = f"journal {self.path}"
        try:
            app_id = conn.execute("PRAGMA application_id").fetchone()[0]
            version = conn.execute("PRAGMA user_version").fetchone()[0]
            tables = {r[0] for r in conn.execute("SELECT name FROM sqlite_master WHERE type = 'table'")}
        except sqlite3.DatabaseError as exc:
            raise JournalError(f"{where}: not a masonry journal ({exc})") from exc
        tables.discard("sqlite_sequence")
        if app_id == 0 and not tables:
            try:
                conn.execute("PRAGMA journal_mode = WAL")
                conn.execute("BEGIN IMMEDIATE")
                for statement in _SCHEMA.strip().split(";"):
                    if statement.strip():
                        conn.execute(statement)
                conn.execute(f"PRAGMA application_id = {APPLICATION_ID}")
                conn.execute(f"PRAGMA user_version = {SCHEMA_VERSION}")
                conn.execute("COMMIT")
            except sqlite3.Error as exc:
                raise JournalError(f"{where}: cannot create: {exc}") from exc
        elif app_id != APPLICATION_ID:
            raise JournalError(f"{where}: not a masonry journal (an SQLite database of another program)")
        elif version != SCHEMA_VERSION:
            raise JournalError(
                f"{where}: journal schema version {version}, this masonry reads version {SCHEMA_VERSION}"
            )
        elif not _TABLES <= tables:
            raise JournalError(f"{where}: damaged journal (tables missing: {', '.join(sorted(_TABLES - tables))})")
        try:
            mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            conn.execute(f"PRAGMA synchronous = {self.sync.upper()}")
        except sqlite3.Error as exc:
            raise JournalError(f"{where}: cannot set up durability: {exc}") from exc
        if str(mode).lower() != "wal":
            raise JournalError(f"{where}: cannot switch to WAL mode (got {mode!r})")

    def close(self) -> None:
        """Close the file (idempotent)."""
        with self._lock:
            if self._conn is not None:
                try:
                    self._conn.close()
                finally:
                    self._conn = None

    def __enter__(self) -> Journal:  # noqa: PYI034 - Self needs Python 3.11
        return self.open()

    def __exit__(
        self, exc_type: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    @property
    def is_open(self) -> bool:
        return self._conn is not None

    # ------------------------------------------------------------------ writing

    def _insert(
        self,
        kind: RecordKind,
        time_s: float,
        task_id: str | None,
        uav: str,
        attempt: int | None,
        data: Mapping[str, Any],
    ) -> None:
        if isinstance(time_s, bool) or not isinstance(time_s, (int, float)) or not math.isfinite(time_s):
            raise JournalError(f"journal {self.path}: {kind} record: time_s must be a finite number, got {time_s!r}")
        if task_id is not None and (not isinstance(task_id, str) or not task_id):
            raise JournalError(f"journal {self.path}: {kind} record: bad task id {task_id!r}")
        if not isinstance(uav, str) or not uav:
            raise JournalError(f"journal {self.path}: {kind} record: bad UAV name {uav!r}")
        if attempt is not None and (isinstance(attempt, bool) or not isinstance(attempt, int) or attempt < 1):
            raise JournalError(f"journal {self.path}: {kind} record: attempt must be an integer >= 1, got {attempt!r}")
        try:
            text = json.dumps(dict(data), default=_json_default, sort_keys=True)
        except (TypeError, ValueError) as exc:
            raise JournalError(f"journal {self.path}: {kind} record of {task_id or uav}: {exc}") from exc
        with self._lock:
            if self._conn is None:
                raise JournalError(f"journal {self.path}: not open (use `with Journal(path)` or .open())")
            try:
                # autocommit: the INSERT is its own transaction, on disk (WAL, synchronous=FULL) when it returns
                self._conn.execute(
                    "INSERT INTO records (kind, time_s, task_id, uav, attempt, data) VALUES (?, ?, ?, ?, ?, ?)",
                    (kind, float(time_s), task_id, uav, attempt, text),
                )
            except sqlite3.Error as exc:
                raise JournalError(f"journal {self.path}: cannot write a {kind} record: {exc}") from exc

    def record_assignment(self, time_s: float, task_id: str, uav: str, attempt: int) -> None:
        """Task ``task_id`` was given to ``uav`` at mission time ``time_s`` as attempt ``attempt`` (from 1)."""
        self._insert("assign", time_s, task_id, uav, attempt, {})

    def record_completion(self, time_s: float, task_id: str, uav: str, **fields: Any) -> None:
        """``uav`` completed ``task_id`` at ``time_s``; ``fields`` (JSON values) are kept with the record."""
        self._insert("complete", time_s, task_id, uav, None, fields)

    def record_failure(self, time_s: float, task_id: str, uav: str, reason: str) -> None:
        """An attempt of ``task_id`` by ``uav`` failed at ``time_s`` for ``reason``."""
        self._insert("fail", time_s, task_id, uav, None, {"reason": str(reason)})

    def record_uav_lost(self, time_s: float, uav: str) -> None:
        """``uav`` was declared lost at ``time_s`` (its task, if any, was released without counting an attempt)."""
        self._insert("uav_lost", time_s, None, uav, None, {})

    def set_meta(self, key: str, value: Any) -> None:
        """Store a JSON value under ``key`` (e.g. the blueprint, policy and seed a resume must match); durable."""
        if not isinstance(key, str) or not key:
            raise JournalError(f"journal {self.path}: meta key must be a non-empty string, got {key!r}")
        try:
            text = json.dumps(value, default=_json_default, sort_keys=True)
        except (TypeError, ValueError) as exc:
            raise JournalError(f"journal {self.path}: meta {key!r}: {exc}") from exc
        with self._lock:
            if self._conn is None:
                raise JournalError(f"journal {self.path}: not open (use `with Journal(path)` or .open())")
            try:
                self._conn.execute("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)", (key, text))
            except sqlite3.Error as exc:
                raise JournalError(f"journal {self.path}: cannot write meta {key!r}: {exc}") from exc

    # ------------------------------------------------------------------ reading

    @property
    def count(self) -> int:
        """Number of records in the journal."""
        with self._lock:
            if self._conn is None:
                raise JournalError(f"journal {self.path}: not open (use `with Journal(path)` or .open())")
            try:
                return int(self._conn.execute("SELECT count(*) FROM records").fetchone()[0])
            except sqlite3.Error as exc:
                raise JournalError(f"journal {self.path}: cannot read: {exc}") from exc

    def replay(self) -> JournalState:
        """Fold every record into a :class:`JournalState` (see there)."""
        with self._lock:
            if self._conn is None:
                raise JournalError(f"journal {self.path}: not open (use `with Journal(path)` or .open())")
            try:
                rows = self._conn.execute(
                    "SELECT seq, kind, time_s, task_id, uav, attempt, data FROM records ORDER BY seq"
                ).fetchall()
                meta_rows = self._conn.execute("SELECT key, value FROM meta ORDER BY key").fetchall()
            except sqlite3.Error as exc:
                raise JournalError(f"journal {self.path}: cannot read: {exc}") from exc
        return _fold(str(self.path), rows, meta_rows)


def read_journal(path: str | PathLike[str]) -> JournalState:
    """Replay the journal at ``path`` (which must exist) without keeping it open.

    Raises:
        JournalError: the file is missing, not a masonry journal, or unreadable.
    """
    p = Path(path)
    if not p.exists():
        raise JournalError(f"journal {p}: no such file")
    with Journal(p) as journal:
        return journal.replay()


def _fold(where: str, rows: list[tuple[Any, ...]], meta_rows: list[tuple[Any, ...]]) -> JournalState:
    records: list[JournalRecord] = []
    done: dict[str, DoneRecord] = {}
    attempts: dict[str, int] = {}
    failures: list[FailureRecord] = []
    running: dict[str, tuple[str, float, int]] = {}  # task -> (uav, start_s, attempt)
    lost: list[str] = []
    last = 0.0
    for seq, kind, time_s, task_id, uav, attempt, data_text in rows:
        try:
            data = json.loads(data_text)
        except (TypeError, ValueError) as exc:
            raise JournalError(f"journal {where}: record {seq}: unreadable data ({exc})") from exc
        if not isinstance(data, dict) or not isinstance(time_s, (int, float)) or not isinstance(uav, str):
            raise JournalError(f"journal {where}: record {seq}: malformed")
        if kind != "uav_lost" and not isinstance(task_id, str):
            raise JournalError(f"journal {where}: record {seq}: {kind} record without a task id")
        rec = JournalRecord(int(seq), kind, float(time_s), task_id, uav, attempt, MappingProxyType(data))
        records.append(rec)
        last = max(last, rec.time_s)
        if kind == "assign":
            running[task_id] = (uav, rec.time_s, int(attempt) if attempt else attempts.get(task_id, 0) + 1)
        elif kind in ("complete", "fail"):
            start = running.pop(task_id, None)
            start_s = start[1] if start is not None and start[0] == uav else None
            number = start[2] if start is not None and start[0] == uav else attempts.get(task_id, 0) + 1
            if kind == "complete" or not str(data.get("reason", "")).startswith(BATTERY_LOW_REASON):
                attempts[task_id] = attempts.get(task_id, 0) + 1  # (the UAV's battery is not the task's fault)
            if kind == "complete":
                if task_id not in done:
                    done[task_id] = DoneRecord(task_id, uav, rec.time_s, start_s, number, MappingProxyType(data))
            else:
                failures.append(FailureRecord(task_id, uav, rec.time_s, start_s, number, str(data.get("reason", ""))))
        else:  # uav_lost: its running task is released, not counted
            if uav not in lost:
                lost.append(uav)
            for tid in [t for t, (u, _, _) in running.items() if u == uav]:
                del running[tid]
    meta: dict[str, Any] = {}
    for key, value in meta_rows:
        try:
            meta[key] = json.loads(value)
        except (TypeError, ValueError) as exc:
            raise JournalError(f"journal {where}: meta {key!r}: unreadable ({exc})") from exc
    return JournalState(
        done=tuple(done.values()),
        attempts=MappingProxyType(attempts),
        failures=tuple(failures),
        in_progress=MappingProxyType({t: u for t, (u, _, _) in running.items()}),
        lost_uavs=tuple(lost),
        last_time_s=last,
        records=tuple(records),
        meta=MappingProxyType(meta),
    )
