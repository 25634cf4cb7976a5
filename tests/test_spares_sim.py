"""Spare bricks in whole simulated missions (issue 30): a brick lost with its UAV is replaced by a spare.

The scenario of the issue: a 30-brick running bond (3 courses of 10, turned 30 degrees, r_c 1.0 m), two brick
UAVs and one adhesion UAV, ``uav-loss=brick-2@80``: brick-2 falls carrying brick 8, far from its pickup.
Without spares brick-1 then looks for brick 8 at its pickup in vain, and 11 tasks behind it are never done.
(At 100 s until branch ``compact48``; since its dispatch rule brick-2 takes brick 8 first and has released it on
the wall by 100 s: that loss is the last test here.)
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import pytest

from masonry.blueprint import Blueprint, format_blueprint, load_blueprint
from masonry.blueprint_gen import generate
from masonry.mission.journal import read_journal
from masonry.mission.report_codec import report_from_record, report_to_record
from masonry.mission.simulate import simulate
from masonry.mission.spares import SPARE_META_PREFIX
from masonry.sim.faults import Faults

pytestmark = pytest.mark.slow

LOSS = Faults.parse(["uav-loss=brick-2@80"])
SEED = 1


def _wall(tmp_path: Path, spares: int | None) -> Blueprint:
    """The issue's wall, through its YAML text (what ``masonry blueprint ... --spares N -o`` writes)."""
    bp = generate(
        "running-bond",
        courses=3,
        bricks_per_course=10,
        brick_uavs=2,
        adhesion_uavs=1,
        yaw_rad=0.5236,
        clearance_m=1.0,
        spares=spares,
    )
    path = tmp_path / f"wall-{spares}.yaml"
    path.write_text(format_blueprint(bp), encoding="utf-8")
    return load_blueprint(path)


def test_a_brick_lost_with_its_uav_is_replaced_by_a_spare_and_the_wall_completes(tmp_path: Path) -> None:
    bp = _wall(tmp_path, spares=2)
    report = simulate(bp, seed=SEED, faults=LOSS)
    assert report.completed, report.summary()
    out = report.to_dict()
    assert out["spares_used"] == [
        {
            "spare": 30,
            "brick": 8,
            "task": "B8",
            "reason": "uav lost (last heard in transport, with brick 8 on its magnet)",
        }
    ]
    assert out["spares_left"] == [31]
    assert out["waiting_for_person"] == []
    # the spare stands where brick 8 was designed to (the world's truth, not the UAV's estimate)
    assert out["placement_error_m"]["B8"] < 0.02
    b8 = next(t for t in report.tasks if t.id == "B8")
    assert [a.uav for a in b8.tries] == ["brick-2", "brick-1"]
    assert "spares used: spare 30 for brick 8" in report.summary()
    # a log's report record keeps it (masonry replay prints the same summary)
    again = report_from_record(json.loads(json.dumps(report_to_record(report))))
    assert again.spares == report.spares and again.summary() == report.summary()


def test_without_a_spare_the_brick_waits_for_a_person_and_the_rest_is_built(tmp_path: Path) -> None:
    bp = _wall(tmp_path, spares=0)  # `spares: []`: accounted for, none on site
    report = simulate(bp, seed=SEED, faults=LOSS)
    assert not report.completed
    out = report.to_dict()
    assert out["spares_used"] == [] and out["spares_left"] == []
    assert [w["brick"] for w in out["waiting_for_person"]] == [8]
    assert "no spare of its size (0.3 x 0.15 x 0.1 m) left" in out["waiting_for_person"][0]["reason"]
    # B8 is tried once at its pickup (its UAV may have put it back), then waits: no third and fourth climb
    b8 = next(t for t in report.tasks if t.id == "B8")
    assert len(b8.tries) == 2
    # what does not depend on brick 8 is built; what does (above it, and its glue) is not
    stuck = set(report.stuck)
    assert {"B8", "B17", "B18", "B27", "B28", "B29"} <= stuck
    done = {t.id for t in report.tasks if t.status == "done"}
    assert len(done) == len(report.tasks) - len(stuck) and len(done) >= 50
    assert "waiting for a person: brick 8" in report.summary()


def test_a_blueprint_without_spares_reports_no_spare_fields(tmp_path: Path) -> None:
    bp = _wall(tmp_path, spares=None)
    assert bp.spares is None
    out = simulate(bp, seed=SEED, faults=LOSS, max_time_s=150.0).to_dict()
    assert not {"spares_used", "spares_left", "waiting_for_person"} & set(out)


def test_a_used_spare_stays_used_after_a_resume(tmp_path: Path) -> None:
    bp = _wall(tmp_path, spares=2)
    journal = tmp_path / "mission.db"
    stopped = simulate(bp, seed=SEED, faults=LOSS, journal_path=journal, max_time_s=200.0)
    assert not stopped.completed
    meta = read_journal(journal).meta
    # journaled when it was handed out (before the stop: brick-2 lost carrying brick 8, not after its release)
    assert f"{SPARE_META_PREFIX}30" in meta, sorted(meta)
    assert meta[f"{SPARE_META_PREFIX}30"]["task"] == "B8"
    resumed = simulate(dataclasses.replace(bp), seed=SEED, journal_path=journal, resume=True)
    assert resumed.completed, resumed.summary()
    out = resumed.to_dict()
    # the resumed mission knows spare 30 went to B8, hands out no other, and leaves spare 31 on the pallet
    assert [(u["spare"], u["brick"]) for u in out["spares_used"]] == [(30, 8)]
    assert out["spares_left"] == [31]
    assert next(t for t in resumed.tasks if t.id == "B8").status == "done"


def test_a_brick_uav_lost_after_its_release_leaves_its_brick_done_no_spare_used(tmp_path: Path) -> None:
    # brick-2 releases brick 8 at 96.5 s and falls climbing out (place_ascend): the brick is on the wall. Given
    # again (branch compact47), brick-1 looked for it at its pickup, spare 30 stood in for it and could not reach
    # its drop-off, brick 8 in it ("not reached within 1.5 cm after 3 descents"): 12 tasks stranded
    bp = _wall(tmp_path, spares=2)
    report = simulate(bp, seed=SEED, faults=Faults.parse(["uav-loss=brick-2@100"]))
    assert report.completed, report.summary()
    out = report.to_dict()
    assert out["spares_used"] == [] and out["spares_left"] == [30, 31]
    b8 = next(t for t in report.tasks if t.id == "B8")
    assert [(a.uav, a.status) for a in b8.tries] == [("brick-2", "done")]
    assert out["placement_error_m"]["B8"] < 0.02
