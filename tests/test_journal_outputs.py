"""Journals that know their wall, output files checked first and written atomically,
resumed reports equal to the run that wrote the journal, and journal errors of the user's making exit 2.
"""

from __future__ import annotations

import json
import os
import socket
import sqlite3
from pathlib import Path

import pytest
from typer.testing import CliRunner

from masonry.blueprint import load_blueprint
from masonry.cli import app
from masonry.errors import InputError, JournalUnusable
from masonry.fingerprint import fleet_digest, wall_digest
from masonry.mission.journal import Journal, read_journal
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
runner = CliRunner()


def sim(blueprint: Path, *args: str):
    return runner.invoke(app, ["sim", str(blueprint), *args])


def one_line_error(res, code: int = 2) -> str:
    """The single error line of a failed command (no traceback, nothing else on stderr)."""
    assert res.exit_code == code, (res.exit_code, res.output, res.exception)
    assert not isinstance(res.exception, Exception) or isinstance(res.exception, SystemExit), res.exception
    lines = [line for line in res.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error: "), res.stderr
    assert "Traceback" not in res.output
    return lines[0]


def moved_case_study(tmp_path: Path) -> Path:
    """The case study with the same task ids and one brick moved 5 cm: another wall."""
    text = CASE_STUDY.read_text().replace(
        "{id: 1, position: [0.0, 0.5, 0.25]", "{id: 1, position: [0.05, 0.5, 0.25]"
    )
    assert text != CASE_STUDY.read_text()
    p = tmp_path / "moved.yaml"
    p.write_text(text)
    return p


def renumbered_case_study(tmp_path: Path) -> Path:
    """The case study with its two bricks renumbered 10 and 11: brick tasks B10, B11, not the journal's B0, B1."""
    text = (
        CASE_STUDY.read_text()
        .replace("{id: 0, position", "{id: 10, position")
        .replace("{id: 1, position", "{id: 11, position")
    )
    p = tmp_path / "renumbered.yaml"
    p.write_text(text)
    assert {t.id for t in make_plan(load_blueprint(p)).tasks if not t.done} == {"A0", "B10", "A1", "B11"}
    return p


@pytest.fixture(scope="module")
def case_journal(tmp_path_factory) -> tuple[Path, dict]:
    """A finished case-study mission's journal and its report (written once for the module)."""
    d = tmp_path_factory.mktemp("case")
    journal = d / "case.db"
    report = simulate(load_blueprint(CASE_STUDY), journal_path=journal).to_dict()
    return journal, report


def copy_journal(src: Path, dst: Path) -> Path:
    with sqlite3.connect(src) as a, sqlite3.connect(dst) as b:
        a.backup(b)
    return dst


# ---------------------------------------------------------------- the journal's fingerprint


def test_journal_stores_the_fingerprint_of_wall_and_fleet(case_journal):
    journal, _ = case_journal
    meta = read_journal(journal).meta
    bp = load_blueprint(CASE_STUDY)
    assert meta["wall_digest"] == wall_digest(bp) and meta["fleet_digest"] == fleet_digest(bp)
    assert meta["fleet"] == ["brick-1", "glue-1"]


def test_resume_with_another_wall_of_other_task_ids_is_one_line_exit_2(case_journal, tmp_path):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    res = sim(
        renumbered_case_study(tmp_path), "--journal", str(journal), "--resume"
    )  # was: KeyError traceback
    line = one_line_error(res)
    assert str(journal) in line and "written for another wall" in line


def test_resume_with_another_wall_of_the_same_task_ids_is_refused(case_journal, tmp_path):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    res = sim(
        moved_case_study(tmp_path), "--journal", str(journal), "--resume"
    )  # was: exit 0, other wall's tasks done
    line = one_line_error(res)
    assert "written for another wall" in line and wall_digest(load_blueprint(CASE_STUDY)) in line
    assert len(read_journal(journal).records) == len(read_journal(case_journal[0]).records), (
        "the refused resume wrote to the journal"
    )


def test_resume_with_another_fleet_is_refused(case_journal, tmp_path):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    line = one_line_error(sim(CASE_STUDY, "--journal", str(journal), "--resume", "--brick-uavs", "2"))
    assert "written for another fleet" in line and "brick-1, glue-1" in line and "brick-2" in line


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return int(s.getsockname()[1])


@pytest.mark.parametrize("other", ["renumbered", "moved"])
def test_mission_control_refuses_a_journal_of_another_wall(case_journal, tmp_path, other):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    blueprint = renumbered_case_study(tmp_path) if other == "renumbered" else moved_case_study(tmp_path)
    res = runner.invoke(
        app,
        [
            "mission-control",
            str(blueprint),
            "--journal",
            str(journal),
            "--resume",
            "--listen",
            f"tcp/127.0.0.1:{_free_port()}",
            "--startup-timeout",
            "0.5",
            "--max-time",
            "0.5",
        ],
    )
    line = one_line_error(res)
    assert "written for another wall" in line


def legacy_journal(case_journal, dst: Path) -> Path:
    """The journal as the previous masonry wrote it: the same records, no fingerprint, no measurements."""
    copy_journal(case_journal[0], dst)
    with sqlite3.connect(dst) as db:
        db.execute("DELETE FROM meta")
        rows = db.execute("SELECT seq, data FROM records").fetchall()
        for seq, data in rows:
            d = json.loads(data)
            d.pop("measured", None)
            db.execute("UPDATE records SET data = ? WHERE seq = ?", (json.dumps(d), seq))
    return dst


def test_a_journal_without_fingerprint_resumes_with_a_warning_and_adopts_the_fingerprint(
    case_journal, tmp_path
):
    journal = legacy_journal(case_journal, tmp_path / "old.db")
    res = sim(CASE_STUDY, "--journal", str(journal), "--resume", "--format", "json")
    assert res.exit_code == 0, res.output
    warnings = [line for line in res.stderr.splitlines() if line.startswith("warning: ")]
    assert len(warnings) == 1 and "no fingerprint" in warnings[0] and str(journal) in warnings[0]
    assert read_journal(journal).meta["wall_digest"] == wall_digest(load_blueprint(CASE_STUDY))
    # from now on it is checked
    assert "written for another wall" in one_line_error(
        sim(moved_case_study(tmp_path), "--journal", str(journal), "--resume")
    )


def test_a_journal_without_fingerprint_naming_other_tasks_is_one_line_exit_2(case_journal, tmp_path):
    journal = legacy_journal(case_journal, tmp_path / "old.db")
    other = renumbered_case_study(tmp_path)
    line = one_line_error(sim(other, "--journal", str(journal), "--resume"))  # was: a KeyError traceback
    assert "names tasks that are not in this blueprint's plan" in line and "B0" in line


def test_simulate_refuses_a_journal_of_another_wall(case_journal, tmp_path):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    with pytest.raises(JournalUnusable, match="written for another wall"):
        simulate(load_blueprint(moved_case_study(tmp_path)), journal_path=journal, resume=True)
    with pytest.raises(JournalUnusable, match="written for another fleet"):
        simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True, adhesion_uavs=2)


# ---------------------------------------------------------------- a resumed report equals the original


def test_resuming_a_finished_mission_reports_exactly_what_its_run_reported(case_journal, tmp_path):
    journal = copy_journal(case_journal[0], tmp_path / "j.db")
    again = simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True).to_dict()
    # was: busy times from mission control's times, distances flown 0 (the rebuilt world flew nothing)
    assert again == case_journal[1]


class _Stop(Exception):
    pass


@pytest.mark.parametrize("after", [2, 3, "60 s"])
def test_report_of_an_interrupted_and_resumed_mission_keeps_what_was_done_before(
    case_journal, tmp_path, after
):
    full = case_journal[1]
    journal = tmp_path / "j.db"

    def stop_after(done: int, total: int, now_s: float) -> None:
        if done >= after:
            raise _Stop  # the process dies here: the journal holds `after` completions

    if after == "60 s":  # the run stops at 60 s of mission time (max_time_s), B1 unfinished
        stopped = simulate(load_blueprint(CASE_STUDY), journal_path=journal, max_time_s=60.0)
        assert not stopped.completed
    else:
        with pytest.raises(_Stop):
            simulate(load_blueprint(CASE_STUDY), journal_path=journal, progress=stop_after)
    before = read_journal(journal)
    finished = [r.task_id for r in before.done]
    # the default (site) reservation: A0, A1, B0 complete by 60 s (the paper's rule: A0, B0)
    assert len(finished) == (3 if after == "60 s" else after) and "B1" not in finished
    resumed = simulate(load_blueprint(CASE_STUDY), journal_path=journal, resume=True).to_dict()
    assert resumed["completed"]
    full_tasks = {t["id"]: t for t in full["tasks"]}
    resumed_tasks = {t["id"]: t for t in resumed["tasks"]}
    for tid in finished:
        # a site interval the crash cut (its UAV was still over the site) ends at the crash: when the UAV would
        # have left is not in the journal; everything else is what the uninterrupted run said
        got = dict(resumed_tasks[tid])
        if got["site_end_s"] != full_tasks[tid]["site_end_s"]:
            assert got["site_end_s"] == pytest.approx(before.last_time_s, abs=0.01)
            got["site_end_s"] = full_tasks[tid]["site_end_s"]
        assert got == full_tasks[tid]
        if tid in full["placement_error_m"]:
            # was: the UAV's release-point estimate instead of the world's true error
            assert resumed["placement_error_m"][tid] == full["placement_error_m"][tid]
    # the UAVs' busy time and distance cover the flying done before the crash (was: only after the resume)
    done_before = dict(before.measured["distances_m"].items())
    for u in resumed["uavs"]:
        assert u["distance_m"] >= round(done_before[u["name"]], 2) > 0
        assert u["busy_s"] >= round(before.measured["busy_s"][u["name"]], 2) > 0


# ---------------------------------------------------------------- journal errors are the user's input: exit 2


def test_journal_input_errors_exit_2_with_one_line(case_journal, tmp_path):
    corrupt = tmp_path / "corrupt.db"
    corrupt.write_bytes(b"not an sqlite file\n" * 200)
    other = tmp_path / "other.db"
    with sqlite3.connect(other) as db:
        db.execute("CREATE TABLE photos (id INTEGER)")
    read_only = copy_journal(case_journal[0], tmp_path / "ro.db")
    read_only.chmod(0o444)
    full = copy_journal(case_journal[0], tmp_path / "full.db")
    cases = [
        (["--journal", str(corrupt)], "not a masonry journal"),
        (["--journal", str(other)], "another program"),
        (["--journal", str(read_only), "--resume"], "read-only"),
        (["--journal", str(full)], "already holds a mission"),
        (["--journal", str(tmp_path / "absent.db"), "--resume"], "no journal to resume from"),
        (["--journal", str(tmp_path / "no" / "dir" / "j.db")], "does not exist"),
    ]
    for args, message in cases:
        line = one_line_error(sim(CASE_STUDY, *args))  # was: exit 1
        assert message in line and args[1] in line


def test_read_only_journal_says_so_in_the_library_too(case_journal, tmp_path):
    read_only = copy_journal(case_journal[0], tmp_path / "ro.db")
    read_only.chmod(0o444)
    with pytest.raises(JournalUnusable, match="is read-only"):
        Journal(read_only).open()
    # reading it (to look at a finished mission) still works
    assert [r.task_id for r in read_journal(read_only).done] == [
        r.task_id for r in read_journal(case_journal[0]).done
    ]


# ---------------------------------------------------------------- output paths: checked first, written atomically


@pytest.mark.parametrize("flag, name", [("--report", "r.json"), ("--gantt", "g.png"), ("--plot3d", "p.png")])
def test_sim_checks_its_outputs_before_simulating(tmp_path, flag, name):
    journal = tmp_path / "j.db"
    bad = tmp_path / "missing-dir" / name
    res = sim(CASE_STUDY, "--journal", str(journal), flag, str(bad))  # was: a traceback after the simulation
    line = one_line_error(res)
    assert flag in line and str(bad) in line and "does not exist" in line
    assert not journal.exists(), "the mission ran although its output could not be written"
    directory = tmp_path / "a-dir.png"
    directory.mkdir()
    assert "is a directory" in one_line_error(sim(CASE_STUDY, flag, str(directory)))


def test_sim_refuses_a_read_only_report_before_simulating(tmp_path):
    report = tmp_path / "r.json"
    report.write_text("old\n")
    report.chmod(0o444)
    line = one_line_error(sim(CASE_STUDY, "--report", str(report), "--journal", str(tmp_path / "j.db")))
    assert "--report" in line and "read-only" in line and not (tmp_path / "j.db").exists()


@pytest.mark.parametrize(
    "argv, flag",
    [
        (["plan", str(CASE_STUDY), "-o", "{bad}/plan.txt"], "--output"),
        (["plan", str(CASE_STUDY), "--graph", "{bad}/g.dot"], "--graph"),
        (["blueprint", "towers", "-o", "{bad}/w.yaml"], "--output"),
        (["fsm", "diagram", "brick", "-o", "{bad}/b.dot"], "--output"),
        (["markers", "--bricks", "0", "-o", "{bad}/m.pdf"], "--output"),
        (["calibrate", "{img}", "-o", "{bad}/c.yaml"], "--output"),
        (
            [
                "mission-control",
                str(CASE_STUDY),
                "--report",
                "{bad}/r.json",
                "--listen",
                "tcp/127.0.0.1:{port}",
                "--startup-timeout",
                "0.2",
                "--max-time",
                "0.2",
            ],
            "--report",
        ),
    ],
)
def test_every_command_that_writes_a_file_checks_it_first(tmp_path, argv, flag):
    img = tmp_path / "blank.png"
    img.write_bytes(b"")  # calibrate must refuse the output before it looks at its images
    bad = tmp_path / "missing-dir"
    args = [a.format(bad=bad, img=img, port=_free_port()) for a in argv]
    line = one_line_error(runner.invoke(app, args))
    assert flag in line and str(bad) in line and "does not exist" in line


def test_outputs_are_replaced_atomically(tmp_path):
    from masonry.cli.outputs import atomic_path, check_output_path, write_atomic

    target = tmp_path / "report.json"
    target.write_text("the previous report\n")
    with pytest.raises(RuntimeError), atomic_path(target, "--report") as tmp:
        assert tmp.parent == tmp_path and tmp.suffix == ".json" and tmp != target
        tmp.write_text('{"half": ')
        raise RuntimeError("killed while writing")
    assert target.read_text() == "the previous report\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["report.json"], "a temporary file was left behind"
    write_atomic(target, "new\n", "--report")
    assert target.read_text() == "new\n" and sorted(p.name for p in tmp_path.iterdir()) == ["report.json"]
    assert oct(target.stat().st_mode & 0o777) == oct(0o666 & ~_umask())
    with pytest.raises(InputError, match=r"^--log .*: the directory .* does not exist$"):
        check_output_path(tmp_path / "nope" / "x.log", "--log")


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def test_sim_writes_report_gantt_and_plot_through_the_atomic_path(tmp_path):
    report, gantt = tmp_path / "r.json", tmp_path / "g.svg"
    report.write_text("stale")
    res = sim(CASE_STUDY, "--format", "json", "--report", str(report), "--gantt", str(gantt))
    assert res.exit_code == 0, res.output
    assert json.loads(report.read_text()) == json.loads(res.stdout)
    assert gantt.read_text().lstrip().startswith("<?xml")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["g.svg", "r.json"]
