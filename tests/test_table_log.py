"""The reservation table in the log, in ``masonry replay --at`` and on the live page (issue 27, section 3): with
``--airspace table`` the log carries each reservation made, moved and released, and folding them back gives the
table mission control held at every change; under the default ``columns`` airspace the log is as before."""

from __future__ import annotations

import json
import math
import shutil
from collections.abc import Sequence
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
from masonry.reservation import Reservation, Table, column, leg, pad, with_holds

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


def _replay_server(events: Sequence[MissionEvent]) -> tuple[ViewServer, float]:
    """The live page replaying a logged case-study mission (as ``masonry replay --serve`` does), and its end."""
    bp = load_blueprint(CASE_STUDY)
    plan = make_plan(bp)
    ids = [t.id for t in plan.tasks]
    end_s = max(e.time_s for e in events)
    server = ViewServer(
        "127.0.0.1",
        0,
        layout=wall_layout(plan, bp.fleet, "case"),
        state=lambda t: view_at(events, end_s if t is None else t, ids).snapshot(),
        version=lambda: 0,
        replay=end_s,
    )
    return server, end_s


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
    server, _end_s = _replay_server(recorded.events)
    b0_transit = next(
        e
        for e in recorded.events
        if e.kind == "reservation" and e.task_id == "B0" and e.fields["purpose"] == "transit"
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


# -- the holds on take-offs (the operator's pause and recall, the wind limit) --------------------------------------


def test_the_watch_reports_a_hold_made_and_released_with_its_cause_uavs_and_window():
    events = EventList()
    watch = TableWatch(lambda: events)
    stay = Reservation("u1", pad((0.0, 0.0)), 0.0, math.inf, "stay")
    watch(Table((stay,)), 0.0)
    paused = with_holds(Table((stay,)), {("operator", frozenset())}, 5.0)
    watch(paused, 5.0)  # the reservations the same, a hold made: reported
    both = with_holds(paused, {("operator", frozenset()), ("wind", frozenset({"u1"}))}, 7.0)
    watch(both, 7.0)
    watch(with_holds(both, {("wind", frozenset({"u1"}))}, 9.0), 9.0)  # the pause lifted
    watch(with_holds(both, {("wind", frozenset({"u1"}))}, 9.0), 9.5)  # no change: nothing
    holds = [e for e in events.events if e.kind == "hold"]
    got = [
        (e.time_s, e.fields["change"], e.fields["id"], e.uav, e.fields["cause"], e.fields["uavs"])
        for e in holds
    ]
    assert got == [
        (5.0, "made", 1, None, "operator", []),
        (7.0, "made", 2, "u1", "wind", ["u1"]),
        (9.0, "released", 1, None, "operator", []),
    ]
    assert (holds[0].fields["t0_s"], holds[0].fields["t1_s"]) == (5.0, None)
    assert (holds[2].fields["t0_s"], holds[2].fields["t1_s"]) == (5.0, 9.0)
    assert "operator on every UAV from 5.0 s to until lifted" in holds[0].line()
    view = TableView()
    for e in events.events:
        view.fold(e)
    assert [h.cause for h in view.holds_at(6.0)] == ["operator"]
    assert [h.cause for h in view.holds_at(9.5)] == ["wind"]
    assert [(r["cause"], r["uavs"], r["t1_s"], r["released"]) for r in view.hold_rows()] == [
        ("operator", [], 9.0, True),
        ("wind", ["u1"], None, False),
    ]
    assert view.lines(9.5)[-2:] == [
        "  holds on take-offs: 1",
        f"    {'wind':<12} holds u1 on the ground      7.0 s -> until lifted",
    ]


PAUSE_S, RESUME_S = 20.0, 90.0


@pytest.fixture(scope="module")
def paused_run(tmp_path_factory: pytest.TempPathFactory) -> dict[str, object]:
    """The case study under the table with ``--log``, paused at 20 s and resumed at 90 s (as
    tests/test_table_holds.py flies it): its log and report."""
    bp = load_blueprint(CASE_STUDY)
    path = tmp_path_factory.mktemp("paused") / "run.mcap"
    log = McapLog(path, make_plan(bp), format_blueprint(bp), title="case").open()
    mission = SimulatedMission.from_blueprint(bp, seed=0, airspace="table", events_sink=log)
    pending = [(PAUSE_S, {"command": "pause"}), (RESUME_S, {"command": "resume"})]

    def operator(now_s: float) -> None:
        while pending and now_s >= pending[0][0]:
            mission.control.operator.submit(pending.pop(0)[1], lambda out: None)

    mission.tick_hooks.append(operator)
    report = mission.run()
    log.finish(report)
    log.close()
    assert report.completed
    return {"log": path, "report": report}


def test_a_pause_under_the_table_is_logged_as_a_hold_made_and_released(paused_run):
    events = read_log(paused_run["log"]).events
    holds = [e for e in events if e.kind == "hold"]
    assert [(e.fields["change"], e.fields["cause"], e.fields["uavs"], e.uav) for e in holds] == [
        ("made", "operator", [], None),
        ("released", "operator", [], None),
    ]
    made, released = holds
    assert PAUSE_S <= made.time_s < PAUSE_S + 0.5 and made.fields["t0_s"] == made.time_s
    assert RESUME_S <= released.time_s < RESUME_S + 0.5
    assert released.fields["t1_s"] == released.time_s and released.fields["id"] == made.fields["id"] == 1
    with open(paused_run["log"], "rb") as f:  # on the table's topic, valid against its schema
        reader = make_reader(f)
        on_topic = []
        for schema, _channel, message in reader.iter_messages(topics=["/mission/reservations"]):
            data = json.loads(message.data)
            assert schema is not None and not list(
                jsonschema.Draft7Validator(json.loads(schema.data)).iter_errors(data)
            )
            on_topic.append(data["kind"])
    assert on_topic.count("hold") == 2 and "reservation" in on_topic
    with open(paused_run["log"], "rb") as f:
        kinds = {
            json.loads(m.data)["kind"]
            for _s, _c, m in make_reader(f).iter_messages(topics=["/mission/events"])
        }
    assert "hold" not in kinds and "operator" in kinds  # (the command itself stays an operator event)


def test_replay_at_prints_the_holds_standing_then(paused_run):
    during = runner.invoke(app, ["replay", str(paused_run["log"]), "--at", "50"])
    assert during.exit_code == 0, during.output
    lines = during.stdout.splitlines()
    head = lines.index("  holds on take-offs: 1")
    assert lines[head + 1].split()[:6] == ["operator", "holds", "every", "UAV", "on", "the"]
    assert lines[head + 1].endswith("-> until lifted")
    after = runner.invoke(app, ["replay", str(paused_run["log"]), "--at", str(RESUME_S + 1.0)])
    assert after.exit_code == 0 and "holds on take-offs" not in after.stdout
    before = runner.invoke(app, ["replay", str(paused_run["log"]), "--at", "10"])
    assert before.exit_code == 0 and "holds on take-offs" not in before.stdout


def test_the_page_state_carries_the_holds_for_the_timeline(paused_run, table_run):
    rows = view_at(read_log(paused_run["log"]).events, 1e6).snapshot()["holds"]
    assert len(rows) == 1 and rows[0]["cause"] == "operator" and rows[0]["uavs"] == [] and rows[0]["released"]
    assert rows[0]["t0_s"] >= PAUSE_S and rows[0]["t1_s"] >= RESUME_S
    assert (
        view_at(read_log(table_run["log"]).events, 1e6).snapshot()["holds"] == []
    )  # (none made: none drawn)


@pytest.mark.slow
def test_the_page_draws_a_hold_over_the_rows_of_the_uavs_it_holds_in_chromium(paused_run):
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium; .ci/run does it where it can)")
    from playwright.sync_api import sync_playwright

    recorded = read_log(paused_run["log"])
    server, end_s = _replay_server(recorded.events)
    with server, sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=["--no-sandbox"])
        page = browser.new_page(viewport={"width": 1400, "height": 1000})
        errors: list[str] = []
        page.on("pageerror", lambda e: errors.append(str(e)))
        page.goto(server.url)
        page.wait_for_selector("#reserved rect.res")
        for at, drawn in ((10.0, 0), (50.0, 1)):
            page.evaluate(f"const s = document.getElementById('slider'); s.value = {at}; s.oninput()")
            page.wait_for_function(f"document.getElementById('clock').textContent === 't = {at:.1f} s'")
            for uav in ("brick-1", "glue-1"):  # a pause holds every UAV: over each row
                assert page.locator(f"#reserved rect.hold.operator[data-uav={uav}]").count() == drawn
        titles = page.locator("#reserved rect.hold.operator title").all_text_contents()
        assert all(t.startswith("operator holds every UAV on the ground: ") for t in titles), titles
        assert all(t.endswith("until lifted") for t in titles), titles  # (at 50 s it is not lifted yet)
        page.evaluate(f"const s = document.getElementById('slider'); s.value = {end_s}; s.oninput()")
        page.wait_for_function("document.querySelectorAll('#reserved rect.hold.released').length === 2")
        browser.close()
    assert errors == []
