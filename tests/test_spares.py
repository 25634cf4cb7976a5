"""Spare bricks (issue 30): the blueprint's ``spares``, their validation, ``--spares``, the mission's book of them,
the dispatcher giving up on a brick, and the UAV taking a spare in its brick's place."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import pytest
import yaml
from typer.testing import CliRunner

from masonry.blueprint import format_blueprint, load_blueprint, parse_blueprint
from masonry.blueprint_gen import generate
from masonry.cli import app
from masonry.errors import BlueprintError, MissionError
from masonry.fingerprint import wall_digest
from masonry.mission.events import MissionEvent
from masonry.mission.handler import UavHandler
from masonry.mission.inproc import InprocBus
from masonry.mission.messages import MISSION_CONTROL, Assign, Result, decode, encode
from masonry.mission.spares import SPARE_META_PREFIX, WAITING_META_PREFIX, SpareBook, SpareReport, brick_gone
from masonry.planner import plan
from masonry.planner.dispatch import Dispatcher
from masonry.planner.tasks import BrickTask
from masonry.ports import RECALL_REASON, TASK_DROPPED_REASON
from masonry.spares import Spare

runner = CliRunner()

WALL = """\
name: two
bricks:
  - {id: 0, position: [0.0, 0.0, 0.05], pickup: [3.0, 0.0, 0.05]}
  - {id: 1, position: [0.3, 0.0, 0.05], pickup: [3.5, 0.0, 0.05]}
  - {id: 2, position: [0.15, 0.0, 0.15], pickup: [4.0, 0.0, 0.05], size: [0.3, 0.15, 0.1]}
fleet:
  - {name: brick-1, role: brick, home: [2.0, -3.0, 0.0]}
  - {name: glue-1, role: adhesion, home: [0.0, -3.0, 0.0]}
"""
SPARES = """\
spares:
  - {id: 10, pickup: [3.0, 1.0, 0.05]}
  - {id: 11, pickup: [3.5, 1.0, 0.06], size: [0.3, 0.15, 0.12]}
"""


def _bp(spares: str = SPARES, source: str = "wall.yaml"):
    return parse_blueprint(yaml.safe_load(WALL + spares), source)


# -- the blueprint -----------------------------------------------------------------------------------------
def test_spares_are_read_with_the_default_size_and_written_back() -> None:
    bp = _bp()
    assert bp.spares == (
        Spare(10, (3.0, 1.0, 0.05), (0.3, 0.15, 0.1)),
        Spare(11, (3.5, 1.0, 0.06), (0.3, 0.15, 0.12)),
    )
    text = format_blueprint(bp)
    assert "spares:\n  - {id: 10, pickup: [3.0, 1.0, 0.05]}\n  - {id: 11, pickup:" in text
    assert parse_blueprint(yaml.safe_load(text)) == replace(bp, source="<blueprint>")
    assert plan(bp).spares == bp.spares


def test_no_spares_key_is_none_and_an_empty_list_is_no_spare() -> None:
    assert _bp("").spares is None and "spares" not in format_blueprint(_bp(""))
    empty = _bp("spares: []\n")
    assert empty.spares == () and "spares: []" in format_blueprint(empty)


@pytest.mark.parametrize(
    "spares, where, problem",
    [
        ("spares: {id: 10}\n", "spares", "must be a list of spares, got a mapping"),
        ("spares: [7]\n", "spares[0]", "must be a mapping with `id` and `pickup`"),
        ("spares: [{pickup: [3, 1, 0.05]}]\n", "spares[0]: id", "must be an integer >= 0, got None"),
        ("spares: [{id: -1, pickup: [3, 1, 0.05]}]\n", "spares[0]: id", "must be an integer >= 0"),
        ("spares: [{id: 10}]\n", "spare 10", "missing key 'pickup'"),
        ("spares: [{id: 10, pickup: [3, 1]}]\n", "spare 10: pickup", "list of 3 finite numbers [x, y, z]"),
        ("spares: [{id: 10, pickup: [3, 1, .nan]}]\n", "spare 10: pickup", "list of 3 finite numbers"),
        ("spares: [{id: 10, pickup: [3, 1, 0.05], colour: red}]\n", "spare 10", "unknown key 'colour'"),
        ("spares: [{id: 10, pickup: [3, 1, 0.05], size: [0.3, 0, 0.1]}]\n", "spare 10: size", "must be > 0"),
        (
            "spares: [{id: 10, pickup: [3, 1, 0.05]}, {id: 10, pickup: [4, 1, 0.05]}]\n",
            "spare 10",
            "duplicate spare id",
        ),
        ("spares: [{id: 2, pickup: [3, 1, 0.05]}]\n", "spare 2: id", "brick 2 has it too"),
        ("spares: [{id: 30, pickup: [3, 1, 0.05]}]\n", "spare 30: id", "are not in DICT_4X4_50"),
        ("spares: [{id: 10, pickup: [0.1, 0.0, 0.05]}]\n", "spare 10: pickup", "inside the wall's footprint"),
        ("spares: [{id: 10, pickup: [3.0, 0.05, 0.05]}]\n", "spare 10: pickup", "is brick 0's pickup too"),
        ("spares: [{id: 10, pickup: [3, 1, 0.01]}]\n", "spare 10: pickup", "below the ground"),
        ("spares: [{id: 10, pickup: [5000, 1, 0.05]}]\n", "spare 10: pickup", "is off the site"),
        (
            "spares: [{id: 10, pickup: [3, 1, 0.05], size: [0.1, 0.15, 0.1]}]\n",
            "spare 10: size",
            "markers do not fit",
        ),
    ],
)
def test_a_bad_spare_is_one_line_naming_the_file_the_spare_and_the_field(
    spares: str, where: str, problem: str
) -> None:
    with pytest.raises(BlueprintError) as info:
        _bp(spares)
    message = str(info.value)
    assert "\n" not in message and message.startswith(f"wall.yaml: {where}: "), message
    assert problem in message


def test_masonry_blueprint_adds_spares_beside_the_pallet_and_changes_nothing_else(tmp_path: Path) -> None:
    args = ["blueprint", "running-bond", "--courses", "2", "--bricks-per-course", "4"]
    plain, spared = tmp_path / "plain.yaml", tmp_path / "spared.yaml"
    assert runner.invoke(app, [*args, "-o", str(plain)]).exit_code == 0
    out = runner.invoke(app, [*args, "--spares", "3", "-o", str(spared)])
    assert out.exit_code == 0 and "8 bricks (8 to place), 3 spares, 2 UAVs" in out.output
    a, b = load_blueprint(plain), load_blueprint(spared)
    assert a.spares is None and "spares" not in plain.read_text()
    assert (b.bricks, b.fleet) == (a.bricks, a.fleet)  # the pads stay where they were
    assert b.spares is not None and [s.id for s in b.spares] == [8, 9, 10]
    assert all(s.size_m == b.brick_size_m for s in b.spares)
    assert "--spares 3" in spared.read_text().splitlines()[0]
    bad = runner.invoke(app, [*args, "--spares", "-1"])
    assert bad.exit_code == 2 and "--spares -1: out of range" in bad.output


@pytest.mark.parametrize("kind", ["running-bond", "towers", "pyramid"])
def test_every_generator_takes_spares_that_validate(kind: str) -> None:
    bp = generate(kind, spares=5, brick_uavs=2)
    again = parse_blueprint(yaml.safe_load(format_blueprint(bp)))  # validated
    assert again.spares is not None and len(again.spares) == 5
    assert generate(kind).spares is None


# -- the mission's book ------------------------------------------------------------------------------------
class Meta:
    def __init__(self) -> None:
        self.meta: dict[str, object] = {}

    def set_meta(self, key: str, value: object) -> None:
        self.meta[key] = value


LOST = "uav lost (last heard in transport, with brick 0 on its magnet)"
NOT_SEEN = "brick 1 not seen near its pickup after 3 climbs"


def test_reasons_that_say_the_brick_is_gone() -> None:
    assert brick_gone(LOST) and brick_gone(NOT_SEEN) and brick_gone("brick dropped in transport")
    assert not brick_gone(f"{TASK_DROPPED_REASON} (its heartbeat holds no task 9.0 s after it)")
    assert not brick_gone("drop-off of B1 not reached within 1.5 cm after 3 descents")
    assert not brick_gone("brick 1 not attached after 3 grasps")
    assert not brick_gone("uav lost")


def test_a_spare_of_the_same_size_stands_in_once_and_is_journaled() -> None:
    p = plan(_bp())
    journal = Meta()
    book = SpareBook(p, journal)
    b0 = p.task("B0")
    assert book.task(b0) is b0
    book.lost("B0", LOST, 100.0)
    flown = book.task(b0)
    assert isinstance(flown, BrickTask)
    assert (flown.spare, flown.pickup_m, flown.marker_ids) == (10, (3.0, 1.0, 0.05), (20, 21))
    assert journal.meta[f"{SPARE_META_PREFIX}10"] == {
        "spare": 10,
        "brick": 0,
        "task": "B0",
        "reason": LOST,
        "time_s": 100.0,
        "failure": False,
    }
    # brick 1's brick is gone too: spare 11 is of another size, so B1 waits for a person (stuck now)
    assert book.failed("B1", NOT_SEEN, 200.0) == (True, True)
    assert book.task(p.task("B1")) == p.task("B1")
    report = book.report()
    assert report is not None
    assert report.to_dict() == {
        "spares_used": [{"spare": 10, "brick": 0, "task": "B0", "reason": LOST}],
        "spares_left": [11],
        "waiting_for_person": [
            {
                "brick": 1,
                "task": "B1",
                "reason": f"{NOT_SEEN}; no spare of its size (0.3 x 0.15 x 0.1 m) left",
            }
        ],
    }
    assert f"{WAITING_META_PREFIX}B1" in journal.meta


def test_a_replaced_attempt_does_not_count_and_other_failures_are_as_before() -> None:
    book = SpareBook(plan(_bp()))
    assert book.failed("B0", NOT_SEEN, 1.0) == (False, False)  # spare 10 stands in: not the task's fault
    assert book.failed("B0", "could not reach the pickup of B0", 2.0) == (True, False)
    assert book.failed("B0", f"{RECALL_REASON}: by the operator", 3.0) == (False, False)
    assert book.failed("A0", NOT_SEEN, 4.0) == (True, False)  # not a brick task


def test_a_plan_without_spares_keeps_the_book_inert() -> None:
    book = SpareBook(plan(_bp("")))
    assert book.failed("B0", NOT_SEEN, 1.0) == (True, False)
    book.lost("B0", LOST, 1.0)
    assert book.used == [] and book.report() is None
    assert book.restore({"spare/10": {"task": "B0"}}, {"B0": 1}, 3) == {"B0": 1}


def test_the_book_restored_from_a_journal_hands_out_no_spare_twice() -> None:
    p = plan(_bp())
    first = Meta()
    book = SpareBook(p, first)
    book.lost("B0", LOST, 10.0)
    book.failed("B2", NOT_SEEN, 20.0)  # spare 11 is 0.12 m high: none for B2, it waits
    again = SpareBook(p)
    # the journal counted B2's failure, and the one spare 10 replaced on B1 after a first (uncounted) loss
    assert again.restore(first.meta, {"B2": 1}, 3) == {"B2": 3}
    assert [(u.spare, u.task_id) for u in again.used] == [(10, "B0")]
    assert again.task(p.task("B0")) == book.task(p.task("B0"))
    assert again.failed("B1", NOT_SEEN, 30.0) == (True, True)  # spare 10 is taken: B1 waits too


def test_an_attempt_a_spare_replaced_is_not_counted_after_a_resume() -> None:
    p = plan(_bp())
    journal = Meta()
    book = SpareBook(p, journal)
    assert book.failed("B0", NOT_SEEN, 10.0) == (False, False)  # spare 10, not counted here...
    again = SpareBook(p)
    # ... nor after a resume, though the journal's failure record counts it; a lost UAV's attempt is no record
    assert again.restore(journal.meta, {"B0": 2, "B1": 1}, 3) == {"B0": 1, "B1": 1}
    assert again.task(p.task("B0")) == book.task(p.task("B0"))


def test_the_dispatcher_gives_up_on_a_task_at_once() -> None:
    p = plan(_bp())
    d = Dispatcher(p, _bp().fleet, "fifo")
    [a] = [a for a in d.assign() if a.task_id.startswith("B")]
    assert d.fail(a.task_id, give_up=True) is False
    assert a.task_id in d.stuck and d.attempts[a.task_id] == 1
    [b] = [b for b in d.assign() if b.task_id.startswith("B")]
    assert b.task_id != a.task_id
    assert d.fail(b.task_id, count=False) is True and b.task_id not in d.attempts


# -- the UAV -----------------------------------------------------------------------------------------------
class Idle:
    finished = True
    state = "idle"

    def step(self, now_s: float) -> None:
        pass


def test_a_uav_takes_a_spare_of_its_blueprint_in_its_bricks_place_and_refuses_any_other() -> None:
    bp = _bp()
    p = plan(bp)
    bus = InprocBus()
    mc = bus.endpoint(MISSION_CONTROL)
    h = UavHandler(
        "brick-1",
        bus.endpoint("brick-1"),
        tasks=p.tasks,
        spares=bp.spares,
        role="brick",
        wall_digest=wall_digest(bp),
    )
    h.attach(Idle())
    b0 = p.task("B0")
    assert isinstance(b0, BrickTask)
    forged = [
        replace(b0, spare=11, pickup_m=(3.5, 1.0, 0.06)),  # another size
        replace(b0, spare=12, pickup_m=(3.0, 1.0, 0.05)),  # no such spare
        replace(b0, spare=10, pickup_m=(9.0, 9.0, 0.05)),  # not where spare 10 waits
    ]
    for k, task in enumerate(forged):
        mc.send("brick-1", encode(Assign(MISSION_CONTROL, "brick-1", task, 1, 0.0, wall_digest(bp))))
        h.step(0.1 * k)
        assert h.poll_task() is None and "geometry differs" in h.refused[-1]
    refusals = [m for m in map(decode, mc.receive()) if isinstance(m, Result)]
    assert [r.result.status for r in refusals] == ["failed"] * 3
    spare = replace(b0, spare=10, pickup_m=(3.0, 1.0, 0.05))
    message = encode(Assign(MISSION_CONTROL, "brick-1", spare, 1, 1.0, wall_digest(bp)))
    assert decode(message).task == spare  # type: ignore[union-attr]
    mc.send("brick-1", message)
    h.step(1.0)
    assert h.poll_task() == spare


def test_the_walls_digest_covers_its_spares_and_is_unchanged_without_the_key() -> None:
    plain, spared = _bp(""), _bp()
    moved = _bp(SPARES.replace("[3.0, 1.0, 0.05]", "[3.0, 1.5, 0.05]"))
    assert (
        len({wall_digest(plain), wall_digest(spared), wall_digest(moved), wall_digest(_bp("spares: []\n"))})
        == 4
    )
    assert wall_digest(replace(spared, spares=None)) == wall_digest(plain)


def test_the_book_tells_the_sink_of_each_spare_and_each_waiting_brick() -> None:
    events: list[MissionEvent] = []

    def emit(
        now_s: float, kind: str, uav: str | None = None, task_id: str | None = None, **fields: object
    ) -> None:
        events.append(MissionEvent(now_s, kind, uav, task_id, fields))

    book = SpareBook(plan(_bp()), emit=emit)
    book.lost("B0", LOST, 5.0)
    book.failed("B1", NOT_SEEN, 6.0)
    assert [(e.kind, e.task_id, e.fields["spare"], e.fields["brick"]) for e in events] == [
        ("spare", "B0", 10, 0),
        ("spare", "B1", None, 1),
    ]
    assert events[0].line() == "     5.0 s  spare B0: spare 10 for brick 0"
    assert events[1].line() == "     6.0 s  spare B1: waiting for a person: brick 1"
    assert MissionEvent.from_dict(events[1].to_dict()) == events[1]


def test_the_spare_report_survives_the_logs_report_record() -> None:
    book = SpareBook(plan(_bp()))
    book.lost("B0", LOST, 5.5)
    book.failed("B1", NOT_SEEN, 6.25)
    report = book.report()
    assert report is not None
    again = SpareReport.from_record(json.loads(json.dumps(report.to_record())))
    assert again == report and again.lines() == report.lines()
    with pytest.raises(MissionError, match="a spare record is malformed"):
        SpareReport.from_record({"used": [[10, 0, "B0"]], "left": [], "waiting": []})
