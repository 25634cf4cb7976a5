"""Journal resume after kill -9 of mission control in the middle of a mission.

A child process runs the paper's case study with a journal (``simulate``: mission control, UAVs and world
in one process) and is killed with SIGKILL right after its second task completes. The mission is then
resumed from the journal: no completed task is repeated, none is lost, the clock continues, and the report
covers the whole mission with the times of the tasks done before the crash.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
from collections import Counter
from pathlib import Path

import pytest

from masonry.blueprint import load_blueprint
from masonry.mission.journal import read_journal
from masonry.mission.simulate import simulate

CASE_STUDY = Path(__file__).resolve().parents[1] / "blueprints" / "paper_case_study.yaml"

CHILD = textwrap.dedent(
    """
    import sys, time
    from masonry.blueprint import load_blueprint
    from masonry.mission.simulate import simulate

    def progress(done, total, now_s):
        print(f"done {done} {now_s:.2f}", flush=True)
        if done >= int(sys.argv[3]):
            time.sleep(60)  # hold still mid-mission: the parent kills us here

    simulate(load_blueprint(sys.argv[1]), journal_path=sys.argv[2], progress=progress, reservation="task")
    """
)


def run_and_kill(journal: Path, after: int) -> None:
    proc = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(CASE_STUDY), str(journal), str(after)],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        seen = 0
        assert proc.stdout is not None
        # a line, or the child's end (its mission is simulated and bounded): no wall-clock deadline, which a
        # loaded machine spent on the child's imports alone
        while seen < after:
            line = proc.stdout.readline()
            assert line, f"child ended before {after} completions"
            if line.startswith("done "):
                seen = int(line.split()[1])
        # the child blocks in its progress callback right after `after` completions, then is killed -9
        # before it can end the mission
        os.kill(proc.pid, signal.SIGKILL)
        assert proc.wait(timeout=10) == -signal.SIGKILL
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def test_resume_after_kill_9_repeats_nothing_and_loses_nothing(tmp_path):
    journal = tmp_path / "mission.db"
    run_and_kill(journal, after=1)
    before = read_journal(journal)
    assert [r.task_id for r in before.done] == ["A0"]
    crash_s = before.last_time_s
    assert crash_s > 0

    report = simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True, reservation="task")
    assert report.completed
    assert report.resumed_from_s == pytest.approx(crash_s)
    after = read_journal(journal)
    completions = Counter(r.task_id for r in after.records if r.kind == "complete")
    assert completions == Counter({"A0": 1, "B0": 1, "A1": 1, "B1": 1}), "a task was repeated or lost"

    by_id = {t.id: t for t in report.tasks}
    a0 = before.done[0]
    # the task done before the crash keeps its UAV and times; the clock continues from the journal
    assert (by_id["A0"].uav, by_id["A0"].start_s, by_id["A0"].end_s) == (
        a0.uav,
        pytest.approx(a0.start_s, abs=0.01),
        pytest.approx(a0.end_s, abs=0.01),
    )
    for tid in ("B0", "A1", "B1"):
        assert by_id[tid].start_s >= crash_s - 1e-9
    assert report.makespan_s == max(t.end_s for t in report.tasks) > crash_s
    # the case study's order survives the crash
    assert [t.id for t in sorted(report.tasks, key=lambda t: t.start_s)] == ["A0", "B0", "A1", "B1"]
    assert report.conflict_violations == 0 and report.dependency_violations == 0


def test_resume_with_a_placed_brick_keeps_it_in_place(tmp_path):
    journal = tmp_path / "mission.db"
    run_and_kill(journal, after=2)
    before = read_journal(journal)
    assert [r.task_id for r in before.done] == ["A0", "B0"]
    # the world's true placement error, journaled with the completion (not the UAV's release-point estimate)
    journaled_error = before.done[1].fields["measured"]["placement_error_m"]
    report = simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True, reservation="task")
    assert report.completed
    assert report.placement_error_m["B0"] == pytest.approx(journaled_error)
    done = Counter(r.task_id for r in read_journal(journal).records if r.kind == "complete")
    assert set(done.values()) == {1} and set(done) == {"A0", "B0", "A1", "B1"}
    # busy time covers the whole mission: brick-1 flew B0 before the crash and B1 after
    brick = {u.name: u for u in report.uavs}["brick-1"]
    b = {t.id: t for t in report.tasks}
    assert brick.busy_s >= (b["B0"].end_s - b["B0"].start_s) + (b["B1"].end_s - b["B1"].start_s) - 0.5
