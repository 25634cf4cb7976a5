"""The mission journal: every assignment, completion, failure and UAV loss, durable on return, replayable.

The journal is an SQLite database (standard library ``sqlite3``) in WAL mode with ``synchronous=FULL`` (or
NORMAL on request); every record is its own transaction, committed before the ``record_*`` call returns, so a
record that was acknowledged survives ``kill -9`` of the process (and, with FULL, a power cut). The file carries an
``application_id`` and a schema version (``user_version``): a file of another program, a corrupt file or a
journal of an unknown version raises :class:`~masonry.errors.JournalError` naming the file.

:meth:`Journal.replay` folds the records into a :class:`JournalState`, what ``--resume`` needs: the completed
tasks with their times, the attempt counts (as :meth:`masonry.planner.Dispatcher.restore` takes them), the
UAVs declared lost and the last mission time.

:func:`open_mission_journal` is how ``masonry sim`` and ``masonry mission-control`` open a journal: a new
journal stores the fingerprint of its wall and fleet (:mod:`masonry.fingerprint`), and a resume is refused
when the blueprint's fingerprint is another one (docs/mission.md, "The journal").

Errors that come from the file the user gave (not a journal, another program's database, corrupt, read-only,
of another wall or fleet, already holding a mission) are :class:`~masonry.errors.JournalUnusable` (exit 2 in
the CLI); a failure to write during the mission (a full disk) stays a plain :class:`JournalError`.
"""

from __future__ import annotations

import json
import math
import os
import sqlite3
import threading
import warnings
from collections.abc import Callable, Collection, Mapping
from os import PathLike
from pathlib import Path
from types import TracebackType
from typing import Any, Literal

from masonry.errors import JournalError, JournalUnusable
from masonry.mission.journal_state import (
    DoneRecord,
    FailureRecord,
    JournalRecord,
    JournalState,
    RecordKind,
    RunningRecord,
    fold_records,
)

__all__ = [
    "APPLICATION_ID",
    "SCHEMA_VERSION",
    "DoneRecord",
    "FailureRecord",
    "Journal",
    "JournalRecord",
    "JournalState",
    "RecordKind",
    "RunningRecord",
    "open_mission_journal",
    "read_journal",
]

SCHEMA_VERSION = 1
APPLICATION_ID = 0x4D534E4A  # "MSNJ": masonry journal

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


def _json_default(value: Any) -> Any:
    # numpy scalars and arrays (placement errors, positions) without importing numpy here
    if hasattr(value, "tolist"):
        return value.tolist()
    if hasattr(value, "item"):
        return value.item()
    # builtin raise: json's contract for a default hook is a TypeError for what it cannot serialise
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
        where = f"journal {self.path}"
        if self.path.is_dir():
            raise JournalUnusable(f"{where}: is a directory")
        parent = self.path.parent
        if not parent.is_dir():
            raise JournalUnusable(f"{where}: cannot open: the directory {parent} does not exist")
        if self.path.exists() and not self.path.is_file():
            raise JournalUnusable(f"{where}: is not a regular file")
        # every record is written as it happens: a journal that cannot be written is refused up front (the
        # mode bits count even for root, who could write anyway: a file made read-only is meant to stay so)
        if self.path.exists() and (not os.access(self.path, os.W_OK) or not self.path.stat().st_mode & 0o222):
            raise JournalUnusable(
                f"{where}: is read-only (the mission cannot be recorded): make it writable "
                "or give another `journal` file",
                options=("journal",),
            )
        if not os.access(parent, os.W_OK | os.X_OK):
            raise JournalUnusable(
                f"{where}: the directory {parent} is read-only (SQLite writes its WAL file "
                "beside the journal): give a `journal` file in a writable directory",
                options=("journal",),
            )
        try:
            conn = sqlite3.connect(
                str(self.path), isolation_level=None, check_same_thread=False, timeout=10.0
            )
        except sqlite3.Error as exc:
            raise JournalUnusable(f"{where}: cannot open: {_reason(exc)}") from exc
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
            raise JournalUnusable(f"{where}: not a masonry journal ({_reason(exc)})") from exc
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
                raise JournalUnusable(f"{where}: cannot create: {_reason(exc)}") from exc
        elif app_id != APPLICATION_ID:
            raise JournalUnusable(f"{where}: not a masonry journal (an SQLite database of another program)")
        elif version != SCHEMA_VERSION:
            raise JournalUnusable(
                f"{where}: journal schema version {version}, this masonry reads version {SCHEMA_VERSION}"
            )
        elif not tables >= _TABLES:
            raise JournalUnusable(
                f"{where}: damaged journal (tables missing: {', '.join(sorted(_TABLES - tables))})"
            )
        try:
            mode = conn.execute("PRAGMA journal_mode = WAL").fetchone()[0]
            conn.execute(f"PRAGMA synchronous = {self.sync.upper()}")
        except sqlite3.Error as exc:
            raise JournalUnusable(f"{where}: cannot set up durability: {_reason(exc)}") from exc
        if str(mode).lower() != "wal":
            raise JournalUnusable(f"{where}: cannot switch to WAL mode (got {mode!r})")

    def close(self) -> None:
        """Close the file (idempotent)."""
        with self._lock:
            if self._conn is not None:
                try:
                    self._conn.close()
                finally:
                    self._conn = None

    def __enter__(self) -> Journal:  # not Self: that needs Python 3.11
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
            raise JournalError(
                f"journal {self.path}: {kind} record: time_s must be a finite number, got {time_s!r}"
            )
        if task_id is not None and (not isinstance(task_id, str) or not task_id):
            raise JournalError(f"journal {self.path}: {kind} record: bad task id {task_id!r}")
        if not isinstance(uav, str) or not uav:
            raise JournalError(f"journal {self.path}: {kind} record: bad UAV name {uav!r}")
        if attempt is not None and (isinstance(attempt, bool) or not isinstance(attempt, int) or attempt < 1):
            raise JournalError(
                f"journal {self.path}: {kind} record: attempt must be an integer >= 1, got {attempt!r}"
            )
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
                raise JournalError(
                    f"journal {self.path}: cannot write a {kind} record: {_reason(exc)}"
                ) from exc

    def record_assignment(self, time_s: float, task_id: str, uav: str, attempt: int, **fields: Any) -> None:
        """Task ``task_id`` was given to ``uav`` at mission time ``time_s`` as attempt ``attempt`` (from 1: the
        assignment's number, one more for each assignment of the task)."""
        self._insert("assign", time_s, task_id, uav, attempt, fields)

    def record_completion(
        self, time_s: float, task_id: str, uav: str, *, attempt: int | None = None, **fields: Any
    ) -> None:
        """``uav`` completed ``task_id`` at ``time_s`` (its attempt ``attempt``; None: not named, the running one);
        ``fields`` (JSON values) are kept with the record."""
        self._insert("complete", time_s, task_id, uav, attempt, fields)

    def record_failure(
        self, time_s: float, task_id: str, uav: str, reason: str, *, attempt: int | None = None, **fields: Any
    ) -> None:
        """An attempt of ``task_id`` by ``uav`` (``attempt``; None: not named, the running one) failed at
        ``time_s`` for ``reason``."""
        self._insert("fail", time_s, task_id, uav, attempt, {**fields, "reason": str(reason)})

    def record_uav_lost(self, time_s: float, uav: str, **fields: Any) -> None:
        """``uav`` was declared lost at ``time_s`` (its task, if any, was released without counting an attempt)."""
        self._insert("uav_lost", time_s, None, uav, None, fields)

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
                raise JournalUnusable(f"journal {self.path}: cannot read: {_reason(exc)}") from exc
        return fold_records(str(self.path), rows, meta_rows)


def read_journal(path: str | PathLike[str]) -> JournalState:
    """Replay the journal at ``path`` (which must exist) without keeping it open.

    Raises:
        JournalError: the file is missing, not a masonry journal, or unreadable.
    """
    p = Path(path)
    if not p.exists():
        raise JournalUnusable(f"journal {p}: no such file")
    if p.is_file() and not p.stat().st_mode & 0o222:
        return _read_only_replay(p)  # an archived, read-only journal can still be read
    with Journal(p) as journal:
        return journal.replay()


def _read_only_replay(p: Path) -> JournalState:
    where = f"journal {p}"
    try:
        conn = sqlite3.connect(f"{p.resolve().as_uri()}?mode=ro", uri=True)
    except sqlite3.Error as exc:
        raise JournalUnusable(f"{where}: cannot open: {_reason(exc)}") from exc
    try:
        app_id = conn.execute("PRAGMA application_id").fetchone()[0]
        version = conn.execute("PRAGMA user_version").fetchone()[0]
        if app_id != APPLICATION_ID or version != SCHEMA_VERSION:
            raise JournalUnusable(f"{where}: not a masonry journal of schema version {SCHEMA_VERSION}")
        rows = conn.execute(
            "SELECT seq, kind, time_s, task_id, uav, attempt, data FROM records ORDER BY seq"
        ).fetchall()
        meta_rows = conn.execute("SELECT key, value FROM meta ORDER BY key").fetchall()
    except sqlite3.Error as exc:
        raise JournalUnusable(f"{where}: cannot read: {_reason(exc)}") from exc
    finally:
        conn.close()
    return fold_records(str(p), rows, meta_rows)


def _reason(exc: BaseException) -> str:
    """SQLite's message, with a read-only location said in plain words."""
    text = str(exc)
    if "readonly" in text.replace(" ", "").lower():
        return f"the journal is read-only ({text})"
    return text


def open_mission_journal(
    path: str | PathLike[str],
    *,
    resume: bool,
    wall_digest: str,
    fleet_digest: str,
    fleet_names: Collection[str] = (),
    task_ids: Collection[str] | None = None,
    sync: Literal["full", "normal"] = "full",
    warn: Callable[[str], None] | None = None,
    reservation: str | None = None,
) -> tuple[Journal, JournalState | None]:
    """Open the journal of a mission: a new one, or (``resume``) the one of this very wall and fleet.

    A new (or empty) journal gets the fingerprint ``wall_digest`` / ``fleet_digest``
    (:func:`masonry.fingerprint.wall_digest`, :func:`~masonry.fingerprint.fleet_digest`) in its meta table. On
    ``resume`` the journal's fingerprint must be the blueprint's. A journal written before fingerprints existed
    (no ``wall_digest``) is resumed with a warning (``warn``, default :func:`warnings.warn`) if every task and
    UAV it names is in this mission, and then gets this mission's fingerprint (docs/mission.md says why).

    Args:
        path: the journal file (created if absent).
        resume: continue the mission the journal holds (it must exist); without it, the journal must hold none.
        wall_digest, fleet_digest: the fingerprint of this mission's blueprint and fleet.
        fleet_names: the fleet's UAV names (stored, and quoted when the fleet differs).
        task_ids: the plan's task ids: a journal naming another task is refused (None: not checked).
        sync: see :class:`Journal`.
        warn: where the warning about a journal without a fingerprint goes.
        reservation: the mission's ``site`` / ``task`` reservation (stored; a resume with another one is refused,
            since the journal's site intervals and running tasks follow its rule). None: not checked.

    Returns:
        The open journal (the caller closes it) and its replayed state (None for a new mission).

    Raises:
        JournalUnusable: no journal to resume, one that already holds a mission, one of another wall or fleet,
            or any reason :meth:`Journal.open` refuses the file. The message names the file.
    """
    p = Path(path)
    where = f"journal {p}"
    existed = p.is_file() and p.stat().st_size > 0
    if resume and not existed:
        raise JournalUnusable(f"{where}: no journal to resume from")
    journal = Journal(p, sync=sync).open()
    try:
        state = journal.replay() if existed else None
        if state is not None and not resume:
            if not state.empty:
                raise JournalUnusable(
                    f"{where} already holds a mission: pass `resume` to continue it, "
                    "or give another `journal` file",
                    options=("resume", "journal"),
                )
            state = None
        if state is not None:
            _check_fingerprint(where, state, wall_digest, fleet_digest, fleet_names, task_ids, warn)
            _check_reservation(where, state, reservation)
        journal.set_meta("wall_digest", wall_digest)
        journal.set_meta("fleet_digest", fleet_digest)
        journal.set_meta("fleet", list(fleet_names))
        if reservation is not None:
            journal.set_meta("reservation", reservation)
    except BaseException:
        journal.close()
        raise
    return journal, state


def _check_reservation(where: str, state: JournalState, reservation: str | None) -> None:
    stored = state.meta.get("reservation")
    if reservation is not None and stored is not None and stored != reservation:
        raise JournalUnusable(
            f"{where} was written with the {stored} reservation, not {reservation}: resume it with "
            f"`reservation` {stored}",
            options=("reservation",),
        )


def _check_fingerprint(
    where: str,
    state: JournalState,
    wall_digest: str,
    fleet_digest: str,
    fleet_names: Collection[str],
    task_ids: Collection[str] | None,
    warn: Callable[[str], None] | None,
) -> None:
    stored_wall = state.meta.get("wall_digest")
    stored_fleet = state.meta.get("fleet_digest")
    if stored_wall is not None and stored_wall != wall_digest:
        raise JournalUnusable(
            f"{where} was written for another wall (wall digest {stored_wall}, this blueprint's is "
            f"{wall_digest}): resume it with the blueprint it was written for, or give another `journal` file",
            options=("journal",),
        )
    elif stored_fleet is not None and stored_fleet != fleet_digest:
        before = state.meta.get("fleet")
        then = f"{', '.join(map(str, before))}, " if isinstance(before, list) and before else ""
        now = f"{', '.join(fleet_names)}, " if fleet_names else ""
        raise JournalUnusable(
            f"{where} was written for another fleet ({then}digest {stored_fleet}; this one: {now}digest "
            f"{fleet_digest}): resume with the same fleet (names, roles, homes; in sim the same `brick_uavs` "
            "and `adhesion_uavs`)",
            options=("brick_uavs", "adhesion_uavs"),
        )
    if task_ids is not None:
        unknown = sorted(state.task_ids - set(task_ids))
        if unknown:
            shown = ", ".join(unknown[:5]) + (f" and {len(unknown) - 5} more" if len(unknown) > 5 else "")
            raise JournalUnusable(f"{where} names tasks that are not in this blueprint's plan: {shown}")
    if fleet_names:
        strangers = sorted(state.uav_names - set(fleet_names))
        if strangers:
            raise JournalUnusable(
                f"{where} names UAVs that are not in this mission's fleet: {', '.join(strangers[:5])}"
            )
    if stored_wall is None and not state.empty:
        # written before journals had a fingerprint: its tasks and UAVs are this mission's (checked above), but
        # a brick moved or a clearance changed cannot be seen; say so and resume (docs/mission.md says why)
        message = (
            f"{where} has no fingerprint of its wall and fleet (written by an earlier masonry): resuming "
            "it checked only by task ids and UAV names; it records this blueprint's fingerprint from now on"
        )
        if warn is not None:
            warn(message)
        else:
            warnings.warn(message, UserWarning, stacklevel=3)
