"""Just-in-time glue (issue 31): the dispatcher holds a bead until its brick can follow and until the glue under
it has cured; mission control sprays an expired bead again before its brick is placed; the simulated world
measures the glue's age and the violations."""

from __future__ import annotations

import dataclasses
import json
import sys
from pathlib import Path

import pytest

from masonry.adhesive import Adhesive
from masonry.blueprint import Blueprint, load_blueprint
from masonry.errors import InputError, PlanningError
from masonry.mission.glue import EXPIRED_REASON
from masonry.mission.simulate import simulate
from masonry.planner import plan as make_plan
from masonry.planner.schedule_policy import make_dispatcher
from masonry.planner.tasks import AdhesionTask

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
SMALL = ROOT / "blueprints" / "running_bond_small.yaml"
sys.path.insert(0, str(Path(__file__).resolve().parent))


def _glued(path: Path, open_time_s: float | None, cure_time_s: float = 0.0) -> Blueprint:
    return dataclasses.replace(
        load_blueprint(path), adhesive=Adhesive(open_time_s=open_time_s, cure_time_s=cure_time_s)
    )


def test_a_bead_waits_until_every_bead_under_its_brick_can_be_laid() -> None:
    """A brick of course 3 rests on bricks j and k of course 2: with j placed and k not, the bead on j waits (it
    would age until k is placed and glued)."""
    bp = _glued(SMALL, 300.0)
    p = make_plan(bp)
    beads: dict[str, list[AdhesionTask]] = {}
    for t in p.tasks:
        if isinstance(t, AdhesionTask):
            beads.setdefault(f"B{t.above}", []).append(t)
    brick, (a1, a2) = next((b, ts) for b, ts in beads.items() if len(ts) == 2 and f"B{ts[0].below}" in beads)
    j, k = f"B{a1.below}", f"B{a2.below}"
    under_j = [t.id for t in beads[j]]
    d = make_dispatcher(p, bp.fleet, "critical-path", reservation="site")
    d.restore([j, *under_j], {})
    assert a1.id in d.held() and a1.id not in d.available and not d.blocked
    d2 = make_dispatcher(p, bp.fleet, "critical-path", reservation="site")
    d2.restore([j, k, *under_j, *(t.id for t in beads[k])], {})
    assert a1.id not in d2.held() and {a1.id, a2.id} <= set(d2.available), brick
    plain = make_dispatcher(make_plan(load_blueprint(SMALL)), bp.fleet, "critical-path", reservation="site")
    plain.restore([j, *under_j], {})
    assert a1.id in plain.available  # without an adhesive: laid as soon as brick j is


def test_without_adhesive_the_dispatcher_is_the_plain_one() -> None:
    bp = load_blueprint(CASE_STUDY)
    d = make_dispatcher(make_plan(bp), bp.fleet, "critical-path", reservation="site")
    assert type(d).__name__ == "Dispatcher"
    d.assign()
    d.complete("A0")
    assert "A1" in {a.task_id for a in d.assign()}  # glue laid long before its brick can come


def test_cure_holds_the_beads_on_top_until_cured_and_reopen_sprays_again() -> None:
    bp = _glued(SMALL, None, 60.0)
    p = make_plan(bp)
    d = make_dispatcher(p, bp.fleet, "critical-path", reservation="task")
    cure = next(x for x in p.deadlines if x.kind == "cure")
    under = [t.id for t in p.tasks if t.kind == "adhesion" and f"B{t.above}" == cure.brick]  # type: ignore[union-attr]
    # fly everything below the glued brick, then the brick itself
    done: set[str] = set()
    while cure.brick not in done:
        running = list(d.in_progress)
        if not running:
            d.assign()
            running = list(d.in_progress)
        assert running, (d.held(), d.available)
        for tid in running:
            d.complete(tid)
            done.add(tid)
        assert cure.adhesion not in d.in_progress
    d.assign()
    assert cure.adhesion not in d.in_progress and cure.adhesion in d.held()
    for tid in list(d.in_progress):
        d.complete(tid)
    d.cured(cure.brick)
    d.assign()
    assert cure.adhesion not in d.held()
    # a bead sprayed again: done no more, its brick waits for it again
    d2 = make_dispatcher(
        make_plan(_glued(CASE_STUDY, 60.0)), bp.fleet[:0] or load_blueprint(CASE_STUDY).fleet, "critical-path"
    )
    d2.assign()
    d2.complete("A0")
    d2.reopen("A0")
    assert "A0" not in d2.done and "A0" in d2.available
    with pytest.raises(PlanningError, match="only a done adhesion task"):
        d2.reopen("B0")
    assert under  # the glued brick has beads under it


def _flight(bp: Blueprint, **kw: object):  # type: ignore[no-untyped-def]
    return simulate(bp, seed=0, **kw)  # type: ignore[arg-type]


def test_a_short_open_time_has_no_violations_and_reports_glue_ages() -> None:
    r = _flight(_glued(CASE_STUDY, 60.0))
    assert r.completed and r.open_time_violations == 0 and r.cure_time_violations == 0
    assert r.glue_age_s is not None and set(r.glue_age_s) == {"B0", "B1"}
    assert all(0.0 < age <= 60.0 for age in r.glue_age_s.values())
    doc = r.to_dict()
    bricks = [t for t in doc["tasks"] if t["id"].startswith("B")]
    assert all(isinstance(t["glue_age_s"], float) for t in bricks)
    assert doc["open_time_violations"] == 0 and doc["cure_time_violations"] == 0
    assert "adhesive: 0 open-time and 0 cure-time violations" in r.summary()
    plain = _flight(load_blueprint(CASE_STUDY))
    text = json.dumps(plain.to_dict())
    assert "glue_age_s" not in text and "open_time_violations" not in text


def test_the_world_counts_glue_older_than_the_open_time() -> None:
    """Measured by the world, not by mission control: a bead left 40 s before its brick is a violation at 20 s."""
    from masonry.sim.adhesive import AdhesiveDeposit
    from masonry.sim.glue import GlueWatch

    bp = _glued(CASE_STUDY, 20.0, 30.0)
    deposit = AdhesiveDeposit()
    watch = GlueWatch(bp, deposit)
    a0 = next(t for t in make_plan(bp).tasks if t.id == "A0")
    deposit.add(a0.start_m, a0.end_m, 5.0)  # type: ignore[union-attr]
    watch.placed(0, bp.brick(0).position_m, 45.0)
    assert watch.glue_age_s == {0: 40.0} and watch.open_violations == [0]
    watch.placed(1, bp.brick(1).position_m, 50.0)  # no glue under it: no age
    assert 1 not in watch.glue_age_s
    inert = GlueWatch(load_blueprint(CASE_STUDY), deposit)
    inert.placed(0, bp.brick(0).position_m, 45.0)
    assert not inert.enabled and inert.glue_age_s == {}


def test_the_world_keeps_counting_across_a_stop() -> None:
    """A rebuilt world (mission control stopped and resumed) lays the journaled beads again at their times: glue
    laid at 5 s before the stop is 40 s old under a brick placed at 45 s after it, a violation at 20 s."""
    from masonry.sim.adhesive import AdhesiveDeposit
    from masonry.sim.glue import GlueWatch

    bp = _glued(CASE_STUDY, 20.0, 30.0)
    deposit = AdhesiveDeposit()
    before = GlueWatch(bp, deposit)
    a0 = next(t for t in make_plan(bp).tasks if t.id == "A0")
    deposit.add(a0.start_m, a0.end_m, 5.0)  # type: ignore[union-attr]
    before.note_bead(a0.start_m, a0.end_m)  # type: ignore[union-attr]
    b1 = bp.brick(1).position_m
    before.note_bead(b1, b1)  # no glue there: nothing
    snap = json.loads(json.dumps(before.snapshot()))  # as the journal keeps it
    assert snap["beads"] == [[*a0.start_m, *a0.end_m, 5.0]]  # type: ignore[union-attr]
    after = GlueWatch(bp, AdhesiveDeposit())
    after.restore(snap)
    after.placed(0, bp.brick(0).position_m, 45.0)
    assert after.glue_age_s == {0: 40.0} and after.open_violations == [0]
    again = GlueWatch(bp, AdhesiveDeposit())
    again.restore(json.loads(json.dumps(after.snapshot())))
    assert again.open_violations == [0] and again.glue_age_s == {0: 40.0} and again.placed_at_s == {0: 45.0}
    again.sprayed_on(0, 50.0)  # on B0 placed (before the stop) at 45 s: 5 s of its 30 s cure
    assert again.cure_violations == {0}
    again.restore({"beads": "junk", "open": [None], "placed_s": {"x": 1.0}})  # unreadable parts are ignored
    assert again.open_violations == [0]


def test_a_recall_expires_the_glue_and_it_is_sprayed_again_before_its_brick(tmp_path: Path) -> None:
    """The operator recalls the brick UAV (it lands with its brick, held until the resume): the bead under B0
    expires while it waits, is sprayed again, and B0 goes onto fresh glue."""
    from test_operator import _fly

    path = tmp_path / "glued.yaml"
    path.write_text(CASE_STUDY.read_text() + "adhesive: {open_time_s: 60}\n")
    _, r, answers = _fly(path, {25.0: {"command": "recall", "uav": "brick-1"}, 70.0: {"command": "resume"}})
    assert [c for _, c, o in answers if o.accepted] == ["recall", "resume"]
    assert r.completed and r.open_time_violations == 0 and r.cure_time_violations == 0
    expired = [a for a in r.attempts if a.reason is not None and a.reason.startswith(EXPIRED_REASON)]
    beads = [a for a in expired if a.kind == "adhesion"]
    assert beads and all(a.status == "failed" for a in expired)
    for a in beads:  # every re-spray explained, and followed by a done attempt of the same bead
        assert any(
            b.task_id == a.task_id and b.status == "done" and b.start_s > a.start_s for b in r.attempts
        )
    b0 = [a for a in r.attempts if a.task_id == "B0" and a.status == "done"]
    a0 = [a for a in r.attempts if a.task_id == "A0" and a.status == "done"]
    assert b0 and a0 and a0[-1].end_s is not None and b0[-1].end_s - a0[-1].end_s <= 60.0  # type: ignore[operator]
    assert r.glue_age_s is not None and all(age <= 60.0 for age in r.glue_age_s.values())
    detail = {t.id: t.to_dict()["attempts_detail"] for t in r.tasks}
    assert any(x["reason"] == EXPIRED_REASON for x in detail[expired[0].task_id])


def test_an_open_time_no_brick_can_meet_is_refused() -> None:
    with pytest.raises(
        InputError, match=r"adhesive.open_time_s: 10 s is not above a brick's placing descent"
    ):
        _flight(_glued(CASE_STUDY, 10.0))


def test_cli_sim_refuses_an_open_time_no_brick_can_meet(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from masonry.cli import app

    path = tmp_path / "glued.yaml"
    path.write_text(CASE_STUDY.read_text() + "adhesive: {open_time_s: 10}\n")
    result = CliRunner().invoke(app, ["sim", str(path)])
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert result.exit_code == 2 and len(lines) == 1, result.stderr
    assert "adhesive.open_time_s: 10 s is not above" in lines[0]


def test_an_expired_bead_waits_for_a_free_brick_uav() -> None:
    """A1's glue expired while brick-1 carried B0: it is laid again only once brick-1 is free to bring B1."""
    bp = _glued(CASE_STUDY, 60.0)
    d = make_dispatcher(make_plan(bp), bp.fleet, "critical-path", reservation="site")
    assert {a.task_id for a in d.assign()} == {"A0", "B0"}
    d.complete("A0")
    assert [a.task_id for a in d.assign()] == ["A1"]
    d.complete("A1")
    d.assign()
    d.reopen("A1")  # (mission control: it expired before B1 could come)
    assert d.assign() == [] and d.held() == ("A1",) and not d.blocked
    d.complete("B0")
    again = {a.task_id: a.attempt for a in d.assign()}
    assert again == {"A1": 2, "B1": 1} and d.held() == ()


class _Control:
    """What GlueGate asks of mission control: its attempts (and their ledger, which numbers the assignments),
    journal, events, recalls, airspace and UAVs."""

    def __init__(self) -> None:
        from masonry.mission.control import Attempt, UavLink
        from masonry.mission.ledger import AttemptLedger

        self.history = [Attempt("A0", "glue-1", 1, 0.0, end_s=15.0, status="done")]
        self.ledger = AttemptLedger(None)
        self.journal = None
        self.recalls: list[tuple[str, str]] = []
        self.named: list[tuple[str | None, int]] = []  # the assignment each recall names
        self.touched = 0
        self.columns = self
        self.events: list[tuple[tuple[object, ...], dict[str, object]]] = []
        self.uavs: dict[str, UavLink] = {}

    def touch(self) -> None:
        self.touched += 1

    def recall(
        self, uav: str, now_s: float, reason: str, task_id: str | None = None, attempt: int = 0
    ) -> None:
        self.recalls.append((uav, reason))
        self.named.append((task_id, attempt))

    def emit_event(self, *args: object, **kw: object) -> None:
        self.events.append((args, kw))


def test_the_gate_tells_the_operator_of_each_bead_waiting_for_its_brick() -> None:
    """A ``glue`` event per bead sprayed, with its brick and when it expires; after a resume, only for the beads
    whose brick is not placed yet."""
    from masonry.mission.glue import glue_gate
    from masonry.mission.sites import SiteIntervals
    from masonry.timing import DEFAULT_TIMING

    bp = _glued(CASE_STUDY, 60.0)
    p = make_plan(bp)
    d = make_dispatcher(p, bp.fleet, "critical-path", reservation="site")
    d.restore(["A0", "B0", "A1"], {})
    gate = glue_gate(p, d, SiteIntervals(p, d.task_of, exclusive=False), DEFAULT_TIMING)
    assert gate is not None
    under = {t.id: f"B{t.above}" for t in p.tasks if isinstance(t, AdhesionTask)}
    gate.restore([("A0", 10.0), ("B0", 30.0), ("A1", 35.0)])
    mc = _Control()
    gate.step(mc, 40.0)
    assert [(a[1], a[3], kw) for a, kw in mc.events] == [
        ("glue", "A1", {"brick": under["A1"], "sprayed_s": 35.0, "open_until_s": 95.0})
    ]
    gate.step(mc, 41.0)  # told once
    assert len(mc.events) == 1


def test_the_gate_expires_a_bead_keeps_its_brick_waiting_then_recalls_it_and_leaves_a_stuck_brick_alone() -> (
    None
):
    from masonry.mission.glue import RECALL_AFTER_EXPIRIES, glue_gate
    from masonry.mission.sites import SiteIntervals
    from masonry.timing import DEFAULT_TIMING

    bp = _glued(CASE_STUDY, 60.0)
    p = make_plan(bp)
    for stuck in (False, True):
        d = make_dispatcher(p, bp.fleet, "critical-path", reservation="site", max_attempts=1)
        gate = glue_gate(p, d, SiteIntervals(p, d.task_of, exclusive=False), DEFAULT_TIMING)
        assert gate is not None and gate.margin_s == 19.5
        mc = _Control()
        d.assign()  # A0 and B0 (fetched while the glue is laid)
        mc.ledger.begin("B0", "brick-1", 10.0)
        d.complete("A0")
        gate.completed("A0", 15.0)
        if stuck:
            d.fail("B0")  # its only attempt: stuck
        assert not gate.step(mc, 50.0)  # 35 s old + 19.5 s to press it: still open
        news = gate.step(mc, 60.0)
        if stuck:
            assert not news and "A0" in d.done and mc.recalls == []
            continue
        # the bead is sprayed again; the brick's UAV is recalled at the RECALL_AFTER_EXPIRIES-th expiry
        recalled = [("brick-1", EXPIRED_REASON)]
        assert news and "A0" not in d.done and mc.recalls == (recalled if RECALL_AFTER_EXPIRIES == 1 else [])
        assert (mc.history[0].status, mc.history[0].reason) == ("failed", EXPIRED_REASON)
        assert gate.expiries == [(60.0, "A0", "B0")]
        t = 60.0
        for n in range(2, RECALL_AFTER_EXPIRIES + 1):  # sprayed again and again, and expiring each time
            d.assign()
            d.complete("A0")
            gate.completed("A0", t)
            t += 60.0
            assert gate.step(mc, t)
            assert mc.recalls == ([] if n < RECALL_AFTER_EXPIRIES else recalled)
        assert len(gate.expiries) == RECALL_AFTER_EXPIRIES
        assert mc.named == [("B0", 1)]  # the recall names the brick's assignment


def test_the_log_keeps_the_glue_and_the_gantt_draws_the_open_windows(tmp_path: Path) -> None:
    from masonry.mission.report_codec import report_from_record, report_to_record
    from masonry.viz.gantt import draw_gantt, open_windows

    r = _flight(_glued(CASE_STUDY, 60.0))
    again = report_from_record(json.loads(json.dumps(report_to_record(r))))
    assert again.to_dict() == r.to_dict() and again.open_time_s == 60.0
    windows = open_windows(r)
    done = [a for a in r.attempts if a.kind == "adhesion" and a.status == "done"]
    assert {w[1] for w in windows} >= {a.task_id for a in done} and done
    assert all(t1 - t0 == pytest.approx(60.0) for _, _, t0, t1 in windows)
    assert draw_gantt(r, tmp_path / "g.png").stat().st_size > 0
    plain = _flight(load_blueprint(CASE_STUDY))
    assert open_windows(plain) == [] and "glue_age_s" not in report_to_record(plain)


def test_a_resumed_mission_knows_its_beads_ages(tmp_path: Path) -> None:
    from masonry.mission.journal import read_journal
    from masonry.mission.simulate import SimulatedMission

    bp = _glued(CASE_STUDY, 60.0)
    journal = tmp_path / "m.db"
    first = _flight(bp, journal_path=journal, max_time_s=25.0)
    assert not first.completed
    a0 = next(r for r in read_journal(journal).done if r.task_id == "A0")
    from masonry.mission.events import EventList

    sink = EventList()
    mission = SimulatedMission.from_blueprint(bp, journal_path=journal, resume=True, events_sink=sink)
    assert mission.control.glue is not None and mission.control.glue.sprayed_at_s == {"A0": a0.time_s}
    r = mission.run()
    # the operator is told at once: A0's age comes from the journal (the live page, the log)
    told = next(e for e in sink.events if e.kind == "glue")
    assert told.task_id == "A0" and told.fields["sprayed_s"] == a0.time_s
    assert r.completed and r.open_time_violations == 0 and r.cure_time_violations == 0
    # the rebuilt world knows the glue laid before the stop: B0, on A0 sprayed then, has its age measured
    assert r.glue_age_s is not None and set(r.glue_age_s) == {"B0", "B1"}
    assert 0.0 < r.glue_age_s["B0"] <= 60.0
