"""The reservation table in the log, in ``masonry replay --at`` and on the live page (issue 27, section 3): with
``--airspace table`` the log carries each reservation made, moved and released, and folding them back gives the
table mission control held at every change; under the default ``columns`` airspace the log is as before."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader
from typer.testing import CliRunner

from masonry.blueprint import format_blueprint, load_blueprint
from masonry.cli import app
from masonry.mission.events import EventFanout, EventList, MissionEvent
from masonry.mission.reserved_parts import ahead_of
from masonry.mission.simulate import SimulatedMission
from masonry.mission.table_events import TableWatch, watch_table
from masonry.mission.table_view import TableView
from masonry.mission.view import MissionView, view_at, wall_layout
from masonry.observe.mcap_log import McapLog, read_log
from masonry.observe.web import ViewServer
from masonry.planner import plan as make_plan
from masonry.reservation import Reservation, Table, column, leg, pad

ROOT = Path(__file__).resolve().parents[1]
CASE_STUDY = ROOT / "blueprints" / "paper_case_study.yaml"
CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
runner = CliRunner()


@pytest.fixture(scope="module")
def table_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """One ``masonry sim --airspace table --log`` run of the case study, and its JSON report."""
    d = tmp_path_factory.mktemp("table")
    log = d / "run.mcap"
    res = runner.invoke(
        app,
        [
            "sim",
            str(CASE_STUDY),
            "--airspace",
            "table",
            "--log",
            str(log),
            "--format",
            "json",
            "--no-progress",
        ],
    )
    assert res.exit_code == 0, res.output
    return {"log": log, "report": json.loads(res.stdout)}


def _reservations(log: Path) -> list[MissionEvent]:
    return [e for e in read_log(log).events if e.kind == "reservation"]


# -- the watch over a table (pure) -------------------------------------------------------------------------------


def test_the_watch_reports_made_moved_and_released_with_ids_and_is_silent_when_a_window_just_ends():
    events = EventList()
    watch = TableWatch(lambda: events, task_of={"u1": "B0"}.get)
    home = Reservation("u1", pad((0.0, 0.0)), 0.0, math.inf, "stay")
    climb = Reservation("u1", column((0.0, 0.0), 0.0, 2.0), 1.0, 5.0, "climb")
    other = Reservation("u2", leg((5.0, 0.0), (9.0, 0.0), 2.0), 0.0, 20.0, "transit", task="A0")
    watch(Table((home, other)), 0.0)
    watch(
        Table((home.until(1.0), climb, other)), 0.5
    )  # u1 sets off at 1 s: its stay shortened, its climb made
    watch(Table((home.until(1.0), climb.shifted(2.0), other)), 0.8)  # its climb moved 2 s later
    watch(Table((climb.shifted(2.0), other.until(2.0))), 2.0)  # u2 cut to now: released; u1's stay just ended
    watch(Table((other.until(2.0),)), 2.5)  # u1's climb dropped before it began (3 s): released
    watch(Table((other.until(2.0),)), 3.0)  # no change: nothing
    got = [
        (e.time_s, e.fields["change"], e.fields["id"], e.uav, e.task_id, e.fields["purpose"])
        for e in events.events
    ]
    assert got == [  # (ids in the order made, by start)
        (0.0, "made", 1, "u2", "A0", "transit"),
        (0.0, "made", 2, "u1", "B0", "stay"),
        (0.5, "moved", 2, "u1", "B0", "stay"),
        (0.5, "made", 3, "u1", "B0", "climb"),
        (0.8, "moved", 3, "u1", "B0", "climb"),
        (2.0, "released", 1, "u2", "A0", "transit"),
        (2.5, "released", 3, "u1", "B0", "climb"),
    ]
    moved = events.events[4].fields
    assert (moved["t0_s"], moved["t1_s"], moved["was"]) == (3.0, 7.0, [1.0, 5.0])
    assert events.events[2].fields["t1_s"] == 1.0 and events.events[2].fields["was"] == [0.0, None]
    assert events.events[1].fields["t1_s"] is None and events.events[1].fields["space"] == "ground"
    assert events.events[6].fields["t1_s"] == 3.0  # released before it began: its window is empty
    view = TableView()
    for e in events.events:
        view.fold(e)
    assert [h.id for h in view.at(3.0)] == [] and len(view.rows()) == 3


def test_a_watch_with_no_sink_reports_everything_once_one_comes():
    events = EventList()
    sink: list[EventList | None] = [None]
    watch = TableWatch(lambda: sink[0])
    r = Reservation("u1", pad((0.0, 0.0)), 0.0, math.inf, "stay")
    watch(Table((r,)), 0.0)
    sink[0] = events
    watch(Table((r, Reservation("u2", pad((3.0, 0.0)), 1.0, math.inf, "stay"))), 1.0)
    assert [(e.uav, e.fields["change"]) for e in events.events] == [("u1", "made"), ("u2", "made")]


def test_the_columns_airspace_has_no_table_to_watch():
    mission = SimulatedMission.from_blueprint(load_blueprint(CASE_STUDY), seed=0)
    assert watch_table(mission.control) is None


# -- the log of a mission ----------------------------------------------------------------------------------------


def test_the_log_of_a_table_mission_folds_back_to_the_table_mission_control_held_at_every_change(tmp_path):
    bp = load_blueprint(CASE_STUDY)
    plan = make_plan(bp)
    log = McapLog(tmp_path / "run.mcap", plan, format_blueprint(bp), title="case").open()
    seen = EventList()
    mission = SimulatedMission.from_blueprint(
        bp, seed=0, airspace="table", events_sink=EventFanout(log, seen)
    )
    columns = mission.control.columns
    watch = columns.on_change
    live: list[tuple[float, int, Table]] = []  # (time, reservation events so far, the table then)

    def spy(table: Table, now_s: float) -> None:
        watch(table, now_s)
        live.append((now_s, sum(e.kind == "reservation" for e in seen.events), table))

    columns.on_change = spy
    report = mission.run()
    log.finish(report)
    log.close()
    assert report.completed
    logged = _reservations(tmp_path / "run.mcap")
    assert [e.to_dict() for e in logged] == [e.to_dict() for e in seen.events if e.kind == "reservation"]
    changes = {str(e.fields["change"]) for e in logged}
    assert changes == {"made", "moved", "released"}, changes
    assert len(live) > 50

    def key(uav: str, purpose: str, t0: float, t1: float, volume: tuple[float, ...]) -> tuple[object, ...]:
        return (
            uav,
            purpose,
            round(t0, 6),
            round(t1, 6) if math.isfinite(t1) else None,
            tuple(round(v, 6) for v in volume),
        )

    view, folded = TableView(), 0
    for now_s, count, table in live:
        while folded < count:
            view.fold(logged[folded])
            folded += 1
        from_log = sorted(key(h.uav, h.purpose, h.t0_s, h.t1_s, h.volume) for h in view.at(now_s))
        held = sorted(
            key(
                r.uav,
                r.purpose,
                r.t0_s,
                r.t1_s,
                (*r.volume.a, *r.volume.b, r.volume.z0_m, r.volume.z1_m, r.volume.radius_m),
            )
            for r in table.reservations
            if r.t1_s > now_s
        )
        assert from_log == held, f"at {now_s:.1f} s the log's table is not mission control's"


def test_the_log_shows_each_tasks_flight_reserved_by_its_uav_during_its_attempt(table_run):
    report = table_run["report"]
    events = _reservations(table_run["log"])
    assert report["completed"] is True
    with open(
        table_run["log"], "rb"
    ) as f:  # its own topic, each message valid against the schema in the file
        reader = make_reader(f)
        for schema, _channel, message in reader.iter_messages(topics=["/mission/reservations"]):
            assert schema is not None and schema.name == "masonry.MissionEvent"
            errors = list(
                jsonschema.Draft7Validator(json.loads(schema.data)).iter_errors(json.loads(message.data))
            )
            assert not errors, errors[0].message
    with open(table_run["log"], "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    assert "/mission/reservations" in {c.topic for c in summary.channels.values()}
    first: dict[int, str] = {}
    for e in events:  # every reservation is made first, then moved or released, and nothing after its release
        rid = int(e.fields["id"])
        assert first.setdefault(rid, str(e.fields["change"])) == "made", e.line()
        assert first[rid] != "gone", f"reservation {rid} changed after its release: {e.line()}"
        if e.fields["change"] == "released":
            first[rid] = "gone"
            # (cut to end now, or, not begun yet, to an empty window at its start)
            assert e.fields["t1_s"] is not None and e.fields["t1_s"] <= max(e.fields["t0_s"], e.time_s) + 1e-9
        if e.fields["change"] == "made":
            assert e.fields["t0_s"] >= e.time_s - 1e-9  # nothing is reserved in the past
    for task in report["tasks"]:
        flights = {
            str(e.fields["purpose"])
            for e in events
            if e.task_id == task["id"]
            and e.fields["change"] == "made"
            and task["start_s"] <= e.time_s <= task["end_s"]
        }
        assert {"climb", "transit", "descend"} <= flights, (task["id"], flights)
        assert {e.uav for e in events if e.task_id == task["id"]} == {task["uav"]}
    end = view_at(read_log(table_run["log"]).events, 1e6)
    held = end.table.at(end.time_s)  # at the end each UAV holds one open-ended stay: where it stays
    assert sorted(h.uav for h in held) == ["brick-1", "glue-1"]
    assert all(h.purpose == "stay" and math.isinf(h.t1_s) for h in held)


def test_replay_at_prints_the_reservation_table_then(table_run):
    b0 = next(t for t in table_run["report"]["tasks"] if t["id"] == "B0")
    events = _reservations(table_run["log"])
    flight = next(e for e in events if e.task_id == "B0" and e.fields["purpose"] == "transit")
    at = flight.time_s + 0.05
    res = runner.invoke(app, ["replay", str(table_run["log"]), "--at", str(at)])
    assert res.exit_code == 0, res.output
    lines = res.stdout.splitlines()
    head = next(i for i, line in enumerate(lines) if line.strip().startswith("reservation table:"))
    n = int(lines[head].split(":", 1)[1].split()[0])
    table = lines[head + 1 : head + 1 + n]
    assert n >= 4 and all(line.startswith("    ") for line in table)
    mine = [line.split() for line in table if line.split()[0] == "brick-1"]
    assert {"climb", "transit", "descend", "stay"} <= {row[1] for row in mine}
    assert all(row[2] == "B0" for row in mine if row[1] in ("climb", "transit", "descend"))
    transit = next(line for line in table if line.split()[:3] == ["brick-1", "transit", "B0"])
    assert f"{flight.fields['t0_s']:8.1f} s -> " in transit and "along (" in transit
    assert lines[0].startswith(f"at {at:.1f} s:") and b0["start_s"] <= at <= b0["end_s"]
    after = runner.invoke(app, ["replay", str(table_run["log"]), "--at", "1e6"])
    assert "reservation table: 2 held" in after.stdout


def test_the_default_columns_airspace_logs_no_table_and_replays_as_before(tmp_path):
    log = tmp_path / "run.mcap"
    res = runner.invoke(app, ["sim", str(CASE_STUDY), "--log", str(log), "--no-progress"])
    assert res.exit_code == 0, res.output
    with open(log, "rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None and "/mission/reservations" not in {c.topic for c in summary.channels.values()}
    assert _reservations(log) == []
    at = runner.invoke(app, ["replay", str(log), "--at", "30"])
    assert at.exit_code == 0 and "reservation table" not in at.stdout
    again = runner.invoke(app, ["replay", str(log)])
    assert again.exit_code == 0 and again.stdout == res.stdout
    assert "reservations" not in view_at(read_log(log).events, 30.0).snapshot()


# -- the live page -----------------------------------------------------------------------------------------------


def test_the_page_state_carries_the_reserved_windows_for_the_timeline(table_run):
    events = read_log(table_run["log"]).events
    view = MissionView()
    for e in events:
        view.emit(e)
    rows = view.snapshot()["reservations"]
    assert {r["uav"] for r in rows} == {"brick-1", "glue-1"}
    assert {"climb", "transit", "descend", "stay"} <= {r["purpose"] for r in rows}
    assert any(r["released"] for r in rows) and any(r["t1_s"] is None for r in rows)
    assert not any(
        "reservation" in line for line in view.snapshot()["recent"]
    )  # (the log's lines stay readable)


@pytest.mark.slow
def test_the_page_draws_a_timeline_of_reserved_windows_under_the_gantt_in_chromium(table_run, tmp_path):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium; .ci/run does it where it can)")
    from playwright.sync_api import sync_playwright

    recorded = read_log(table_run["log"])
    bp = load_blueprint(CASE_STUDY)
    plan = make_plan(bp)
    ids = [t.id for t in plan.tasks]
    end_s = max(e.time_s for e in recorded.events)
    b0_transit = next(
        e
        for e in recorded.events
        if e.kind == "reservation" and e.task_id == "B0" and e.fields["purpose"] == "transit"
    )
    server = ViewServer(
        "127.0.0.1",
        0,
        layout=wall_layout(plan, bp.fleet, "case"),
        state=lambda t: view_at(recorded.events, end_s if t is None else t, ids).snapshot(),
        version=lambda: 0,
        replay=end_s,
    )
    with server, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server.url)
        page.wait_for_selector("#reserved rect.res")
        at = b0_transit.time_s + 0.05
        page.evaluate(f"const s = document.getElementById('slider'); s.value = {at}; s.oninput()")
        page.wait_for_function(f"document.getElementById('clock').textContent === 't = {at:.1f} s'")
        assert page.is_visible("#reserved-box")
        # a row per UAV, brick-1's flight to B0 among its windows (its title says so), the line of now
        for uav in ("brick-1", "glue-1"):
            assert page.locator(f"#reserved rect.res[data-uav={uav}]").count() >= 2
        titles = page.locator("#reserved rect.res.transit[data-uav=brick-1] title").all_text_contents()
        assert any(
            t.startswith(f"brick-1 transit for B0: {b0_transit.fields['t0_s']:.1f} s to ") for t in titles
        ), titles
        assert page.locator("#reserved line.now").count() == 1
        # under the Gantt chart, on its time axis
        gantt, reserved = page.locator("#gantt").bounding_box(), page.locator("#reserved").bounding_box()
        assert gantt is not None and reserved is not None and reserved["y"] > gantt["y"] + gantt["height"]
        page.screenshot(path=str(tmp_path / "page.png"), full_page=True)
        browser.close()
    assert errors == []


@pytest.mark.slow
def test_the_page_hides_the_timeline_without_a_table():
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium; .ci/run does it where it can)")
    from playwright.sync_api import sync_playwright

    bp = load_blueprint(CASE_STUDY)
    plan = make_plan(bp)
    view = MissionView([t.id for t in plan.tasks])
    view.emit(MissionEvent(1.0, "assigned", "glue-1", "A0", {"attempt": 1}))
    server = ViewServer(
        "127.0.0.1",
        0,
        layout=wall_layout(plan, bp.fleet, "case"),
        state=lambda _t: view.snapshot(),
        version=lambda: view.events,
    )
    with server, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page()
        page.goto(server.url)
        page.wait_for_selector("#gantt rect.bar")
        assert not page.is_visible("#reserved-box") and page.locator("#reserved rect").count() == 0
        browser.close()


def test_a_leg_cut_to_what_lies_ahead_of_its_uav_is_logged_moved_not_made_in_the_past():
    # table49's leg cut (reserved_parts.ahead_of) keeps the leg's window with a shorter volume: logged as a new
    # reservation, it was "made" with its window begun in the past
    watch = TableWatch(lambda: None)
    r = Reservation("a", leg((0.0, 0.0), (4.0, 0.0), 2.3), 1.0, 9.0, "transit")
    assert [e.fields["change"] for e in watch.changes(Table((r,)), 1.0)] == ["made"]
    cut = ahead_of(r, (2.0, 0.0, 2.3))
    (e,) = watch.changes(Table((cut,)), 5.0)
    assert e.fields["change"] == "moved" and e.fields["id"] == 1 and e.fields["t0_s"] == 1.0
    assert e.fields["volume"][:2] == pytest.approx([cut.volume.a[0], 0.0]) and cut.volume.a[0] > 1.0
