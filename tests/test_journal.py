"""Mission journal: records, replay for --resume, durability under kill -9, and bad files."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from masonry.blueprint import UavSpec
from masonry.errors import JournalError
from masonry.mission.journal import DoneRecord, Journal, JournalState, RunningRecord, read_journal
from masonry.planner.dispatch import Dispatcher
from masonry.planner.tasks import AdhesionTask, BrickTask, Plan


def case_study_plan() -> Plan:
    tasks = (
        BrickTask("B0", 0, False, (0.3, 0.0, 0.05), 0.0, (-2.0, 0.0, 0.05)),
        BrickTask("B1", 1, False, (1.0, 0.0, 0.05), 0.0, (-2.0, 0.0, 0.05)),
        AdhesionTask("A0", 0, 1, (0.2, 0.0, 0.1), (0.4, 0.0, 0.1), 0.2),
        AdhesionTask("A1", 1, 2, (0.9, 0.0, 0.1), (1.1, 0.0, 0.1), 0.2),
    )
    return Plan(tasks, (("B0", "A0"), ("B1", "A1")), (("B0", "A1"),))


FLEET = [UavSpec("brick-1", "brick", (-3.0, 0.0, 0.0)), UavSpec("glue-1", "adhesion", (-3.0, 1.0, 0.0))]


def test_empty_journal_replays_to_an_empty_state(tmp_path: Path) -> None:
    with Journal(tmp_path / "j.sqlite") as j:
        state = j.replay()
        assert j.count == 0
    assert state == JournalState()
    assert state.empty and state.last_time_s == 0.0 and state.done_ids == frozenset()


def test_replay_folds_assignments_completions_failures_and_losses(tmp_path: Path) -> None:
    path = tmp_path / "mission.sqlite"
    with Journal(path) as j:
        j.set_meta("blueprint", {"name": "case", "bricks": 2})
        j.record_assignment(0.0, "A0", "glue-1", 1)
        j.record_completion(40.5, "A0", "glue-1", coverage=0.97)
        j.record_assignment(40.5, "B0", "brick-1", 1)
        j.record_failure(60.0, "B0", "brick-1", "grasp failed")
        j.record_assignment(61.0, "B0", "brick-1", 2)
        j.record_completion(90.25, "B0", "brick-1", placement_error_m=0.012)
        j.record_assignment(90.25, "A1", "glue-1", 1)
        j.record_assignment(91.0, "B1", "brick-2", 1)
        j.record_uav_lost(95.0, "brick-2")
        assert j.count == 9
    state = read_journal(path)
    assert [r.task_id for r in state.done] == ["A0", "B0"]
    assert state.done[0] == DoneRecord("A0", "glue-1", 40.5, 0.0, 1, {"coverage": 0.97})
    b0 = state.done[1]
    assert (b0.start_s, b0.end_s, b0.attempt, b0.uav) == (61.0, 90.25, 2, "brick-1")
    assert b0.fields["placement_error_m"] == pytest.approx(0.012)
    assert dict(state.attempts) == {"A0": 1, "B0": 2}
    # B1's UAV was lost: B1 is released, a failure with the loss's reason, not counted in attempts
    assert [(f.task_id, f.attempt, f.start_s, f.time_s, f.reason) for f in state.failures] == [
        ("B0", 1, 40.5, 60.0, "grasp failed"),
        ("B1", 1, 91.0, 95.0, "uav lost"),
    ]
    # A1 was flying when the journal ends: in progress, with its start and attempt number
    assert dict(state.in_progress) == {"A1": "glue-1"}
    assert state.running == (RunningRecord("A1", "glue-1", 90.25, 1),)
    assert state.lost_uavs == ("brick-2",)
    assert state.last_time_s == 95.0
    assert [r.kind for r in state.records] == [
        "assign",
        "complete",
        "assign",
        "fail",
        "assign",
        "complete",
        "assign",
        "assign",
        "uav_lost",
    ]
    assert state.meta == {"blueprint": {"name": "case", "bricks": 2}}


def test_a_failure_for_the_uavs_battery_is_not_replayed_as_an_attempt(tmp_path: Path) -> None:
    path = tmp_path / "mission.sqlite"
    with Journal(path) as j:
        j.record_assignment(0.0, "B0", "brick-1", 1)
        j.record_failure(30.0, "B0", "brick-1", "battery low (19%)")
        j.record_assignment(95.0, "B0", "brick-1", 1)
        j.record_failure(99.0, "B0", "brick-1", "grasp failed")
    state = read_journal(path)
    assert dict(state.attempts) == {"B0": 1}  # the grasp failure only, as mission control counted
    assert [f.reason for f in state.failures] == ["battery low (19%)", "grasp failed"]


def test_reopening_appends_to_the_same_journal(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite"
    with Journal(path) as j:
        j.record_assignment(1.0, "A0", "glue-1", 1)
    with Journal(path) as j:
        j.record_completion(2.0, "A0", "glue-1")
        assert j.count == 2
    assert read_journal(path).done_ids == {"A0"}


def test_numpy_values_in_completion_fields_are_stored(tmp_path: Path) -> None:
    import numpy as np

    with Journal(tmp_path / "j.sqlite") as j:
        j.record_completion(1.0, "B0", "brick-1", placement_error_m=np.float32(0.5), xyz=np.array([1.0, 2.0]))
        (rec,) = j.replay().done
    assert rec.fields == {"placement_error_m": 0.5, "xyz": [1.0, 2.0]}


def test_resume_restores_the_dispatcher_without_repeating_or_losing_tasks(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite"
    plan = case_study_plan()
    # First run: A0 done, B0 failed once then in flight when the process "dies".
    with Journal(path) as j:
        d = Dispatcher(plan, FLEET, "fifo")
        t = 0.0
        for a in d.assign():
            j.record_assignment(t, a.task_id, a.uav, a.attempt)
        d.complete("A0")
        j.record_completion(10.0, "A0", "glue-1")
        (a,) = d.assign()
        j.record_assignment(10.0, a.task_id, a.uav, a.attempt)
        d.fail("B0")
        j.record_failure(20.0, "B0", "brick-1", "dropped")
        (a,) = d.assign()
        assert a.attempt == 2
        j.record_assignment(21.0, a.task_id, a.uav, a.attempt)
    # Resume.
    state = read_journal(path)
    d2 = Dispatcher(plan, FLEET, "fifo")
    d2.restore(state.done_ids, state.attempts)
    assert set(d2.done) == {"A0"}
    got = {a.task_id: a.attempt for a in d2.assign()}
    assert got == {"B0": 2}  # B0 flies again as its 2nd attempt; A0 is not repeated
    assert state.last_time_s == 21.0


@pytest.mark.parametrize("sync", ["full", "normal"])
def test_durable_after_kill_9_mid_write_loop(tmp_path: Path, sync: str) -> None:
    """Every record the child acknowledged (printed after its commit returned) is in the journal after kill -9."""
    path = tmp_path / "killed.sqlite"
    child = textwrap.dedent(
        f"""
        import sys
        from masonry.mission.journal import Journal
        j = Journal({str(path)!r}, sync={sync!r}).open()
        i = 0
        while True:
            j.record_assignment(float(i), "B%d" % i, "brick-1", 1)
            j.record_completion(float(i) + 0.5, "B%d" % i, "brick-1", placement_error_m=0.001 * i)
            print(i, flush=True)
            i += 1
        """
    )
    proc = subprocess.Popen([sys.executable, "-c", child], stdout=subprocess.PIPE, text=True)
    acknowledged = -1
    try:
        assert proc.stdout is not None
        for line in proc.stdout:
            acknowledged = int(line)
            if acknowledged >= 60:
                break
        os.kill(proc.pid, signal.SIGKILL)
    finally:
        proc.kill()
        proc.wait(timeout=10)
    assert proc.returncode == -signal.SIGKILL
    assert acknowledged >= 60
    state = read_journal(path)  # the WAL left behind by the killed writer is recovered on open
    done = [r.task_id for r in state.done]
    # every acknowledged pair is there, in order, and nothing but a prefix of the loop
    assert done[: acknowledged + 1] == [f"B{i}" for i in range(acknowledged + 1)]
    assert done == [f"B{i}" for i in range(len(done))]
    assert state.done[acknowledged].fields["placement_error_m"] == pytest.approx(0.001 * acknowledged)


def test_a_file_that_is_not_sqlite_raises_journal_error_naming_it(tmp_path: Path) -> None:
    path = tmp_path / "notes.txt"
    path.write_text("this is not a database, just some text that is long enough " * 20)
    with pytest.raises(JournalError, match=r"notes\.txt: not a masonry journal"):
        Journal(path).open()


def test_a_foreign_sqlite_database_raises_journal_error(tmp_path: Path) -> None:
    path = tmp_path / "other.db"
    conn = sqlite3.connect(path)
    conn.execute("CREATE TABLE customers (id INTEGER)")
    conn.commit()
    conn.close()
    with pytest.raises(
        JournalError, match=r"other\.db: not a masonry journal \(an SQLite database of another"
    ):
        read_journal(path)


def test_a_journal_of_another_schema_version_raises(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite"
    with Journal(path):
        pass
    conn = sqlite3.connect(path)
    conn.execute("PRAGMA user_version = 99")
    conn.commit()
    conn.close()
    with pytest.raises(JournalError, match="schema version 99, this masonry reads version 1"):
        Journal(path).open()


def test_a_corrupted_journal_raises_journal_error(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite"
    with Journal(path) as j:
        for i in range(200):
            j.record_completion(float(i), f"B{i}", "brick-1", note="x" * 200)
    data = bytearray(path.read_bytes())
    data[0:16] = b"garbage garbage!"  # destroy the SQLite header
    path.write_bytes(bytes(data))
    with pytest.raises(JournalError, match=r"j\.sqlite"):
        read_journal(path)


def test_missing_file_directory_and_closed_journal(tmp_path: Path) -> None:
    with pytest.raises(JournalError, match="no such file"):
        read_journal(tmp_path / "absent.sqlite")
    with pytest.raises(JournalError, match="is a directory"):
        Journal(tmp_path).open()
    with pytest.raises(JournalError, match="cannot open"):
        Journal(tmp_path / "no" / "such" / "dir" / "j.sqlite").open()
    j = Journal(tmp_path / "j.sqlite")
    with pytest.raises(JournalError, match="not open"):
        j.record_uav_lost(1.0, "brick-1")
    with pytest.raises(JournalError, match="sync must be 'full' or 'normal'"):
        Journal(tmp_path / "j.sqlite", sync="off")  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda j: j.record_assignment(float("nan"), "B0", "brick-1", 1), "finite"),
        (lambda j: j.record_assignment(1.0, "B0", "brick-1", 0), "attempt must be an integer >= 1"),
        (lambda j: j.record_assignment(1.0, "", "brick-1", 1), "bad task id"),
        (lambda j: j.record_failure(1.0, "B0", "", "x"), "bad UAV name"),
        (
            lambda j: j.record_completion(1.0, "B0", "brick-1", blob=object()),
            "object is not JSON serialisable",
        ),
    ],
)
def test_bad_records_raise_journal_error(tmp_path: Path, call, message: str) -> None:  # type: ignore[no-untyped-def]
    with Journal(tmp_path / "j.sqlite") as j:
        with pytest.raises(JournalError, match=message):
            call(j)
        assert j.count == 0


def test_journal_is_in_wal_mode_with_a_versioned_schema(tmp_path: Path) -> None:
    path = tmp_path / "j.sqlite"
    with Journal(path):
        pass
    conn = sqlite3.connect(path)
    try:
        assert conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
        assert conn.execute("PRAGMA user_version").fetchone()[0] == 1
        assert conn.execute("PRAGMA application_id").fetchone()[0] == 0x4D534E4A
    finally:
        conn.close()
